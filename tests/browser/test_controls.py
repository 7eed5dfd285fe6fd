"""Controls moved in the page, as a person would, change the server's state and the picture.

The mouse drags Mantine slider thumbs and picks a dropdown option; the test then reads the session on the
server (the page's own session, found by its client id) and compares pictures of the same simulated time
before and after, outside the control panel.
"""

from __future__ import annotations

import math

import numpy as np

from . import pictures
from .conftest import AppPage, assert_mechanism_drawn, save_failure, wait_until

PICTURE_TIME = 2.0
KNOBS = "Bodies and motors"  # the one session's folder of a hosted chain's numbers (app/chain_knobs.py)
START = "Start (t = 0)"  # its folder of the start's angles and speeds
MASS_1 = "bar 1: mass m (kg)"


def scene_difference(app: AppPage, before: np.ndarray, after: np.ndarray) -> float:
    """Fraction of the canvas outside the control panel whose pixels differ."""
    outside = ~pictures.box_mask(before.shape, app.panel_box())
    return float(pictures.differing(after, before)[outside].mean())


def test_mass_and_initial_angle_sliders_and_method_dropdown_through_the_page(start_lab):
    lab = start_lab(preset="triple-a")
    app = lab.open_page()
    session = app.session
    assert session.params.m[0] == 1.0 and session.params.method == "lagrange"

    app.show_time(PICTURE_TIME)
    start_joints = np.array(session.snapshot()["joints"])
    before = app.picture("controls-1-start")
    assert_mechanism_drawn(before, app)

    # a mass: drag bar 1's "bar 1: mass m (kg)" thumb (the one panel's "Bodies and motors") from 1 kg towards 3 kg
    app.open_tab("Mechanism")
    app.drag_slider(MASS_1, 3.0, folder=KNOBS)
    wait_until(
        lambda: session.params.m[0] != 1.0 and session.params.m[0] == app.slider_value(MASS_1, folder=KNOBS),
        message="bar 1's mass on the server to follow the slider",
    )
    assert abs(session.params.m[0] - 3.0) <= 0.15, session.params.m
    app.show_time(PICTURE_TIME)
    heavier_joints = np.array(session.snapshot()["joints"])
    assert np.abs(heavier_joints - start_joints).max() > 0.05, "a heavier first bar must change the motion"
    heavier = app.picture("controls-2-heavier")
    assert_mechanism_drawn(heavier, app)
    changed = scene_difference(app, before, heavier)
    if changed <= pictures.FRACTION_TOLERANCE:
        save_failure("controls-mass", heavier, before)
    assert changed > pictures.FRACTION_TOLERANCE, f"the scene barely changed after the mass change ({changed:.4f})"

    # an initial angle: drag theta1 from 90 degrees towards 45
    app.drag_slider("theta1 (°)", 45.0, folder=START)
    wait_until(
        lambda: abs(math.degrees(session.params.theta0[0]) - app.slider_value("theta1 (°)")) < 1e-6
        and app.slider_value("theta1 (°)") != 90.0,
        message="theta1 on the server to follow the slider",
    )
    assert abs(math.degrees(session.params.theta0[0]) - 45.0) <= 3.0, session.params.theta0
    app.show_time(PICTURE_TIME)
    assert np.abs(np.array(session.snapshot()["joints"]) - heavier_joints).max() > 0.05
    turned = app.picture("controls-3-theta1")
    assert_mechanism_drawn(turned, app)
    changed = scene_difference(app, heavier, turned)
    assert changed > pictures.FRACTION_TOLERANCE, f"the scene barely changed after the angle change ({changed:.4f})"

    # the method: pick DAE in the dropdown; same physics, so the scene stays, the status line changes
    app.open_tab("Simulation")
    app.choose("Method", "DAE")
    wait_until(lambda: session.params.method == "dae", message="the method to become dae on the server")
    app.show_time(PICTURE_TIME)
    status_line = app.page.locator("p", has_text="(paused)")
    status_line.filter(has_text="DAE").first.wait_for()  # the status line names the method in use
    by_dae = app.picture("controls-4-dae")
    assert_mechanism_drawn(by_dae, app)
    assert scene_difference(app, turned, by_dae) <= pictures.FRACTION_TOLERANCE, (
        "the same start integrated by another formulation should look the same at 2 s"
    )
    panel = pictures.box_mask(by_dae.shape, app.panel_box())
    assert pictures.differing(by_dae, turned)[panel].any(), "the panel (status line) did not change"
