"""The timeline (issue 14): its range is the run so far and its thumb the time shown; dragging it pauses at that
time (drawn from the stored run, nothing recomputed), Play goes on from there, Reset starts it again."""

from __future__ import annotations

import pytest

from conftest import wait_until
from physics import LinkageError


def test_the_timeline_follows_scrubs_back_and_plays_on(connect):
    _, session = connect()
    session.play()
    timeline = session.timeline  # the one session's Timeline slider
    assert wait_until(lambda: session.snapshot()["time"] > 2.0, timeout=30)
    assert wait_until(lambda: timeline.max > 1.5 and timeline.value > 1.5, timeout=5), (timeline.max, timeline.value)
    furthest = timeline.max

    timeline.value = 1.0  # what a browser's drag does
    assert wait_until(lambda: session.snapshot()["time"] == pytest.approx(1.0, abs=1e-9), timeout=10)
    assert not session.player.playing
    theta_at_1 = session.snapshot()["runs"][0]["theta"]
    assert timeline.max >= furthest  # the run so far is still there to go forward again

    session.play()
    assert wait_until(lambda: session.snapshot()["time"] > 1.3, timeout=10)
    session.scrub(1.0)
    assert wait_until(lambda: session.snapshot()["time"] == pytest.approx(1.0, abs=1e-9), timeout=10)
    assert session.snapshot()["runs"][0]["theta"] == pytest.approx(theta_at_1, abs=1e-12)  # the same stored run

    with pytest.raises(LinkageError, match="timeline"):
        session.scrub(float("nan"))
    session.reset()
    session.play()
    assert wait_until(lambda: timeline.max < furthest, timeout=10)  # a new run, a new range


def test_a_new_start_clears_the_old_trace_and_plots_until_its_first_frame(connect):
    """Issue 14 item 9: while a cold cache derives a new mechanism, the old trace and plots stayed beside it."""
    _, session = connect()
    session.play()
    assert wait_until(lambda: session.trace.points_shown > 10 and session.energy_plot.points_shown > 10, timeout=30)
    session.pause()
    session.player.wait_idle(30)
    with session.player.lock:  # no frame may come in between: as while the new equations are derived
        session.set_mechanism("double")  # a new mechanism: the chain session's view.show_start
        assert session.trace.points_shown == 0 and not session.trace.handle.visible
        assert session.energy_plot.points_shown == 0 and session.drift_plot.points_shown == 0
