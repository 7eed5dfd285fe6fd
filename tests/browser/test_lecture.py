"""Lecture mode and dark mode, measured in Chromium (issue 26, "Readable from the back row").

Text sizes are read as a person sees them: the computed font size of every visible text in the panel (scaled by
an SVG's own scale for figure text) and, for the uPlot charts' canvases, the size each text was drawn at (the
canvas's ``fillText`` is watched from the page's first script) times the canvas's CSS-to-canvas scale.
"""

from __future__ import annotations

import time

import pytest

from app import snapshot as snap

from .conftest import OUTPUT, SERVER_TIMEOUT_S, wait_until

pytestmark = pytest.mark.browser

# Every canvas text is recorded with the size it was drawn at (in canvas pixels, through the context's transform,
# so a rotated axis label counts with its own size).
RECORD_CANVAS_TEXT = """
(() => {
  const fill = CanvasRenderingContext2D.prototype.fillText;
  CanvasRenderingContext2D.prototype.fillText = function (text, x, y, maxWidth) {
    const size = /(\\d+(?:\\.\\d+)?)px/.exec(this.font);
    if (size && this.canvas) {
      const t = this.getTransform();
      this.canvas.__texts = this.canvas.__texts || new Map();
      this.canvas.__texts.set(String(text), parseFloat(size[1]) * Math.hypot(t.c, t.d));
    }
    return fill.apply(this, arguments);
  };
})();
"""

PANEL_TEXT_SIZES = """
() => {
  const panel = document.querySelector('[data-testid="floating-panel"]');
  const out = [];
  const shown = (r) => r.width > 0 && r.height > 0 && r.bottom > 0 && r.top < innerHeight && r.right > 0 &&
                       r.left < innerWidth;
  const walker = document.createTreeWalker(panel, NodeFilter.SHOW_TEXT);
  for (let node = walker.nextNode(); node; node = walker.nextNode()) {
    if (!node.textContent.trim()) continue;
    const element = node.parentElement;
    const range = document.createRange();
    range.selectNodeContents(node);
    if (!shown(range.getBoundingClientRect())) continue;
    const style = getComputedStyle(element);
    if (style.visibility === "hidden" || style.opacity === "0") continue;
    let px = parseFloat(style.fontSize);
    const svg = element.closest("svg");
    if (svg && svg.getScreenCTM()) px *= svg.getScreenCTM().a;
    out.push({text: node.textContent.trim().slice(0, 40), px: px, kind: element.tagName});
  }
  for (const canvas of panel.querySelectorAll("canvas")) {
    const r = canvas.getBoundingClientRect();
    if (!shown(r) || !canvas.__texts || !canvas.width) continue;
    for (const [text, px] of canvas.__texts) out.push({text: text.slice(0, 40), px: px * r.width / canvas.width,
                                                      kind: "CANVAS"});
  }
  return out;
}
"""


def open_with(lab, query: str = "", viewport: dict | None = None, scheme: str = "light"):
    """A page of ``lab`` with ``query`` added to the app's address, canvas text recorded; paused once drawn."""
    before = set(lab.server.sessions)
    context = lab.browser.new_context(viewport=viewport or {"width": 1920, "height": 1080}, device_scale_factor=1,
                                      color_scheme=scheme)
    context.add_init_script(RECORD_CANVAS_TEXT)
    page = context.new_page()
    page.set_default_timeout(SERVER_TIMEOUT_S * 1000)
    lab.opened.append(page)
    page.goto(snap.page_url(lab.port) + query)
    wait_until(lambda: set(lab.server.sessions) - before, message="a session for the page")
    (client_id,) = set(lab.server.sessions) - before
    session = lab.server.session_for(client_id)
    session.pause()
    snap.wait_until_drawn(page)
    return page, session


def text_sizes(page) -> list[dict]:
    return page.evaluate(PANEL_TEXT_SIZES)


