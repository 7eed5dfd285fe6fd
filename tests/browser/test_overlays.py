"""The energy plot and the tip trace are drawn: pixels of their colours where they belong."""

from __future__ import annotations

import numpy as np

from app import snapshot as snap
from app.overlays import TRACE_COLOR

from . import pictures
from .conftest import AppPage, assert_mechanism_drawn, save_failure, wait_until

PICTURE_TIME = 3.0
# A projector's window: the mechanism is framed beside the control panel, drawn large enough to judge colours.
LECTURE_VIEWPORT = {"width": 1400, "height": 850}
KINETIC_BLUE = (31, 119, 180)  # app/session.py: the energy plot's series colours
POTENTIAL_GREEN = (44, 160, 44)


def plot_box(app: AppPage, title: str) -> dict:
    """The drawing canvas of the uPlot chart titled ``title`` in the control panel, scrolled into view."""
    chart = app.page.locator(".uplot", has=app.page.locator(".u-title", has_text=title)).first
    chart.scroll_into_view_if_needed()
    box = chart.locator("canvas").first.bounding_box()
    assert box is not None, f"plot {title!r} has no canvas"
    return box


def trace_points_seen(app: AppPage, image: np.ndarray, radius: int = 3) -> tuple[int, int]:
    """Of the traced point's positions along the newest quarter of the drawn trace (its most saturated end: the
    colour fades with the age fraction to the power 1.5, so this quarter keeps at least two thirds of it), how
    many have trace-coloured pixels within ``radius`` px on the page, out of how many lie on the canvas outside
    the control panel. (A fixed last second was half faded at t = 3 s with a 4-s trace; it passed only while
    the faded half lay behind the panel, before the mechanism was framed beside it.)"""
    history = app.session.history()
    drawn = min(app.session.display.trace_seconds, history["t"][-1] - history["t"][0])
    recent = history["t"] >= history["t"][-1] - 0.25 * drawn
    xy = history["trace_xy"][recent]
    world = np.column_stack([xy[:, 0], np.zeros(len(xy)), xy[:, 1]])  # app/scene.py: (x, y) -> (x, 0, y)
    projected = snap.project_world_points(app.page, "/linkage", world)
    trace = pictures.hue_match(image, TRACE_COLOR)
    panel = pictures.box_mask(image.shape, app.panel_box())
    seen = considered = 0
    for x, y in projected:
        if not (0 <= int(y) < image.shape[0] and 0 <= int(x) < image.shape[1]) or panel[int(y), int(x)]:
            continue
        considered += 1
        seen += pictures.count_near(trace, (x, y), radius) > 0
    return seen, considered


def test_energy_plot_and_trace_are_drawn(start_lab):
    lab = start_lab(preset="triple-a")
    app = lab.open_page(viewport=LECTURE_VIEWPORT)
    app.show_time(PICTURE_TIME)
    wait_until(lambda: app.session.trace.points_shown > 10,  # the one session's TraceLine (app/overlays.py)
               message="the trace to hold points")
    image = app.picture("overlays-1-trace-on")
    assert_mechanism_drawn(image, app)

    # energy plot: kinetic (red) and potential (blue) series inside the plot, across the time axis
    box = plot_box(app, "Energy")
    image = app.picture("overlays-2-energy-plot")
    inside = pictures.box_mask(image.shape, box)
    for name, colour in (("kinetic", KINETIC_BLUE), ("potential", POTENTIAL_GREEN)):
        drawn = pictures.colour_match(image, colour, max_residual=50.0, shade=(0.8, 1.2))
        assert drawn[inside].sum() >= 40, f"{name} energy series missing from the plot ({drawn[inside].sum()} px)"
        columns = np.nonzero(drawn[inside.any(axis=1)][:, inside.any(axis=0)].any(axis=0))[0]
        assert columns.max() - columns.min() >= 0.5 * box["width"], f"{name} series spans too little of the time axis"

    # the trace: its colour along the traced point's recent path
    image = app.picture("overlays-3-trace")
    seen, considered = trace_points_seen(app, image)
    assert considered >= 10, f"too few trace points on the visible canvas ({considered})"
    if seen < 0.8 * considered:
        save_failure("overlays-trace", image)
    assert seen >= 0.8 * considered, f"trace colour found at only {seen} of {considered} recent trace points"

    # a trace length of 0 s, set with the keyboard on the slider, removes it: the check above then fails
    app.open_tab("Display")
    app.press_on_slider("Trace length (s)", "Home")
    wait_until(lambda: app.session.display.trace_seconds == 0.0, message="the trace length to become 0 on the server")
    wait_until(lambda: not app.session.trace.handle.visible,
               message="the trace to be hidden")
    app.show_time(PICTURE_TIME)
    image = app.picture("overlays-4-trace-off")
    seen, considered = trace_points_seen(app, image)
    assert seen <= 0.1 * considered, f"trace colour still at {seen} of {considered} points with the trace off"
