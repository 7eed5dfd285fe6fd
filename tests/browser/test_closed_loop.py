"""A closed loop driven to an angle where it cannot assemble: a notice in the page, the last valid state
kept, and the server goes on serving."""

from __future__ import annotations

import math
import urllib.request

import numpy as np

from physics import loop_closure

from .conftest import wait_until

# The seed four-bar (crank 1, coupler 1, rocker 2, ground ~1.49) is a non-Grashof triple rocker: its
# crank angle theta1 cannot reach the band around the pin's direction (about 6..89 degrees).
UNREACHABLE_DEG = 45.0
REACHABLE_DEG = 130.0


def closes(session, theta1_deg: float) -> bool:
    p = session.params
    try:
        p.assembled(np.array([math.radians(theta1_deg)]), theta_prev=np.asarray(p.theta0))
    except Exception:
        return False
    return True


def test_unreachable_angle_shows_a_notice_and_the_server_keeps_serving(start_lab):
    lab = start_lab(preset="four-bar")
    app = lab.open_page()
    session = app.session
    assert session.params.pinned
    assert not closes(session, UNREACHABLE_DEG) and closes(session, REACHABLE_DEG)

    app.open_tab("Mechanism")
    app.drag_slider("theta1 (°)", UNREACHABLE_DEG, folder="Start (t = 0)")  # the one session's start folder
    notice = app.page.locator(".mantine-Notification-root", has_text="cannot")
    notice.first.wait_for(state="visible")
    text = notice.first.inner_text()
    assert "theta1" in text and "cannot close" in text and "°" in text, text
    assert session.notice is not None

    # the session kept its last valid (assembled) start, and that start closes the loop
    kept = math.degrees(session.params.theta0[0])
    assert abs(kept - UNREACHABLE_DEG) > 5.0, kept
    assert closes(session, kept)
    p = session.params
    residual = loop_closure.loop_residual(np.asarray(p.L), np.asarray(p.theta0), np.asarray(p.pin))
    assert math.hypot(*residual) < 1e-9

    # the server keeps serving: its page answers, and the same browser can carry on
    with urllib.request.urlopen(f"http://127.0.0.1:{lab.port}/", timeout=30) as response:
        assert response.status == 200
    app.drag_slider("theta1 (°)", REACHABLE_DEG, folder="Start (t = 0)")  # the one session's start folder
    wait_until(
        lambda: abs(math.degrees(session.params.theta0[0]) - REACHABLE_DEG) <= 3.0,
        message="a reachable theta1 to be applied after the refused one",
    )
    app.show_time(1.0)
    assert not session.closed and session.player.alive