def wait_for_panel_width(page, at_least: float = 0.0, back_to: float | None = None) -> float:
    """The panel's width once it is at least ``at_least`` px (or within 2 px of ``back_to``): the session's
    lecture flag changes at once, the page's panel when the browser has applied the server's message."""
    deadline = time.monotonic() + SERVER_TIMEOUT_S
    while time.monotonic() < deadline:
        width = page.locator(snap.CONTROL_PANEL).bounding_box()["width"]
        if (width >= at_least) if back_to is None else abs(width - back_to) <= 2:
            return width
        time.sleep(0.05)
    wanted = f"at least {at_least:.0f}" if back_to is None else f"{back_to:.0f} +- 2"
    raise AssertionError(f"the panel stayed {width:.0f} px wide (wanted {wanted} px)")


def keep_picture(page, name: str) -> None:
    OUTPUT.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(OUTPUT / f"{name}.png"))


def test_lecture_mode_makes_every_panel_and_chart_text_18px_at_1920(start_lab):
    """Default mode has text under 18 px (so the measurement can tell); the Display tab's checkbox turns lecture
    mode on, and then every visible text of the panel and its charts is at least 18 px, in a wider panel."""
    lab = start_lab(preset="double")
    page, session = open_with(lab)
    default_width = page.locator(snap.CONTROL_PANEL).bounding_box()["width"]
    before = text_sizes(page)
    assert min(item["px"] for item in before) < 18, "default mode already has no text under 18 px"
    page.get_by_role("tab", name="Display", exact=True).click()
    page.get_by_label("Lecture mode").check()
    wait_until(lambda: session.lecture, message="the session in lecture mode")
    width = wait_for_panel_width(page, 1.4 * default_width)
    assert width >= 0.3 * 1920
    page.get_by_role("tab", name="Mechanism", exact=True).click()
    page.wait_for_timeout(1500)  # the charts redraw at the panel's new width
    sizes = text_sizes(page)
    keep_picture(page, "lecture-1920")
    # the charts sit under the tabs (tests/browser/test_layout.py): scrolled to, and measured there too
    page.locator(f"{snap.CONTROL_PANEL} canvas").first.scroll_into_view_if_needed()
    sizes += text_sizes(page)
    drawn = [item for item in sizes if item["kind"] == "CANVAS"]
    assert len(drawn) >= 8, f"the charts' canvas text was not measured: {drawn}"
    small = [item for item in sizes if item["px"] < 18.0]
    assert not small, f"text under 18 px in lecture mode at 1920x1080: {small[:10]}"
    # and back: the checkbox turns it off again
    page.get_by_role("tab", name="Display", exact=True).click()
    page.get_by_label("Lecture mode").uncheck()
    wait_until(lambda: not session.lecture, message="lecture mode off")
    wait_for_panel_width(page, back_to=default_width)  # raises if it never comes back to the default width


def test_a_lecture_link_opens_in_lecture_mode_and_text_follows_the_window(start_lab):
    """``?lecture=1`` starts the page's session in lecture mode; at 1280 px the text is in proportion (at least
    12 px), and a bad value is one notice naming the field."""
    lab = start_lab(preset="double")
    page, session = open_with(lab, "&lecture=1", viewport={"width": 1280, "height": 720})
    assert session.lecture
    sizes = [item["px"] for item in text_sizes(page) if item["kind"] != "CANVAS"]
    assert min(sizes) >= 12.0 * 0.98 and min(sizes) <= 18 * 1280 / 1920 + 1.0, sizes
    page2, session2 = open_with(lab, "&lecture=maybe")
    assert not session2.lecture
    page2.wait_for_selector(".mantine-Notification-root, :text('lecture: ')", timeout=SERVER_TIMEOUT_S * 1000)
    assert "lecture: 'maybe' is not 0 or 1" in page2.locator("body").inner_text()


def _contrast(a: list[float], b: list[float]) -> float:
    def luminance(rgb):
        channels = [c / 255 for c in rgb[:3]]
        linear = [c / 12.92 if c <= 0.03928 else ((c + 0.055) / 1.055) ** 2.4 for c in channels]
        return 0.2126 * linear[0] + 0.7152 * linear[1] + 0.0722 * linear[2]

    high, low = sorted((luminance(a), luminance(b)), reverse=True)
    return (high + 0.05) / (low + 0.05)


