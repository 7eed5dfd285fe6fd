"""Rest positions (issue 15), the panel's "Rest positions" folder: the list matches physics, and a jump starts
from the rest chosen."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import wait_until
from physics import LinkageError
from physics.rest_positions import rest_positions


def find(session):
    session.rests.find()  # the Display tab's "Find rest positions" (what its button calls)
    session.rests.wait()
    return session.rests


def angles(rest) -> np.ndarray:
    """A rest pose's bar angles: the chain's bodies turn from its sketch hanging down, so each body's rotation
    (every third coordinate of the pose) is its bar's angle from the downward vertical, in (-pi, pi]."""
    return np.angle(np.exp(1j * np.asarray(rest.q[2::3], dtype=float)))


def max_omega_over(session, seconds: float) -> float:
    """The largest bar rate the run has stored (its samples computed ahead too) once ``seconds`` are shown: each
    body's rotation rate (every third speed of the run) is its bar's omega."""
    assert session.player.wait_idle(60)  # the restart from the rest has been installed
    run = session.player.runs[0]
    assert np.allclose(run.ring.get("qdot", 0), 0.0) and run.ring.get("t", 0) == 0.0
    assert wait_until(lambda: session.snapshot()["time"] > seconds, timeout=120)
    data = run.ring.window(0, len(run.ring) - 1, names=["qdot"])
    return float(np.max(np.abs(data["qdot"][:, 2::3])))


def test_the_list_is_physics_rest_positions_and_a_stable_rest_stays_still(connect):
    _, session = connect()
    session.set_mechanism("four-bar")
    panel = find(session)
    expected = rest_positions(session.params.chain)
    assert len(panel.rests) == len(expected) >= 2
    for found, rest in zip(panel.rests, expected):  # the same rests, lowest potential first
        assert np.allclose(angles(found), np.angle(np.exp(1j * rest.theta)), atol=1e-6)
        assert found.stable == rest.stable and found.potential == pytest.approx(rest.potential, abs=1e-9)
    assert panel.choice.options[0].startswith("1: stable")
    stable = next(k for k, r in enumerate(panel.rests) if r.stable)
    panel.choice.value = panel.choice.options[stable]
    panel.go.value = "Go and play"  # viser runs the button group's callback
    assert wait_until(lambda: session.player.playing
                      and np.allclose(session.params.theta0, angles(panel.rests[stable]), atol=1e-12))
    assert np.all(session.params.omega0 == 0.0)
    assert max_omega_over(session, 3.0) < 1e-6


def test_an_unstable_rest_is_set_exactly_and_a_nudge_shows_it_unstable(connect):
    _, session = connect()
    session.set_mechanism("double")
    panel = find(session)
    unstable = len(panel.rests) - 1  # the highest: both bars straight up
    assert not panel.rests[unstable].stable
    panel.jump(unstable, play=False)
    assert session.player.wait_idle(60)
    assert not session.player.playing
    theta = panel.rests[unstable].q[2::3]  # the bodies' turns from the sketch hanging down: the bar angles
    assert np.array_equal(session.params.theta0, theta)  # set exactly
    assert np.allclose(np.abs(angles(panel.rests[unstable])), np.pi)  # both bars straight up
    session.set_start(theta + np.array([1e-3, 0.0]), np.zeros_like(theta), play=True)  # the nudge
    # a 1e-3 rad nudge from a stable rest swings at most ~ 1e-3 * sqrt(g / L) ~ 3e-3 rad/s; here it falls over
    assert max_omega_over(session, 4.0) > 0.5


def test_a_stale_list_is_refused(connect):
    _, session = connect()
    panel = find(session)
    session.set("m1", 2.0)
    with pytest.raises(LinkageError, match="press 'Find rest positions' again"):
        panel.jump(0)
    session.set_mechanism("double")
    assert panel.rests == []
