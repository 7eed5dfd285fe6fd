"""The Report tab in a real browser: it opens, its figure fits the 384-px panel, another figure can be chosen, and
its picture matches the stored reference (tests/browser/references/report-tab.png)."""

from __future__ import annotations

import pytest

from app.report_view import FIGURES

from . import pictures
from .conftest import save_failure, wait_until
from .panel_pictures import REPORT_IMAGE, open_report_tab, report_tab_png
from .references_spec import REFERENCES

REGENERATE = "python tests/browser/regenerate_references.py report-tab"


def test_the_report_tab_fits_the_panel_and_changes_figure(start_lab):
    lab = start_lab(preset="triple-a")
    app = lab.open_page()
    open_report_tab(app.page)
    panel = app.panel_box()
    image = app.page.locator(REPORT_IMAGE).first
    box = image.bounding_box()
    assert box is not None and panel is not None
    assert box["x"] >= panel["x"] and box["x"] + box["width"] <= panel["x"] + panel["width"] + 0.5, (box, panel)
    assert box["width"] > 300 and box["height"] > 150, box
    natural = image.evaluate("img => [img.naturalWidth, img.naturalHeight]")
    assert natural[0] > 0 and abs(box["height"] / box["width"] - natural[1] / natural[0]) < 0.02  # scaled, not cut
    assert "16.61" not in app.page.locator("body").inner_text()
    app.choose("Figure", FIGURES[2].label)
    wait_until(lambda: "Figure 11" in app.session.seed_report.figure.content, message="figure 11 chosen")
    app.page.locator('img[alt^="Figure 11"]').first.wait_for(state="visible")
    text = app.page.locator("body").inner_text()  # its verdict, with the report's numbers for both controllers
    assert "t = 17.81 s with ode45" in text and "16.61 s with" in text, text[-600:]


def test_the_report_tab_matches_its_reference(browser):
    path = REFERENCES / "report-tab.png"
    assert path.exists(), f"no reference picture {path.name}; make it with `{REGENERATE}` and look at it"
    expected = pictures.read_png(path)
    actual = pictures.decode_png(report_tab_png(browser))
    if actual.shape != expected.shape:
        save_failure("report-tab", actual)
        pytest.fail(f"report-tab: picture {actual.shape} instead of {expected.shape}; if intended: {REGENERATE}")
    fraction = pictures.differing_fraction(actual, expected)
    if fraction > pictures.FRACTION_TOLERANCE:
        failure = save_failure("report-tab", actual, expected)
        pytest.fail(f"report-tab: {100 * fraction:.2f} % of pixels differ; see {failure}. If intended: {REGENERATE}")
