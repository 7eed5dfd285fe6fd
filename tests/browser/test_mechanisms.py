"""A general mechanism in a real browser (issue 16): chosen in the mechanism menu, drawn, its generated controls
shown, and back to a chain, all in one page."""

from __future__ import annotations

import numpy as np

from .conftest import wait_until


def _saturated_pixels(image: np.ndarray, right: float) -> int:
    """Coloured pixels (the bars) left of ``right`` (the panel's left edge), below the notification strip."""
    canvas = image[:, : int(right)].astype(int)
    spread = canvas.max(axis=2) - canvas.min(axis=2)
    return int(np.sum(spread > 80))


def test_choosing_the_jansen_leg_draws_it_with_its_controls_and_a_chain_comes_back(start_lab):
    from app.session import Session

    lab = start_lab(preset="single")
    page = lab.open_page()
    client_id = page.client_id
    session = lab.server.session_for(client_id)
    assert isinstance(session, Session) and session.chain is not None  # a chain preset in the one session
    page.show_time(0.5)
    single = page.picture("mechanism-menu-single")
    right = page.panel_box()["x"]
    before = _saturated_pixels(single, right)

    page.choose("Mechanism", "jansen-leg")
    # the page's one session shows the leg (a menu choice stays in its session: no switch between sessions)
    wait_until(lambda: session.chain is None and session.label == "jansen-leg",
               message="the page's session to show the Jansen leg")
    assert lab.server.session_for(client_id) is session
    wait_until(lambda: bool(session.player.runs) and session.player.runs[0].spec.structure == session.spec.structure,
               message="the leg's run to be the one shown")
    frames = session.frames_sent  # the single pendulum's frames were counted by the same session
    wait_until(lambda: session.frames_sent > frames + 30 and session.trace.points_shown > 20,
               message="the leg to move and its foot's path to be drawn")
    session.pause()
    panel = page.page.locator(".mantine-Paper-root").first
    facts = "7 bodies, 10 joints; mobility 1 (Grübler count 1); driven by 1 motor; 0 free (motors: O (speed))"
    # the same page's panel is rebuilt for the leg (a busy software renderer lags behind the server)
    wait_until(lambda: facts in page.page.inner_text("body") and "crank: m (kg)" in page.page.inner_text("body"),
               message="the panel to show the leg's facts and controls")
    panel_text = page.page.inner_text("body")
    assert facts in panel_text
    assert "Bodies and motors" in panel_text and "crank: m (kg)" in panel_text
    assert "motor O: speed (°/s)" in panel_text
    assert "Driving torque (inverse dynamics)" in panel_text and "Help" in panel_text
    assert panel is not None
    leg = page.picture("mechanism-jansen-leg")
    drawn = _saturated_pixels(leg, right)
    # seven bodies in seven colours, far more coloured area than the single pendulum's one bar
    assert drawn > 3 * max(before, 1) and drawn > 3000, (before, drawn)

    # a refused value typed into a generated control: one notice naming the body, the field and the range
    session.guard(lambda: session.set("mass:crank", -2))
    wait_until(lambda: any("crank: m (kg) = -2" in text for text in page.notification_texts()),
               message="the refusal's notice in the page")

    page.choose("Mechanism", "double")
    wait_until(lambda: session.chain is not None and session.chain.preset == "double",
               message="the page's session to show a chain again")
    # the mechanism's controls leave the panel, the chain's (app/chain_knobs.py) take their place
    wait_until(lambda: "crank: m (kg)" not in page.page.inner_text("body")
               and "bar 2: length L (m)" in page.page.inner_text("body"),
               message="the mechanism's controls to leave the panel")
    back = lab.server.session_for(client_id)
    assert back is session and back.params.preset == "double" and not session.closed


def test_the_mechanism_panel_has_the_chain_panels_tabs_integrator_and_start(start_lab):
    """Issue 24: the integrator menu of the Simulation tab refuses what the method does not take in one notice
    naming what it does, applies the rest; the Mechanism tab's start box re-assembles the slider-crank at the
    typed crank angle and the run starts there."""
    import math

    from app.session import Session

    lab = start_lab(preset="slider-crank")
    page = lab.open_page()
    session = page.session
    assert isinstance(session, Session)
    tabs = page.page.get_by_role("tab").all_inner_texts()
    assert [tab.strip() for tab in tabs] == ["Mechanism", "Simulation", "Display", "Equations", "Export", "Help",
                                            "Analysis", "Report", "Design"]  # as a chain's, Design last

    page.open_tab("Simulation")
    page.choose("Integrator", "variational")
    wait_until(lambda: any("integrator = variational: does not apply to method dae" in text
                           and "allowed RK45, DOP853, ode45, Radau, LSODA, midpoint" in text
                           for text in page.notification_texts()),
               message="the refusal naming the integrators the DAE takes")
    assert session.settings.integrator == "DOP853"
    page.choose("Integrator", "midpoint")
    wait_until(lambda: session.settings.integrator == "midpoint", message="midpoint to be applied")
    wait_until(lambda: page.page.locator("label", has_text="type fixed step (ms)").first.is_visible(),
               message="the fixed step's box to show for midpoint")
    assert not page.page.locator("label", has_text="type tolerance rtol = atol").first.is_visible()

    page.open_tab("Mechanism")
    label = page.page.locator("label", has_text="type crank: start angle (°)").first
    box = label.locator("xpath=ancestor::*[.//input][1]").locator("input").first
    box.scroll_into_view_if_needed()
    box.fill("2.5e1")  # read as written: 25°, not the browser's 2.51
    wait_until(lambda: abs(session.q0[2] - math.radians(25.0)) < 1e-12, message="the crank to start at 25°")
    # The run that starts there: the session sets its start before it asks the player for the new run (the
    # scene is rebuilt between the two), so "the player is idle" alone may still describe the run before (seen
    # in a CI rehearsal under load). The first midpoint run of a fresh clone compiles its kernel (about 20 s
    # idle, more beside other work): the wait is for the run, not a speed budget.
    wait_until(lambda: (session.player.wait_idle(0.05)
                        and abs(session.player.runs[0].ring.get("q", 0)[2] - math.radians(25.0)) < 1e-9),
               timeout_s=300, message="the run shown to start at the typed 25°")
    assert session.player.runs[0].failed is None
