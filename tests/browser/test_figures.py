"""Figures readable at the panel's width and full-screen on a click, measured in Chromium at 1920 x 1080 with the
default panel (issue 26, "Readable from the back row": at least 12 px text).

How text is measured, as a person sees it:

- an SVG figure: each text's computed font size times the scale the SVG is drawn at (``getScreenCTM``, whose
  first column's length holds for a rotated axis label too). A figure
  shown as an ``<img>`` (the Report tab) exposes no text, so its SVG is laid out once more at the image's drawn
  width, off screen, and measured the same way;
- a raster figure (the chaos map): the height of its drawn digits, from a screenshot of the image as shown,
  against the height of the digits of 12 px text in the same browser (``measureText``), so "at least 12 px" means
  the same for pictures as for text.
"""

from __future__ import annotations

import numpy as np
import pytest

from app.mechanism_analysis import CHAIN_CHAOS_RESOLUTION
from app.report_view import FIGURES
from physics.studies import chaos_map

from . import pictures
from .conftest import wait_until

pytestmark = pytest.mark.browser

SCREEN = {"width": 1920, "height": 1080}
SMALLEST_PX = 12.0
ANALYSIS_TIMEOUT_S = 240.0
OVERLAY = "#linkage-lab-figure-overlay"

# The SVG inside an <img src="data:image/svg+xml;base64,...">, laid out off screen at the image's drawn width:
# [text, drawn px] for every text, and the width it was laid out at.
# The texts that reach past the picture's edge (issue 26: the work-precision chart's x-axis label "0.1" was cut)
TEXT_OUTSIDE = """(svg) => {
  const box = svg.getBoundingClientRect();
  return Array.from(svg.querySelectorAll("text")).filter((t) => t.textContent.trim()).filter((t) => {
    const r = t.getBoundingClientRect();
    return r.left < box.left - 0.5 || r.right > box.right + 0.5 || r.top < box.top - 0.5 || r.bottom > box.bottom + 0.5;
  }).map((t) => t.textContent.trim().slice(0, 40));
}"""

IMAGE_SVG_TEXT_SIZES = """
(img) => {
  const TEXT_OUTSIDE = """ + TEXT_OUTSIDE + """;
  const source = atob(img.getAttribute("src").split(",")[1]);
  const width = img.getBoundingClientRect().width;
  const holder = document.createElement("div");
  holder.style.cssText = `position:absolute;left:-30000px;top:0;width:${width}px`;
  holder.innerHTML = source;
  document.body.appendChild(holder);
  const svg = holder.querySelector("svg");
  svg.setAttribute("width", `${width}`);
  svg.removeAttribute("height");
  svg.style.display = "block";
  const scale = (element) => Math.hypot(element.getScreenCTM().a, element.getScreenCTM().b);  // rotated too
  const sizes = [];
  for (const text of svg.querySelectorAll("text")) {
    if (!text.textContent.trim()) continue;
    sizes.push([text.textContent.trim().slice(0, 40),
                parseFloat(getComputedStyle(text).fontSize) * scale(text)]);
  }
  const drawn = svg.getBoundingClientRect().width;
  const outside = TEXT_OUTSIDE(svg);
  holder.remove();
  return {sizes: sizes, width: drawn, outside: outside};
}
"""

INLINE_SVG_TEXT_SIZES = """
(svg) => Array.from(svg.querySelectorAll("text")).filter((t) => t.textContent.trim()).map((t) => {
  const m = t.getScreenCTM();
  return [t.textContent.trim().slice(0, 40), parseFloat(getComputedStyle(t).fontSize) * Math.hypot(m.a, m.b)];
})
"""

DIGIT_HEIGHT_AT_12PX = """
() => {
  const context = document.createElement("canvas").getContext("2d");
  context.font = `12px ${getComputedStyle(document.body).fontFamily}`;
  const m = context.measureText("0123456789");
  return m.actualBoundingBoxAscent + m.actualBoundingBoxDescent;
}
"""


def _too_small(sizes) -> list:
    return [(text, round(px, 1)) for text, px in sizes if px < SMALLEST_PX]


def _report_figure(app, label: str):
    image = app.page.locator(f'img[alt="{label}"]').first
    image.wait_for(state="visible")
    app.page.wait_for_function("(img) => img.complete && img.naturalWidth > 0", arg=image.element_handle())
    return image


def test_every_seed_report_figure_has_text_of_12px_at_the_panel_width(start_lab):
    lab = start_lab(preset="triple-a")
    app = lab.open_page(viewport=SCREEN)
    app.open_tab("Report")
    panel = app.panel_box()
    assert panel is not None and panel["width"] < 420, panel  # the default panel, not lecture mode's
    failures = {}
    for index, figure in enumerate(FIGURES):
        if index:
            app.choose("Figure", figure.label)
        image = _report_figure(app, figure.label)
        box = image.bounding_box()
        assert box is not None and box["width"] <= panel["width"], (figure.label, box, panel)
        measured = image.evaluate(IMAGE_SVG_TEXT_SIZES)
        assert abs(measured["width"] - box["width"]) < 1.0, (figure.label, measured["width"], box)
        assert len(measured["sizes"]) >= 5, (figure.label, measured)
        small = _too_small(measured["sizes"])
        if small:
            failures[figure.file] = small[:6]
        if measured["outside"]:
            failures[f"{figure.file} (past the edge)"] = measured["outside"][:6]
    assert not failures, f"text under {SMALLEST_PX:g} px at the panel's width, or cut at its edge: {failures}"


