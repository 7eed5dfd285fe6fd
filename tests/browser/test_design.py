"""Design mode with real mouse events (app/design_view.py, issue 27): in Chromium, a four-bar crank-rocker is
drawn by clicks in the plane (two ground pivots, three bars, each bar pinned where it was drawn on a point), the
panel shows mobility 1, a motor is added from the panel, a ground pivot is dragged with the mouse and the
mechanism re-assembles with its coupler curve changed, and Run plays the design as a preset."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app import snapshot as snap
from app.design_view import handles_of
from physics.mechanism.design_analysis import topology_of

from .conftest import AppPage, wait_until

pytestmark = pytest.mark.browser

VIEWPORT = {"width": 1400, "height": 850}
GROUND_2, CRANK, COUPLER_END = (0.4, 0.0), (0.1, 0.0), (0.45, 0.25)


def on_page(app: AppPage, xy) -> list[float]:
    """Page pixels of physics point ``xy``: world (x, 0, y) through the browser's own camera (``/linkage`` is a
    frame at the world's origin, hidden while designing)."""
    (point,) = snap.project_world_points(app.page, "/linkage", [[float(xy[0]), 0.0, float(xy[1])]])
    return point


def draw_with_the_mouse(app: AppPage, pivots, bars) -> None:
    """Design in the scene, seen from the front, then click two ground ``pivots`` and the ``bars`` (pairs of
    points, each drawn from a point already there so it is pinned to it), each click's edit awaited."""
    session = app.session
    view = session.design_view
    app.open_tab("Design")
    app.page.get_by_text("Design in the scene", exact=True).click()
    wait_until(lambda: view.on, message="designing on")
    wait_until(lambda: session.camera.view == "front", message="the camera in front")
    snap.wait_for_drawn_frames(app.page)
    app.page.wait_for_timeout(800)  # the camera's move to the front view arrives and is drawn
    done = len(view.history.done)

    def edits() -> int:
        return len(view.history.done) - done

    app.choose("Tool", "Ground pivot")
    wait_until(lambda: view.tool == "Ground pivot", message="the tool chosen")
    for k, xy in enumerate(pivots):
        app.page.mouse.click(*on_page(app, xy))
        wait_until(lambda k=k: edits() == k + 1, message=f"ground pivot {k + 1} placed")
    app.choose("Tool", "Bar")
    wait_until(lambda: view.tool == "Bar", message="the bar tool chosen")
    for k, (first, second) in enumerate(bars):
        app.page.mouse.click(*on_page(app, first))
        wait_until(lambda: len(view.pending) == 1, message="the bar's first point")
        app.page.mouse.click(*on_page(app, second))
        wait_until(lambda k=k: edits() == len(pivots) + 1 + k, message=f"bar {k + 1} drawn")


def test_a_four_bar_drawn_with_the_mouse_has_mobility_one_drags_and_runs(start_lab):
    lab = start_lab(preset="crank-rocker")
    app = lab.open_page(viewport=VIEWPORT)
    session = app.session
    view = session.design_view

    def history() -> int:
        return len(view.history.done)

    draw_with_the_mouse(app, ((0.0, 0.0), GROUND_2), (((0.0, 0.0), CRANK), (CRANK, COUPLER_END),
                                                      (COUPLER_END, GROUND_2)))
    design = view.design
    assert len(design.bodies) == 3 and len(design.joints) == 4, design
    assert np.allclose([design.point("ground.G2"), design.point("bar3.B")], [GROUND_2, GROUND_2])
    app.page.get_by_text("3 bodies, 4 joints, 1 loop: mobility 1", exact=False).wait_for(timeout=30_000)
    assert "no motor" in view.topology_line.content

    # a motor from the panel's row, on the pin at the first ground pivot
    pin = next(j.name for j in design.joints if "ground.G1" in (j.a, j.b))
    label = app.page.locator("label", has_text="Motor on pin").first
    box = label.locator("xpath=ancestor::*[.//input][1]").locator("input").first
    box.scroll_into_view_if_needed()
    box.fill(pin)
    box.press("Enter")
    wait_until(lambda: view.motor_pin.value == pin, message="the pin typed")
    app.page.get_by_role("button", name="Add motor", exact=True).click()
    wait_until(lambda: "driven by 1 motor" in view.topology_line.content, message="the motor added")
    view.set_trace("bar2.B")  # the traced point (typed in the Item row in use; set here to keep the test short)
    curve_before = view.curve
    assert curve_before is not None

    # drag the second ground pivot with the mouse: the mechanism re-assembles, the coupler curve changes
    edits = history()
    target = (0.43, 0.03)
    mouse = app.page.mouse
    mouse.move(*on_page(app, GROUND_2))
    mouse.down()
    mouse.move(*on_page(app, target), steps=12)
    mouse.up()
    wait_until(lambda: history() == edits + 1, message="the drag to end as one edit")
    moved = view.design.point("ground.G2")
    assert math.dist(moved, target) < 0.015, moved
    rocker = [xy for _, xy in view.design.body("bar3").points]
    assert math.dist(*rocker) == pytest.approx(math.hypot(0.05, 0.25), abs=1e-9), "the rocker keeps its length"
    assert view.curve is not None and not np.allclose(view.curve, curve_before)
    assert [r for r, _ in handles_of(view.design)][:2] == ["ground.G1", "ground.G2"]

    # Run: the design plays as a preset does
    app.page.get_by_role("button", name="Run", exact=True).click()
    wait_until(lambda: session.label == "design (design)" and not view.on, message="the design to run")
    wait_until(lambda: session.player.playing and session.player.display_time > 0.3, message="the run to play")
    assert session.mechanism == view.design.to_mechanism()


