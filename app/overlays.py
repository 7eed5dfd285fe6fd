"""What is drawn on top of the mechanism: trace, plots, reaction arrows and the status line.

Each overlay is made once and then fed arrays; none of them computes physics. Plots use uPlot (``gui.add_uplot``)
with simulated seconds on the x axis (``time: False``, so uPlot does not print dates).
"""

from __future__ import annotations

import math

import numpy as np

from . import lecture
from .logs import quietly
from .scene import to_world
from .text import markdown_literal
from .viser_compat import update_node_props

TRACE_COLOR = (200, 30, 140)
TRACE_FADED = (245, 235, 242)  # the oldest end of the trace, close to the white background
REACTION_COLOR = (220, 60, 20)
# The trace's width on screen, in pixels: the same on a projector, a laptop and a phone, however small the
# mechanism is drawn (the reach is framed in the part of the canvas the panel leaves free).
TRACE_PIXELS = 4.0

# compare mode's runs (the scene's mechanisms, its key and its divergence charts all take them from here): hues far
# apart, each with a contrast ratio of at least 3 against white and against the dark panel (26, 27, 30); Lagrange's
# orange was (255, 127, 14), 2.4 against white: pale, and hard to tell from the green on a projector
METHOD_COLORS = {
    "newton_euler": (31, 119, 180),
    "lagrange": (200, 82, 0),
    "dae": (44, 160, 44),
    "reduced": (148, 103, 189),
}
# chart lines legible on the panel's white and on its near-black (dark mode): each of these has a contrast ratio of
# at least 3 against both (tests/browser/test_lecture.py measures it in the browser); a near-black line vanished
ENERGY_COLORS = ((31, 119, 180), (44, 160, 44), (230, 85, 13))  # kinetic, potential, total
RESIDUAL_COLOR = (168, 98, 62)
PLOT_POINTS = 300  # points per plotted series (downsampled), enough for a 300 px wide panel
DIVERGENCE_FLOOR = 1e-16  # log-scale plots cannot show zero


DARK_PANEL = (26, 27, 30)  # the dark scheme's panel behind the charts (viser's Mantine dark body)


def _luminance(rgb) -> float:
    """WCAG's relative luminance of an sRGB colour (0-255 channels)."""
    linear = [c / 12.92 if c <= 0.03928 else ((c + 0.055) / 1.055) ** 2.4 for c in (v / 255.0 for v in rgb[:3])]
    return 0.2126 * linear[0] + 0.7152 * linear[1] + 0.0722 * linear[2]


def chart_color(rgb) -> tuple[int, int, int]:
    """A line colour a chart can draw on the light panel: ``rgb`` darkened, hue kept, only as far as a contrast
    ratio of 3 against white needs (the tab palette's orange, olive, cyan and pink are 2.1-2.6). A colour this
    dark still has a contrast above 5 against the dark panel; a colour too dark for the dark panel (the palette's
    navy and brown) is lightened as far as a ratio of 3 against it needs, which keeps it above 5 against white.
    So one palette serves both schemes, and each line keeps the hue of the bar it plots."""
    color = tuple(float(c) for c in rgb[:3])
    while 1.05 / (_luminance(color) + 0.05) < 3.0:
        color = tuple(0.97 * c for c in color)
    dark = _luminance(DARK_PANEL) + 0.05
    while (_luminance(color) + 0.05) / dark < 3.0:  # a navy or brown, lightened towards white as far as needed
        color = tuple(c + 0.04 * (255.0 - c) for c in color)
    return (int(round(color[0])), int(round(color[1])), int(round(color[2])))


def _rgb(color) -> str:
    return "rgb({}, {}, {})".format(*color)