def test_a_click_opens_a_report_figure_full_screen_and_escape_or_a_click_closes_it(start_lab):
    lab = start_lab(preset="triple-a")
    app = lab.open_page(viewport=SCREEN)
    app.open_tab("Report")
    image = _report_figure(app, FIGURES[0].label)
    page = app.page
    for closing in ("Escape", "click"):
        image.click()
        overlay = page.locator(OVERLAY)
        overlay.wait_for(state="visible")
        shown = overlay.locator("img").first
        shown.wait_for(state="visible")
        page.wait_for_function("(img) => img.complete && img.naturalWidth > 0", arg=shown.element_handle())
        box = shown.bounding_box()
        assert box is not None and box["width"] >= 0.9 * SCREEN["width"] and box["height"] >= 0.9 * SCREEN["height"], box
        assert shown.get_attribute("src") == image.get_attribute("src")
        if closing == "Escape":
            page.keyboard.press("Escape")
        else:
            page.mouse.click(SCREEN["width"] / 2, SCREEN["height"] / 2)
        overlay.wait_for(state="detached")
    assert app.session.seed_report.figure.content  # the panel's figure is still there


def _digit_heights(shot: np.ndarray, columns: slice, rows: slice) -> list[int]:
    """Heights of the runs of rows holding dark ink in ``shot[rows, columns]``: one run per line of text."""
    ink = (shot[rows, columns].max(axis=-1) < 170).any(axis=1)  # grey and darker: text antialiased and scaled
    heights, run = [], 0
    for dark in ink:
        if dark:
            run += 1
        elif run:
            heights.append(run)
            run = 0
    if run:
        heights.append(run)
    return heights


def test_the_analysis_tabs_figures_have_text_of_12px_and_open_full_screen(start_lab):
    lab = start_lab(preset="triple-a")
    app = lab.open_page(viewport=SCREEN)
    session, page = app.session, app.page
    app.open_tab("Analysis")

    # the work-precision chart: an inline SVG as wide as the panel
    page.get_by_role("button", name="Work-precision chart", exact=True).click()
    wait_until(lambda: session.analysis.chart_html.content != "", timeout_s=ANALYSIS_TIMEOUT_S,
               message="the work-precision chart on the server")
    chart = page.locator("svg.linkage-lab-figure", has_text="Work-precision").first
    chart.wait_for(state="visible")
    sizes = chart.evaluate(INLINE_SVG_TEXT_SIZES)
    assert len(sizes) >= 10, sizes
    assert not _too_small(sizes), f"work-precision chart: text under {SMALLEST_PX:g} px: {_too_small(sizes)}"
    assert not chart.evaluate(TEXT_OUTSIDE), "work-precision chart: text cut at the picture's edge"
    chart.click(position={"x": 30, "y": 30})
    overlay = page.locator(OVERLAY)
    overlay.locator("svg").first.wait_for(state="visible")
    box = overlay.locator("svg").first.bounding_box()
    assert box is not None and box["width"] >= 0.9 * SCREEN["width"], box
    page.keyboard.press("Escape")
    overlay.wait_for(state="detached")

    # the chaos map: a picture (PNG); its colour bar's labels ("0.01 s" ... "20 s") measured in what is shown
    page.get_by_role("button", name=f"Chaos map (double pendulum, {CHAIN_CHAOS_RESOLUTION} x "
                     f"{CHAIN_CHAOS_RESOLUTION})").click()
    wait_until(lambda: session.analysis.image_handle is not None, timeout_s=ANALYSIS_TIMEOUT_S,
               message="the chaos map on the server")
    image = page.locator('[data-testid="floating-panel"] img[src^="blob:"]').first
    image.wait_for(state="visible")
    image.scroll_into_view_if_needed()
    page.wait_for_function("(img) => img.complete && img.naturalWidth > 0", arg=image.element_handle())
    natural_width = image.evaluate("img => img.naturalWidth")
    shot = pictures.decode_png(image.screenshot())
    scale = shot.shape[1] / natural_width
    map_size = natural_width - (chaos_map.FRAME_LEFT + chaos_map.BAR_GAP + chaos_map.BAR_WIDTH + chaos_map.BAR_LABELS)
    labels_from = chaos_map.FRAME_LEFT + map_size + chaos_map.BAR_GAP + chaos_map.BAR_WIDTH + 5
    top, bottom = chaos_map.FRAME_TOP - 12, chaos_map.FRAME_TOP + map_size + 12
    heights = _digit_heights(shot, slice(int(labels_from * scale) + 1, None),
                             slice(int(top * scale), int(bottom * scale)))
    twelve = page.evaluate(DIGIT_HEIGHT_AT_12PX)
    assert len(heights) >= 4, heights  # one per colour-bar label
    assert min(heights) >= twelve, (f"chaos map: digits {heights} px tall as shown, under the {twelve:.1f} px of "
                                    f"{SMALLEST_PX:g} px text")
    image.click()
    overlay.locator("img").first.wait_for(state="visible")
    box = overlay.locator("img").first.bounding_box()
    assert box is not None and box["height"] >= 0.9 * SCREEN["height"], box
    page.mouse.click(10, 10)
    overlay.wait_for(state="detached")