# Each chart's key markers (the colour of its line, as uPlot draws the key) and the colour the chart sits on.
CHART_COLOURS = """
() => {
  const rgb = (text) => (text.match(/[\\d.]+/g) || []).map(Number);
  const opaque = (element) => {
    for (let e = element; e; e = e.parentElement) {
      const c = rgb(getComputedStyle(e).backgroundColor);
      if (c.length >= 3 && (c.length < 4 || c[3] > 0.5)) return c.slice(0, 3);
    }
    return [255, 255, 255];
  };
  return [...document.querySelectorAll('[data-testid="floating-panel"] .uplot')].filter(
    (plot) => plot.getBoundingClientRect().height > 0).map((plot) => ({
      title: (plot.querySelector(".u-title") || {}).textContent,
      background: opaque(plot),
      lines: [...plot.querySelectorAll(".u-legend .u-series")].map((row) => ({
        label: row.textContent.trim(), marker: row.querySelector(".u-marker") &&
          rgb(getComputedStyle(row.querySelector(".u-marker")).borderColor).slice(0, 3),
        text: rgb(getComputedStyle(row).color).slice(0, 3)})).filter((line) => line.marker && line.marker.length)}));
}
"""


@pytest.mark.parametrize("scheme", ["dark", "light"])
def test_every_chart_line_and_key_stands_out_in_both_schemes(start_lab, scheme):
    """Every chart's lines (the colours of its key's markers, which are the series' strokes) have a contrast ratio
    of at least 3 against the chart's background, and the key's text at least 4.5, in dark and light mode; the
    drawn chart really has pixels of each line's colour. Each chart the panel can show: the energy charts, the
    Angles chart, and compare mode's charts."""
    from app.panel_rows import CHAIN_PLOT_CHOICES  # noqa: PLC0415

    lab = start_lab(preset="four-bar")
    page, session = open_with(lab, "", viewport={"width": 1280, "height": 900}, scheme=scheme)
    session.play()
    wait_until(lambda: session.player.display_time > 1.0, message="a second of motion")
    session.pause()
    page.wait_for_timeout(1000)
    titles = _check_charts(page, scheme, "energy")
    keep_picture(page, f"charts-{scheme}")
    session.plot_choice.value = CHAIN_PLOT_CHOICES[1]  # "Angles θ(t)", as the browser sends it
    wait_until(lambda: session.coordinate_plot.handle.visible, message="the Angles chart shown")
    page.wait_for_timeout(1500)
    titles |= _check_charts(page, scheme, "angles")
    session.plot_choice.value = CHAIN_PLOT_CHOICES[0]
    session.set_compare(True)
    session.play()
    wait_until(lambda: session.player.display_time > 2.0, message="compare mode's motion")
    session.pause()
    page.wait_for_timeout(1500)
    titles |= _check_charts(page, scheme, "compare")
    assert len(titles) >= 3, f"{scheme}: the charts checked: {titles}"


def _check_charts(page, scheme: str, what: str) -> set:
    """The contrast of every shown chart's lines and key, and its key's colours among its drawn pixels; the
    charts' titles."""
    import numpy as np  # noqa: PLC0415

    from . import pictures  # noqa: PLC0415

    charts = page.evaluate(CHART_COLOURS)
    assert charts, f"{scheme}, {what}: no chart shown"
    if scheme == "dark":
        assert all(sum(chart["background"]) < 3 * 80 for chart in charts), charts
    poor = []
    for chart in charts:
        for line in chart["lines"]:
            line_contrast = _contrast(line["marker"], chart["background"])
            text_contrast = _contrast(line["text"], chart["background"])
            if line_contrast < 3.0 or text_contrast < 4.5:
                poor.append((chart["title"], line["label"], round(line_contrast, 2), round(text_contrast, 2)))
    assert not poor, f"{scheme}, {what}: lines or keys too faint against their chart (title, line, contrast): {poor}"
    # the drawn charts (uPlot's canvases, as the page shows them) hold pixels of each line's colour: the key's
    # colours are the lines really drawn, not a key over lines of another colour
    drawn = [pictures.decode_png(canvas.screenshot())[..., :3].reshape(-1, 3).astype(int)
             for canvas in page.locator(f"{snap.CONTROL_PANEL} .uplot canvas").all() if canvas.is_visible()]
    assert drawn, f"{scheme}, {what}: no chart canvas shown"
    pixels = np.unique(np.concatenate(drawn), axis=0)
    missing = [(chart["title"], line["label"], line["marker"]) for chart in charts for line in chart["lines"]
               if np.min(np.abs(pixels - np.array(line["marker"][:3])).sum(axis=1)) > 45]
    assert not missing, f"{scheme}, {what}: key colours with no pixel of their colour in the drawn charts: {missing}"
    return {chart["title"] for chart in charts}


