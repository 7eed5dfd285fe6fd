"""Compare mode's run colours and the energy colours: one source each (app/overlays.py), legible on the light and
the dark panel and told apart from each other (issue 26: "compare-mode traces are pale and hard to tell apart")."""

from __future__ import annotations

import colorsys
import itertools

from app.mechanism_compare import COMPARE_METHODS
from app.overlays import DARK_PANEL, ENERGY_COLORS, METHOD_COLORS, chart_color
from app.phase_view import BAR_COLORS
from conftest import lab_of, wait_until

BACKGROUNDS = {"light": (255, 255, 255), "dark": (26, 27, 30)}  # the panel's white and Mantine's dark body
MIN_CONTRAST = 3.0  # WCAG's ratio for graphics
MIN_HUE_APART = 60.0  # degrees of hue between any two runs' colours


def _luminance(rgb) -> float:
    linear = [c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4 for c in (v / 255 for v in rgb)]
    return 0.2126 * linear[0] + 0.7152 * linear[1] + 0.0722 * linear[2]


def _contrast(a, b) -> float:
    high, low = sorted((_luminance(a), _luminance(b)), reverse=True)
    return (high + 0.05) / (low + 0.05)


def _hue_apart(a, b) -> float:
    ha = colorsys.rgb_to_hsv(*(v / 255 for v in a))[0] * 360
    hb = colorsys.rgb_to_hsv(*(v / 255 for v in b))[0] * 360
    return min(abs(ha - hb), 360 - abs(ha - hb))


def test_compare_runs_and_energy_lines_are_legible_on_both_panels():
    faint = [(name, scheme, round(_contrast(color, background), 2))
             for name, color in [*((m, METHOD_COLORS[m]) for m in COMPARE_METHODS),
                                 *zip(("kinetic", "potential", "total"), ENERGY_COLORS)]
             for scheme, background in BACKGROUNDS.items() if _contrast(color, background) < MIN_CONTRAST]
    assert not faint, f"colours under a contrast of {MIN_CONTRAST} (name, panel, contrast): {faint}"


def test_compare_runs_are_told_apart_by_hue():
    close = [(a, b, round(_hue_apart(METHOD_COLORS[a], METHOD_COLORS[b]))) for a, b in
             itertools.combinations(COMPARE_METHODS, 2) if _hue_apart(METHOD_COLORS[a], METHOD_COLORS[b]) < MIN_HUE_APART]
    assert not close, f"compare-mode runs whose hues lie closer than {MIN_HUE_APART}°: {close}"


slider_lab = lab_of("slider-crank")


def _strokes(plot) -> list[str]:
    return [s["stroke"] for s in plot.handle.series[1:]]


def _rgb(color) -> str:
    return "rgb({}, {}, {})".format(*color)


def test_every_energy_chart_and_compare_chart_draws_the_one_palette(connect, slider_lab):
    """A chain's and a mechanism's Energy chart draw kinetic, potential and total in ENERGY_COLORS; compare mode's
    divergence chart draws each run in METHOD_COLORS (as its scene and key do, tests/app/test_compare_key.py)."""
    for server in (None, slider_lab):
        _, session = connect(server)
        session.player.pause()
        assert _strokes(session.energy_plot) == [_rgb(c) for c in ENERGY_COLORS]
    _, session = connect()
    session.player.pause()
    session.set_compare(True)
    assert wait_until(lambda: session.compare_view is not None and session.compare_view.between is not None, 60)
    assert _strokes(session.compare_view.between) == [_rgb(METHOD_COLORS[m]) for m in COMPARE_METHODS[1:]]


def test_every_bar_colour_drawn_in_a_chart_stands_out_on_both_panels_with_its_hue():
    """Issue 26: the Angles chart drew each bar's line in the bar's tab colour, and the orange, olive, cyan and pink
    have a contrast of 2.1-2.6 on the light panel (the navy 1.7 on the dark one). A chart draws them through
    ``chart_color``: at least 3 against both panels, the hue kept."""
    contrast = _contrast
    assert min(contrast(color, (255, 255, 255)) for color in BAR_COLORS) < 3.0  # the palette alone fails
    for color in BAR_COLORS:
        drawn = chart_color(color)
        assert contrast(drawn, (255, 255, 255)) >= 3.0 and contrast(drawn, DARK_PANEL) >= 3.0, (color, drawn)
        hue, hue_drawn = (colorsys.rgb_to_hsv(*(c / 255 for c in rgb))[0] for rgb in (color, drawn))
        assert min(abs(hue - hue_drawn), 1 - abs(hue - hue_drawn)) < 0.02, (color, drawn)