def test_an_impossible_drag_with_the_mouse_is_one_notice_and_undo_redo_buttons_step_back(start_lab):
    lab = start_lab(preset="crank-rocker")
    app = lab.open_page(viewport=VIEWPORT)
    session = app.session
    view = session.design_view
    # the four-bar drawn through the view's own methods (the first test draws it with the mouse)
    view.add_ground("O2", (0.0, 0.0))
    view.add_ground("O4", GROUND_2)
    view.add_bar("crank", ("A0", (0.0, 0.0)), ("A", CRANK))
    view.add_bar("coupler", ("A", CRANK), ("B", COUPLER_END))
    view.add_bar("rocker", ("B", COUPLER_END), ("B0", GROUND_2))
    for name, a, b in (("O2p", "ground.O2", "crank.A0"), ("Ap", "crank.A", "coupler.A"),
                       ("Bp", "coupler.B", "rocker.B"), ("O4p", "rocker.B0", "ground.O4")):
        view.add_pin(name, a, b)
    app.open_tab("Design")
    app.page.get_by_text("Design in the scene", exact=True).click()
    wait_until(lambda: view.on and session.camera.view == "front", message="designing, seen from the front")
    snap.wait_for_drawn_frames(app.page)
    app.page.wait_for_timeout(800)
    built = view.design
    mouse = app.page.mouse

    def drag(from_xy, to_xy) -> None:
        mouse.move(*on_page(app, from_xy))
        mouse.down()
        mouse.move(*on_page(app, to_xy), steps=12)
        mouse.up()

    drag(GROUND_2, (0.42, 0.0))
    wait_until(lambda: view.design != built, message="the valid drag to apply")
    valid = view.design
    drag((0.42, 0.0), (1.2, 0.0))  # the rocker and coupler cannot reach: refused, the last valid design kept
    wait_until(lambda: any("cannot be assembled" in text for text in app.notification_texts()),
               message="the refusal's notice")
    app.page.wait_for_timeout(500)  # the drag's end is handled
    refusals = [text for text in app.notification_texts() if "cannot be assembled" in text]
    assert len(refusals) == 1, refusals
    # kept: the last design the mouse reached that assembles (the drag's moves within reach applied)
    after = view.design
    assert view.shown == after and topology_of(after).mobility == 1
    assert 0.42 - 1e-9 <= after.point("ground.O4")[0] <= 0.1 + 0.43 + math.hypot(0.05, 0.25)
    app.page.get_by_role("button", name="Undo", exact=True).click()
    expected = valid if after != valid else built  # a drag that changed nothing is no edit
    wait_until(lambda: view.design == expected, message="Undo to the design before the drag")
    app.page.get_by_role("button", name="Redo", exact=True).click()
    wait_until(lambda: view.design == after, message="Redo to the dragged design")


def test_a_slider_crank_drawn_with_the_mouse_and_the_slider_tool_runs(start_lab):
    lab = start_lab(preset="crank-rocker")
    app = lab.open_page(viewport=VIEWPORT)
    session = app.session
    view = session.design_view
    # the crank's pivot and a point of the piston's guide; crank, rod, and a piston pinned to the rod, each
    # drawn from the point the last one ended on
    draw_with_the_mouse(app, ((0.0, 0.0), (0.4, 0.0)), (((0.0, 0.0), (0.05, 0.0)), ((0.05, 0.0), (0.25, 0.0)),
                                                        ((0.25, 0.0), (0.3, 0.0))))
    app.choose("Tool", "Slider")
    wait_until(lambda: view.tool == "Slider", message="the slider tool chosen")
    app.page.mouse.click(*on_page(app, (0.3, 0.0)))  # the piston's far end slides ...
    wait_until(lambda: len(view.pending) == 1, message="the sliding point picked")
    app.page.mouse.click(*on_page(app, (0.4, 0.0)))  # ... along the guide through the second ground pivot
    wait_until(lambda: len(view.history.done) == 6, message="the slider added")
    design = view.design
    slider = next(j for j in design.joints if j.kind == "prismatic")
    assert (slider.body, slider.point, slider.on, slider.through) == ("bar3", "B", "ground", "G2"), slider
    app.page.get_by_text("3 bodies, 4 joints, 1 loop: mobility 1", exact=False).wait_for(timeout=30_000)

    pin = next(j.name for j in design.joints if j.kind == "revolute" and "ground.G1" in (j.a, j.b))
    view.add_motor(pin, speed=3.0)  # the panel's motor row is driven by the four-bar test
    view.set_trace("bar3.B")
    wait_until(lambda: "driven by 1 motor" in view.topology_line.content, message="the motor added")
    assert view.curve is not None and np.ptp(view.curve[:, 0]) == pytest.approx(0.1, rel=1e-6), \
        "the piston strokes twice the crank"

    app.page.get_by_role("button", name="Run", exact=True).click()
    wait_until(lambda: session.label == "design (design)" and not view.on, message="the design to run")
    wait_until(lambda: session.player.playing and session.player.display_time > 0.3, message="the run to play")
    assert session.mechanism == view.design.to_mechanism()