def _lightness(png: bytes) -> tuple[float, float]:
    """The median lightness (0-255) of a picture and the share of its pixels far from that median (its drawing)."""
    import numpy as np  # noqa: PLC0415

    from . import pictures  # noqa: PLC0415

    lightness = pictures.decode_png(png)[..., :3].astype(float).mean(axis=2)
    median = float(np.median(lightness))
    return median, float(np.mean(np.abs(lightness - median) > 60))


@pytest.mark.parametrize("scheme", ["dark", "light"])
def test_figures_follow_the_scheme(start_lab, scheme):
    """Issue 26: the work-precision chart was a white block in dark mode. A study's chart and the seed report's
    figure are drawn on white; in dark mode the page shows them dark (their lightness turned round), with their
    drawing still standing out; in light mode they stay white."""
    from .panel_pictures import REPORT_IMAGE, open_report_tab  # noqa: PLC0415

    lab = start_lab(preset="triple-a")
    page, session = open_with(lab, "", viewport={"width": 1280, "height": 900}, scheme=scheme)
    open_report_tab(page)
    figure = page.locator(REPORT_IMAGE).first
    figure.scroll_into_view_if_needed()
    pictures = {"report figure": figure.screenshot()}
    page.get_by_role("tab", name="Analysis", exact=True).click()
    page.get_by_role("button", name="Work-precision chart", exact=True).click()
    wait_until(lambda: session.analysis.chart_html.content != "", timeout_s=240.0,
               message="the work-precision chart on the server")
    chart = page.locator("svg", has_text="Work-precision").first
    chart.wait_for(state="visible")
    chart.scroll_into_view_if_needed()
    page.wait_for_timeout(300)
    pictures["work-precision chart"] = chart.screenshot()
    keep_picture(page, f"figures-{scheme}")
    for name, png in pictures.items():
        median, drawn = _lightness(png)
        if scheme == "dark":
            assert median < 90, f"{name}: a light block in dark mode (median lightness {median:.0f})"
        else:
            assert median > 200, f"{name}: not on white in light mode (median lightness {median:.0f})"
        assert drawn > 0.01, f"{name}: nothing drawn stands out ({100 * drawn:.2f} % of its pixels)"


def test_every_tab_in_lecture_mode_has_no_text_under_18px_at_1920(start_lab):
    """Issue 26's target holds for the whole panel, not the first tab alone: with ``?lecture=1`` at 1920x1080
    each tab's visible text (labels, boxes, buttons, notes, tables, charts' canvas text, figures' SVG text) is at
    least 18 px."""
    lab = start_lab(preset="double")
    page, session = open_with(lab, "&lecture=1")
    assert session.lecture
    tabs = page.locator(f"{snap.CONTROL_PANEL} [role=tab]").all_inner_texts()
    assert {"Mechanism", "Simulation", "Display", "Equations", "Export", "Analysis", "Report", "Design"} <= set(tabs)
    small = {}
    for name in tabs:
        page.get_by_role("tab", name=name, exact=True).click()
        page.wait_for_timeout(1200)  # the tab drawn, its charts at the panel's width
        sizes = text_sizes(page)
        assert len(sizes) >= 10, f"{name}: its text was not measured ({sizes})"
        under = [(item["kind"], round(item["px"], 1)) for item in sizes if item["px"] < 18.0]
        if under:
            small[name] = under[:8]
    assert not small, f"text under 18 px in lecture mode at 1920x1080: {small}"
