"""Rest positions of a general mechanism (issue 24): the chain's panel (app/rest_view.py) in the mechanism's
Display tab, listing physics' rest poses (the ``equilibrium`` command's) with their stability, and a jump that
starts from the one chosen; a mechanism with nothing free to rest (the Jansen leg's turning motor) says why."""

from __future__ import annotations

import numpy as np
import pytest

from app.session import Session
from conftest import lab_of, wait_until
from physics import LinkageError
from physics.mechanism.statics import rest_poses

slider_lab = lab_of("slider-crank")
jansen_lab = lab_of("jansen-leg")


def find(session):
    session.rests.find()
    session.rests.wait()
    return session.rests


def max_speed_over(session, seconds: float) -> float:
    """The largest |qdot| of the run started from the rest, over its first ``seconds``."""
    assert session.player.wait_idle(60)  # the restart from the rest has been installed
    run = session.player.runs[0]
    assert np.allclose(run.ring.get("qdot", 0), 0.0) and run.ring.get("t", 0) == 0.0
    assert wait_until(lambda: session.snapshot()["time"] > seconds, timeout=120)
    data = run.ring.window(0, len(run.ring) - 1, names=["qdot"])
    return float(np.max(np.abs(data["qdot"])))


def test_the_list_is_physics_rest_poses_and_a_stable_one_stays_still(slider_lab, connect):
    _, session = connect(slider_lab)
    assert isinstance(session, Session)
    panel = find(session)
    expected = rest_poses(session.mechanism)
    assert len(panel.rests) == len(expected) >= 2
    for shown, pose in zip(panel.rests, expected):
        assert shown.stable == pose.stable and np.allclose(shown.q, pose.q, atol=1e-12)
    options = list(panel.choice.options)
    assert options[0].startswith("1: stable") and any(": unstable" in o for o in options)
    assert "stable)" in panel.status.content
    stable = next(k for k, r in enumerate(panel.rests) if r.stable)
    panel.choice.value = options[stable]
    panel.go.value = "Go and play"
    assert wait_until(lambda: session.player.playing and np.allclose(session.q0, panel.rests[stable].q))
    assert np.all(session.qdot0 == 0.0)
    assert max_speed_over(session, 3.0) < 1e-6


def test_an_unstable_rest_is_set_exactly_paused_and_a_stale_list_is_refused(slider_lab, connect):
    _, session = connect(slider_lab)
    panel = find(session)
    unstable = next(k for k, r in enumerate(panel.rests) if not r.stable)
    session.guard(lambda: panel.jump(unstable, play=False))
    assert session.player.wait_idle(60)
    assert not session.player.playing
    assert np.array_equal(session.q0, panel.rests[unstable].q)
    assert np.array_equal(session.player.runs[0].ring.get("q", 0), panel.rests[unstable].q)
    session.set_typed("g", "5")
    with pytest.raises(LinkageError, match="press 'Find rest positions' again"):
        panel.jump(0)


def test_a_mechanism_with_a_turning_motor_says_why_it_has_no_rest(jansen_lab, connect):
    """The Jansen leg's motor turns at a set speed: no pose stays at rest (physics' refusal, shown in the panel)."""
    _, session = connect(jansen_lab)
    panel = find(session)
    assert panel.rests == []
    assert panel.status.content.startswith("No list:") and "speed motor" in panel.status.content
    with pytest.raises(LinkageError, match="press 'Find rest positions' first"):
        panel.index_of("1: stable")


def test_another_mechanism_clears_the_list_and_a_reset_keeps_it(slider_lab, connect):
    _, session = connect(slider_lab)
    panel = find(session)
    assert panel.rests
    session.guard(session.reset)
    assert panel.rests and panel.choice.options[0].startswith("1: stable")  # the same mechanism: still applies
    session.guard(lambda: session.choose("watt-six-bar"))
    assert wait_until(lambda: session.mechanism.name == "watt-six-bar", timeout=60)
    assert panel.rests == [] and tuple(panel.choice.options) == ("(press Find)",)
    assert "--preset watt-six-bar --body" in session.free_body_help.content