class TraceLine:
    """The traced point's path over the last N seconds, drawn as line segments fading towards the past."""

    def __init__(self, scene_api, name: str, color=TRACE_COLOR, thickness: float = TRACE_PIXELS) -> None:
        self.color = np.array(color, dtype=float)
        self.faded = np.array(TRACE_FADED, dtype=float)
        self.handle = scene_api.add_line_segments(
            name, points=np.zeros((1, 2, 3), np.float32), colors=np.zeros((1, 2, 3), np.uint8), thickness=thickness,
            thickness_units="screen",
        )
        self.handle.visible = False
        self.points_shown = 0
        self.shown_xy = np.zeros((0, 2))  # the path as drawn now (a picture framed on the pose includes it)
        self._colors: np.ndarray | None = None

    @property
    def name(self) -> str:
        return self.handle.name

    def update(self, xy: np.ndarray) -> None:
        """``xy`` (m, 2): the traced point's positions, oldest first."""
        m = len(xy)
        if m < 2:
            if self.handle.visible:
                self.handle.visible = False
            self.points_shown = 0
            self.shown_xy = np.zeros((0, 2))
            return
        segments = np.zeros((m - 1, 2, 3), np.float32)
        segments[:, 0, 0], segments[:, 0, 2] = xy[:-1, 0], xy[:-1, 1]  # world (x, 0, y), see scene.to_world
        segments[:, 1, 0], segments[:, 1, 2] = xy[1:, 0], xy[1:, 1]
        updates = {"points": segments}
        if self._colors is None or len(self._colors) != m - 1:  # the fade depends on the length only
            age = np.linspace(0.0, 1.0, m)  # 0 = oldest, 1 = newest
            shade = self.faded[None, :] + age[:, None] ** 1.5 * (self.color - self.faded)[None, :]
            self._colors = np.stack([shade[:-1], shade[1:]], axis=1).round().astype(np.uint8)
            updates["colors"] = self._colors
        update_node_props(self.handle, updates)  # points and colours in one message, no per-call cast
        if not self.handle.visible:
            self.handle.visible = True
        self.points_shown = m
        self.shown_xy = np.asarray(xy, dtype=float)[:, :2]


    def remove(self) -> None:
        quietly(self.handle.remove, "removing an overlay")


class ReactionArrows:
    """Joint reaction forces of the dae formulation as arrows at the joints, scaled to lengths."""

    def __init__(self, scene_api, name: str) -> None:
        self.scene_api = scene_api
        self.name = name
        self.handle = None
        self.count = 0

    def update(self, joints_xy: np.ndarray, forces: np.ndarray, scale: float, radius: float) -> None:
        """``joints_xy`` (k, 2) points of application, ``forces`` (k, 2); arrow length = scale * |force|."""
        if len(forces) == 0:
            self.hide()
            return
        start = to_world(joints_xy)
        with np.errstate(invalid="ignore", over="ignore"):
            end = to_world(joints_xy + scale * forces)
        # a force that is not finite (a run's last sample before it stopped) is no arrow: NaN or inf points
        # reach the browser's buffers as they are
        start = np.where(np.isfinite(start), start, 0.0)
        drawn = np.isfinite(end).all(axis=-1, keepdims=True)
        end = np.where(drawn, end, start)
        points = np.stack([start, end], axis=1).astype(np.float32)
        colors = np.tile(np.array(REACTION_COLOR, np.uint8), (len(forces), 1))
        if self.handle is None or self.count != len(forces):
            if self.handle is not None:
                self.handle.remove()
            self.handle = self.scene_api.add_arrows(
                self.name, points=points, colors=colors, shaft_radius=radius, head_radius=2.5 * radius,
                head_length=6 * radius,
            )
            self.count = len(forces)
        else:
            self.handle.points = points
            if not self.handle.visible:
                self.handle.visible = True

    def hide(self) -> None:
        if self.handle is not None and self.handle.visible:
            self.handle.visible = False

    def remove(self) -> None:
        if self.handle is not None:
            quietly(self.handle.remove, "removing the reaction arrows")
            self.handle = None


def _downsample(*arrays: np.ndarray, points: int = PLOT_POINTS):
    m = len(arrays[0])
    if m <= points:
        return arrays
    idx = np.linspace(0, m - 1, points).round().astype(int)
    return tuple(a[idx] for a in arrays)


def _x_axis(label: str = "simulated time (s)") -> dict:
    return {"label": label, "size": 36}


