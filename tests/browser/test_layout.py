"""The default panel's layout at a laptop's 1280x720 and on a 390x844 phone, measured in Chromium (issue 26,
"Readable from the back row"): what a person needs first is on screen without scrolling."""

from __future__ import annotations

import pytest

from app import snapshot as snap

pytestmark = pytest.mark.browser

LAPTOP = {"width": 1280, "height": 720}

# How many elements of the page (or the page itself) are scrolled: "without scrolling" means none.
SCROLLED = """
() => [...document.querySelectorAll('*')].filter((e) => e.scrollTop > 0).length + (scrollY > 0 ? 1 : 0)
"""

# The first drawn slider below the tabs (the open tab's first) and the first text box below it (its number box).
FIRST_BELOW = """
(top) => {
  const panel = document.querySelector('[data-testid="floating-panel"]');
  const box = (e) => { const r = e.getBoundingClientRect(); return {x: r.x, y: r.y, width: r.width, height: r.height}; };
  const drawn = (e) => e.getBoundingClientRect().width > 0 && e.getBoundingClientRect().height > 0;
  const slider = [...panel.querySelectorAll('.mantine-Slider-root')].find((e) => drawn(e) &&
                                                                             e.getBoundingClientRect().top >= top);
  if (!slider) return {slider: null, box: null};
  const below = slider.getBoundingClientRect().bottom;
  const text = [...panel.querySelectorAll('input[type="text"], input:not([type])')].find((e) => drawn(e) &&
                                                                             e.getBoundingClientRect().top >= below);
  return {slider: box(slider), box: text ? box(text) : null};
}
"""


def _on_screen(box: dict, panel: dict, window: dict) -> bool:
    """Wholly inside the window and the panel's visible box (what shows without scrolling)."""
    return (box["y"] >= max(0.0, panel["y"]) and box["y"] + box["height"] <= min(window["height"],
                                                                                  panel["y"] + panel["height"])
            and box["x"] >= 0 and box["x"] + box["width"] <= window["width"])


@pytest.mark.parametrize("preset", ["double", "four-bar"])
def test_at_1280x720_play_the_method_menu_and_the_first_slider_show_without_scrolling(start_lab, preset):
    """Play, the open tab's first slider and its number box, and (Simulation tab) the Method menu lie inside the
    window and the panel's visible box with nothing scrolled: the tabs come before the two charts."""
    lab = start_lab(preset=preset)
    app_page = lab.open_page(viewport=LAPTOP)
    page = app_page.page
    panel = app_page.panel_box()
    tabs = page.get_by_role("tablist").first.bounding_box()
    below_tabs = page.evaluate(FIRST_BELOW, tabs["y"] + tabs["height"])
    shown = {"Play": page.get_by_role("button", name="Play", exact=True).first.bounding_box(),
             "the open tab's first slider": below_tabs["slider"],
             "its number box": below_tabs["box"]}
    assert page.evaluate(SCROLLED) == 0, "something is scrolled before the test looked"
    for name, box in shown.items():
        assert box is not None, f"{name} is not drawn"
        assert _on_screen(box, panel, LAPTOP), f"{name} is below the fold at 1280x720: {box} (panel {panel})"
    charts = [c.bounding_box() for c in page.locator(f"{snap.CONTROL_PANEL} canvas").all() if c.is_visible()]
    assert len(charts) >= 2, "the two charts are not shown"
    assert all(tabs["y"] + tabs["height"] <= chart["y"] for chart in charts), "a chart is drawn above the tabs"
    app_page.open_tab("Simulation")
    method = page.get_by_label("Method", exact=True).first
    method.wait_for(state="visible")
    assert page.evaluate(SCROLLED) == 0
    box = method.bounding_box()
    assert _on_screen(box, panel, LAPTOP), f"the Method menu is below the fold at 1280x720: {box} (panel {panel})"


# Every slider's end labels (Mantine's mark labels) and number box, with their right edges, and the panel's.
SLIDER_LABELS = """
() => {
  const panel = document.querySelector('[data-testid="floating-panel"]');
  const drawn = (e) => e.getBoundingClientRect().width > 0 && e.getBoundingClientRect().height > 0;
  const labels = [...panel.querySelectorAll('.mantine-Slider-root')].filter(drawn).flatMap((slider) =>
      [...slider.parentElement.querySelectorAll('.mantine-Slider-markLabel, input')].filter(drawn));
  return {right: panel.getBoundingClientRect().right,
          labels: labels.map((e) => [e.textContent || e.value, e.getBoundingClientRect().right])};
}
"""


def test_at_1920x1080_no_slider_label_of_a_12_bar_chain_passes_the_panel_s_right_edge(start_lab):
    """Issue 26 saw the 12-bar chain's slider end labels 17-19 px past the panel's right edge: every end label
    and number box of every slider drawn, in every tab, ends inside the panel."""
    lab = start_lab(preset="chain")
    app_page = lab.open_page(viewport={"width": 1920, "height": 1080})
    app_page.session.set_links(12)
    page = app_page.page
    page.get_by_text("bar 12: length L (m)", exact=True).first.wait_for(state="attached")
    tabs = [tab.inner_text() for tab in page.get_by_role("tab").all() if tab.is_visible()]
    checked = 0
    for tab in tabs:
        app_page.open_tab(tab)
        shown = page.evaluate(SLIDER_LABELS)
        past = [(text, right - shown["right"]) for text, right in shown["labels"] if right > shown["right"] + 0.5]
        assert not past, f"slider labels past the panel's right edge in the {tab} tab (text, px past): {past}"
        checked += len(shown["labels"])
    assert checked >= 2 * 12, f"only {checked} slider labels drawn: the 12-bar panel did not show"
