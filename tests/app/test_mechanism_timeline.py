"""The timeline of a general mechanism (issue 24: every feature of the chain panel for any mechanism): its range
is the run so far and its thumb the time shown; dragging it pauses there (drawn from the stored run, nothing
recomputed), Play goes on from there, Reset starts it again."""

from __future__ import annotations

import pytest

from conftest import lab_of, wait_until
from physics import LinkageError

crank_lab = lab_of("slider-crank")


def test_the_mechanisms_timeline_follows_scrubs_back_and_plays_on(crank_lab, connect):
    _, session = connect(crank_lab)
    session.play()
    timeline = session.timeline
    assert wait_until(lambda: session.snapshot()["time"] > 2.0, timeout=60)
    assert wait_until(lambda: timeline.max > 1.5 and timeline.value > 1.5, timeout=10), (timeline.max, timeline.value)
    furthest = timeline.max

    timeline.value = 1.0  # what a browser's drag does
    assert wait_until(lambda: session.snapshot()["time"] == pytest.approx(1.0, abs=1e-9), timeout=10)
    assert not session.player.playing
    q_at_1 = session.snapshot()["q"]
    assert timeline.max >= furthest  # the run so far is still there to go forward again

    session.play()
    assert wait_until(lambda: session.snapshot()["time"] > 1.3, timeout=10)
    session.scrub(1.0)
    assert wait_until(lambda: session.snapshot()["time"] == pytest.approx(1.0, abs=1e-9), timeout=10)
    assert session.snapshot()["q"] == pytest.approx(q_at_1, abs=1e-12)  # the same stored run

    with pytest.raises(LinkageError, match="timeline"):
        session.scrub(float("nan"))
    session.guard(lambda: session.scrub("later"))
    assert "timeline" in (session.notices.text or "")
    session.reset()
    session.play()
    assert wait_until(lambda: timeline.max < furthest, timeout=20)  # a new run, a new range
