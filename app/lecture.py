"""Lecture mode: the panel, its charts and figures readable from the back row of a lecture hall.

Switched by the Display tab's "Lecture mode" checkbox, a link's ``?lecture=1`` or the server's ``--lecture``.
What it changes is only how things are drawn, per browser (per session): a stylesheet the session puts into its
own panel (:data:`LECTURE_CSS`: every text in the panel at least :data:`TEXT_AT_1920` px at 1920 px of window
width and in proportion to the window, a wider panel, figures at the panel's width) and the uPlot charts' own
canvas text and size (:func:`chart_style`), which a stylesheet cannot reach.

Charts are registered per GUI (:func:`register`) when they are made, so that every chart of a session, whichever
part of the app made it, follows the switch, including charts made after it was thrown.
"""

from __future__ import annotations

import weakref
from typing import Any, Protocol

TEXT_AT_1920 = 18.0
"""px of the smallest text in lecture mode at a 1920 px wide window."""
TEXT_VW = 100.0 * (TEXT_AT_1920 + 0.5) / 1920.0  # a hair above 18 px at 1920, so rounding never lands below
CHART_FONT_PX = 18
"""The charts' tick and axis-label text in lecture mode (canvas text, drawn at this size in CSS pixels)."""
CHART_ASPECT = 1.5
"""Lecture mode's charts: width / height, sized to the (wider) panel."""

LECTURE_CSS = f"""<style>
/* Linkage Lab lecture mode (app/lecture.py) */
:root {{ --lecture-text: max(12px, {TEXT_VW:.4f}vw); }}
/* the floating panel keeps its top-right corner and grows leftwards (viser places it by its left edge) */
[data-testid="floating-panel"] {{
  width: max(384px, 34vw) !important; max-width: calc(100vw - 30px) !important; left: auto !important;
  right: 15px !important;
}}
[data-testid="floating-panel"] :is(p, span, label, button, input, li, td, th, code, a, div, h1, h2, h3, h4, h5, h6,
  text, tspan, .u-title, .u-legend, .u-label, .mantine-Text-root, .mantine-Tabs-tabLabel, select, option) {{
  font-size: var(--lecture-text) !important; line-height: 1.3 !important;
}}
[data-testid="floating-panel"] :is(h1, h2, h3, .u-title) {{ font-size: calc(1.15 * var(--lecture-text)) !important; }}
[data-testid="floating-panel"] .mantine-Slider-markLabel {{ font-size: var(--lecture-text) !important; }}
[data-testid="floating-panel"] input {{ min-height: calc(1.8 * var(--lecture-text)) !important; }}
[data-testid="floating-panel"] .mantine-Slider-thumb {{ width: 22px !important; height: 22px !important; }}
/* the status line: one compact block */
[data-testid="floating-panel"] .linkage-lab-status p {{ margin: 0 !important; }}
.mantine-Select-dropdown :is(.mantine-Select-option, .mantine-Combobox-option, div) {{
  font-size: var(--lecture-text) !important;
}}
.mantine-Tooltip-tooltip {{ font-size: var(--lecture-text) !important; }}
.mantine-Notification-root :is(div, p, span) {{ font-size: var(--lecture-text) !important; }}
</style>"""
"""The stylesheet a session adds to its panel while lecture mode is on (an ``<style>`` in an HTML element:
viser renders it as markup, which runs no script)."""


class Chart(Protocol):
    def set_lecture(self, on: bool) -> None: ...


_charts: "weakref.WeakKeyDictionary[Any, weakref.WeakSet]" = weakref.WeakKeyDictionary()
_on: "weakref.WeakKeyDictionary[Any, bool]" = weakref.WeakKeyDictionary()


def is_on(gui: Any) -> bool:
    """Whether lecture mode is on for the panel ``gui`` (a client's or the shared server's GUI)."""
    try:
        return _on.get(gui, False)
    except TypeError:  # a GUI that cannot be weakly referenced has no lecture mode
        return False


def register(gui: Any, chart: Chart) -> None:
    """A chart made on ``gui``: it follows :func:`switch` from now on (forgotten when the chart goes)."""
    try:
        _charts.setdefault(gui, weakref.WeakSet()).add(chart)
    except TypeError:  # a GUI that cannot be weakly referenced (a test's stand-in) has no lecture mode to follow
        return


def switch(gui: Any, on: bool) -> None:
    """Lecture mode on or off for every chart made on ``gui`` and every chart made on it later."""
    try:
        _on[gui] = bool(on)
    except TypeError:
        return
    for chart in list(_charts.get(gui, ())):
        chart.set_lecture(bool(on))


def chart_style(on: bool, x_label: str, y_label: str, height: int) -> dict:
    """uPlot options that differ in lecture mode: the axes' fonts and room, and the chart's size (lecture: sized
    to the panel's width by ``aspect``; otherwise the fixed ``height``)."""
    if not on:
        return {"axes": ({"label": x_label, "size": 36}, {"label": y_label, "size": 50}),
                "height": height, "aspect": 2.0}
    font = f"{CHART_FONT_PX}px system-ui, sans-serif"
    label_font = f"bold {CHART_FONT_PX}px system-ui, sans-serif"
    common = {"font": font, "labelFont": label_font, "labelSize": CHART_FONT_PX + 10}
    return {"axes": ({"label": x_label, "size": 2 * CHART_FONT_PX + 14, **common},
                     {"label": y_label, "size": 4 * CHART_FONT_PX + 8, **common}),
            "height": None, "aspect": CHART_ASPECT}
