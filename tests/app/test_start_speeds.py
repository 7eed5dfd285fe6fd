"""Initial angular velocity sliders (issue 14): ω₀ per bar in degrees per second; a closed loop takes the first
ones and the others follow the loop (its velocity constraint holds); the run starts with them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import wait_until
from physics.loop_closure import driving_range, loop_jacobian


def sliders(session) -> dict:
    """The generated controls' sliders by name (``theta1``, ``omega2``, ``L1`` ...) of the one session's panel."""
    return session._knob_handles  # noqa: SLF001 - the panel's own handles


def test_an_open_chain_starts_with_the_speeds_set_on_the_sliders(connect):
    _, session = connect()
    session.set_mechanism("triple-a")
    controls = sliders(session)
    assert all(not controls[f"omega{k}"].disabled for k in (1, 2, 3))
    controls["omega2"].value = 120.0
    session.set_typed("omega3", "-1e2")
    assert session.params.omega0 == pytest.approx(np.radians([0.0, 120.0, -100.0]))
    assert controls["omega3"].value == -100.0
    expected = np.radians([0.0, 120.0, -100.0])

    def started_with_them() -> bool:
        omega = session.history()["omega"]
        return omega.shape[0] > 0 and bool(np.allclose(omega[0], expected, atol=1e-9, rtol=0))

    assert wait_until(started_with_them, timeout=30), session.history()["omega"][:1]


def test_a_closed_loop_takes_its_first_speed_and_the_others_follow_the_loop(connect):
    _, session = connect()
    session.set_mechanism("four-bar")
    controls = sliders(session)
    assert not controls["omega1"].disabled
    # the speeds the loop sets are shown, greyed out and saying so (the chain panel showed them)
    assert {"omega2", "omega3"} <= set(controls), f"no omega2/omega3 sliders: {sorted(controls)}"
    assert controls["omega2"].disabled and controls["omega3"].disabled
    assert "follows the loop" in controls["omega2"].label
    controls["omega1"].value = 90.0
    p = session.params
    assert p.omega0[0] == pytest.approx(math.radians(90.0))
    residual = loop_jacobian(np.array(p.L), p.theta0) @ p.omega0
    assert np.max(np.abs(residual)) < 1e-9 and abs(p.omega0[1]) > 0.01
    shown = [controls[f"omega{k}"].value for k in (2, 3)]
    assert shown == pytest.approx(np.degrees(p.omega0[1:]), abs=2.5)  # on the slider's 5 °/s step
    with pytest.raises(Exception, match="this mechanism takes only omega1"):
        session.set("omega2", 10.0)


def test_the_status_line_says_paused_at_once(connect):
    """A paused player draws no new frame; the status line used to say "(playing)" until the next change."""
    _, session = connect()
    session.play()
    assert wait_until(lambda: "(playing)" in session.status.content, timeout=30)
    session.pause()
    assert wait_until(lambda: "(paused)" in session.status.content, timeout=2), \
        session.status.content
    session.play()
    assert wait_until(lambda: "(playing)" in session.status.content, timeout=2)


def test_a_four_bar_shows_where_theta1_can_be_set(connect):
    _, session = connect()
    session.set_mechanism("four-bar")
    line = session.facts  # the line under the Mechanism menu: a four-bar's reach is its second paragraph
    assert "\n\n*theta1 reachable: " in line.content, line.content
    p = session.params
    intervals = driving_range(p.L, p.pin)
    for low, high in intervals:
        assert f"{math.degrees(low):.1f}°" in line.content or f"{math.degrees(high):.1f}°" in line.content
    before = line.content
    session.set("L1", 0.5 * p.L[0])
    assert line.content != before  # the range follows the lengths
    session.set_mechanism("triple-a")
    assert "reachable" not in session.facts.content


def test_the_mechanism_menu_says_what_the_preset_is(connect):
    _, session = connect()
    for name in ("triple-a", "four-bar"):
        session.set_mechanism(name)
        text = session.description.content
        assert text.startswith("*Seed") and len(text) > 40, text
