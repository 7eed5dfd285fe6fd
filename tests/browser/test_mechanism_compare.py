"""Compare mode and the free-body view of a general mechanism in a real browser (issue 24): ticked in the
mechanism's panel, the three formulations drawn in their colours with the divergence plots under the panel, and
a body's loads drawn as labelled arrows."""

from __future__ import annotations

import numpy as np

from .conftest import wait_until


def _pixels_near(image: np.ndarray, right: float, color: tuple[int, int, int], tolerance: int = 40) -> int:
    """Pixels of the scene (left of the panel at ``right``) within ``tolerance`` of ``color`` (shading varies)."""
    canvas = image[:, : int(right)].astype(int)
    return int(np.sum(np.all(np.abs(canvas - np.array(color)) < tolerance, axis=2)))


def test_a_mechanism_in_compare_mode_and_its_free_body_diagram(start_lab):
    from app.overlays import METHOD_COLORS
    from app.session import COMPARE_METHODS  # the one session's (not the chain view's module)

    lab = start_lab(preset="crank-rocker")
    page = lab.open_page()
    session = page.session
    page.show_time(0.3)
    right = page.panel_box()["x"]
    single = page.picture("mechanism-single")

    page.open_tab("Simulation")  # the panel's tabs, as a chain's
    page.page.get_by_role("checkbox", name="Compare formulations").check()
    wait_until(lambda: session.compare and [r.spec.label for r in session.player.runs][:3] == list(COMPARE_METHODS),
               message="the three formulations to run")
    page.show_time(1.0)
    wait_until(lambda: session.compare_view.between is not None and session.compare_view.between.points_shown > 5,
               message="the divergence plots to be fed")
    compared = page.picture("mechanism-compare")
    text = page.page.inner_text("body")
    assert "divergence from Newton-Euler" in text and "error vs a converged run" in text
    assert "from the converged run" in text  # the line of first passing times under the plots
    # the front mechanism is drawn in its method's colour, which the single mechanism's palette does not use
    front = METHOD_COLORS[COMPARE_METHODS[0]]
    assert _pixels_near(compared, right, front) > 300 + _pixels_near(single, right, front), "no mechanism in its colour"

    page.page.get_by_role("checkbox", name="Compare formulations").uncheck()
    wait_until(lambda: not session.compare and [r.spec.label for r in session.player.runs] == ["main"],
               message="one run again")
    page.open_tab("Display")
    page.choose("Body", "coupler")
    page.show_time(0.5)
    before = page.picture("mechanism-before-free-body")
    page.page.get_by_role("checkbox", name="Free-body diagram").check()
    wait_until(lambda: session.free_body.visible() and session.free_body.shown_bar == 2
               and session.free_body.shown_t is not None and abs(session.free_body.shown_t - 0.5) < 1e-9,
               message="the coupler's free-body diagram at the time shown")
    diagram = page.picture("mechanism-free-body")
    # the pins' arrows (green, lit lighter) and the weight's (dark grey) where the same pose without it has none
    changed = np.any(np.abs(diagram.astype(int) - before.astype(int)) > 30, axis=2)
    changed[:, int(right):] = False
    pixels = diagram[changed].astype(int)
    greenish = (pixels[:, 1] > pixels[:, 0] + 20) & (pixels[:, 1] > pixels[:, 2] + 20)
    dark_grey = (pixels.max(axis=1) < 110) & (pixels.max(axis=1) - pixels.min(axis=1) < 25)
    assert greenish.sum() > 500 and dark_grey.sum() > 300, (greenish.sum(), dark_grey.sum())
    labels = session.free_body.labels()
    assert len(labels) == 3 and sum(label.startswith("pin ") for label in labels) == 2


def test_a_mechanisms_equations_and_its_run_as_a_file_in_the_page(start_lab, tmp_path):
    """The Equations folder draws the system as maths in the panel; the CSV button hands the browser a file with
    the ``mechanism`` command's columns."""
    import csv
    import io
    import re

    from physics.mechanism import derived_system

    lab = start_lab(preset="slider-crank")
    page = lab.open_page()
    session = page.session
    page.show_time(0.5)

    page.page.get_by_text("Equations", exact=True).first.click()
    page.page.get_by_role("button", name="Show the equations of the method").click()
    system = derived_system(session.mechanism, "dae")
    wait_until(lambda: f"{system.A.shape[0]} equations" in session.equations.content,
               message="the equations derived")
    heading = page.page.get_by_text("LMB crank (x)", exact=False).first
    heading.wait_for()
    heading.scroll_into_view_if_needed()
    assert page.page.locator("math").count() > system.A.shape[0]  # the unknowns and every row, as MathML
    page.picture("mechanism-equations")

    page.page.get_by_text("Export", exact=True).first.click()
    page.page.get_by_role("button", name="CSV", exact=True).click()
    link = page.page.get_by_role("link", name=re.compile(r"mechanism-slider-crank-dae\.csv")).first
    link.wait_for()  # viser shows the file as a link in a notification: a person clicks it to save it
    with page.page.expect_download() as download_info:
        link.click()
    download = download_info.value
    assert download.suggested_filename == "mechanism-slider-crank-dae.csv"
    path = tmp_path / download.suggested_filename
    download.save_as(path)
    rows = list(csv.reader(io.StringIO(path.read_text())))
    assert rows[0][:7] == ["t", "trace_x", "trace_y", "kinetic", "potential", "energy", "constraint_residual"]
    assert any(name.startswith("lambda[") for name in rows[0])
    assert abs(float(rows[-1][0]) - 0.5) < 1e-12 and len(rows) == 1 + 31  # the run up to the time shown, 1/60 s apart