class Plot:
    """One uPlot chart: x = simulated seconds, one or more series.

    ``log``: the series are drawn as log10 of their absolute value on a linear axis (uPlot's own log axis
    labels tiny values as "0", and its tick formatters are functions, which viser cannot send).
    """

    def __init__(self, gui, title: str, labels: list[str], colors: list, *, log: bool = False, height: int = 160,
                 y_label: str = "", order: float | None = None) -> None:
        self.log = log
        self.labels = labels
        if log:
            labels = [f"log10 {label}" for label in labels]
        series = [{"label": "t (s)"}] + [
            {"label": label, "stroke": _rgb(color), "width": 1.5} for label, color in zip(labels, colors)
        ]
        data = tuple(np.zeros(2) for _ in range(len(labels) + 1))
        self._axis_labels = (_x_axis()["label"], ("log10 " + y_label).strip() if log else y_label)
        self._height = height
        self.lecture = lecture.is_on(gui)
        self.handle = gui.add_uplot(
            data=data,
            series=tuple(series),
            title=title,
            scales={"x": {"time": False, "auto": True}, "y": {"auto": True}},
            legend={"show": True, "live": False},
            order=order,
            **lecture.chart_style(self.lecture, *self._axis_labels, height),
        )
        lecture.register(gui, self)
        self.points_shown = 0

    def set_lecture(self, on: bool) -> None:
        """Lecture mode's larger canvas text and panel-wide size, or the default (app/lecture.py)."""
        if on == self.lecture:
            return
        self.lecture = on
        style = lecture.chart_style(on, *self._axis_labels, self._height)

        def apply() -> None:
            self.handle.axes = style["axes"]
            self.handle.aspect = style["aspect"]
            self.handle.height = style["height"]

        quietly(apply, "restyling a chart for lecture mode")

    def update(self, t: np.ndarray, *ys: np.ndarray) -> None:
        """The series over ``t``; a single sample (a run paused at its start) is drawn as its point, so that a
        chart never sits empty while the start is shown."""
        if len(t) < 1:
            return
        arrays = _downsample(t, *ys)
        if self.log:
            arrays = (arrays[0],) + tuple(np.log10(np.maximum(np.abs(a), DIVERGENCE_FLOOR)) for a in arrays[1:])
        arrays = tuple(np.nan_to_num(np.asarray(a, dtype=np.float64), nan=0.0, posinf=0.0, neginf=0.0) for a in arrays)
        self.handle.data = arrays
        self.points_shown = len(arrays[0])

    def clear(self) -> None:
        """No data (a new mechanism's first frame has not come yet)."""
        self.handle.data = tuple(np.zeros(2) for _ in range(len(self.labels) + 1))
        self.points_shown = 0

    def set_visible(self, visible: bool) -> None:
        if self.handle.visible != visible:
            self.handle.visible = visible

    def remove(self) -> None:
        quietly(self.handle.remove, "removing an overlay")


def relative_drift(energy: np.ndarray, reference: float, scale: float) -> np.ndarray:
    """(E - E_ref) / max(|E_ref|, scale): relative, and still defined when E_ref = 0."""
    return (energy - reference) / max(abs(reference), scale, 1e-300)


def energy_scale(m, L, g) -> float:
    """A characteristic energy of the mechanism, total weight times reach: the drift's floor denominator."""
    return float(np.sum(m) * g * np.sum(L)) or 1.0


def status_markdown(
    t: float,
    playing: bool,
    rtf: float,
    method_label: str,
    drift: float | None,
    constraint: float | None,
    notice: str | None,
    warning: bool = True,
) -> str:
    """The status line; ``notice`` is prefixed with a warning sign when ``warning`` (a refusal, a failure), not
    when it is news (a study's "Done", "Computing")."""
    state = "playing" if playing else "paused"
    # Scrubbing back moves the shown time backwards: a negative "factor" says nothing about the run's speed.
    pace = f"real-time factor {rtf:4.2f}×" if math.isfinite(rtf) and rtf >= 0 else "scrubbing"
    parts = [f"**t = {t:8.3f} s** ({state})", pace, method_label]
    if drift is not None and math.isfinite(drift):
        parts.append(f"energy error {drift:.2e}")
    if constraint is not None and math.isfinite(constraint):
        parts.append(f"constraint error {constraint:.2e}")
    text = " · ".join(parts)
    if notice:
        text += f"\n\n{'⚠ ' if warning else ''}{markdown_literal(notice)}"
    return text
