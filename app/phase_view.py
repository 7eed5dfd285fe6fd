"""The phase portrait: each bar's angle against its angular velocity over the last seconds, as a small picture.

Why a picture: uPlot (viser's chart) draws series over an increasing x, and a phase portrait's x (the angle) goes
back and forth. The picture is drawn with Pillow (which viser brings) a few times a second, only while it is
the chosen plot.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from PIL import Image, ImageDraw, ImageFont

WIDTH, HEIGHT = 384, 276
MARGIN_LEFT, MARGIN_RIGHT, MARGIN_TOP, MARGIN_BOTTOM = 60, 10, 26, 44
TEXT_PX = 14  # shown at the panel's width (about 1:1), every text at least 12 px (issue 26)
LEGEND_STEP = 56  # across, between a chain's "bar k" entries
# one colour per bar (up to 12), the matplotlib "tab" colours that the bars' own colours follow
BAR_COLORS = [(31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189), (140, 86, 75),
              (227, 119, 194), (127, 127, 127), (188, 189, 34), (23, 190, 207), (57, 59, 121), (99, 121, 57)]


def _ticks(low: float, high: float, count: int = 5) -> list[float]:
    """Round tick values between ``low`` and ``high`` (1, 2 or 5 times a power of ten apart)."""
    span = max(high - low, 1e-12)
    raw = span / count
    power = 10.0 ** math.floor(math.log10(raw))
    step = min((m * power for m in (1.0, 2.0, 5.0, 10.0)), key=lambda s: abs(s - raw))
    first = math.ceil(low / step) * step
    return [first + i * step for i in range(int((high - first) / step + 1e-9) + 1)]


@functools.lru_cache(maxsize=1)
def _font() -> ImageFont.FreeTypeFont | ImageFont.ImageFont:
    """Pillow's own scalable font at :data:`TEXT_PX` (its far smaller bitmap font only where Pillow was built
    without FreeType); loaded once, not with each picture (drawn a few times a second while shown)."""
    return ImageFont.load_default(size=TEXT_PX)


def phase_picture(theta_deg: np.ndarray, omega_deg: np.ndarray, *, legend: list[str] | None = None,
                  title: str = "Phase portrait: omega (deg/s) against theta", x_label: str = "theta (deg)",
                  wrap: bool = True) -> np.ndarray:
    """An RGB picture (HEIGHT, WIDTH, 3): ``theta_deg`` (samples, bars) wrapped to [-180, 180] on x, ``omega_deg``
    on y; a line breaks where an angle wraps round. A mechanism's free coordinate may be a length: ``wrap``
    False spans x over the values instead (no wrapping), and ``legend``, ``title`` and ``x_label`` name it
    (default: a chain's bars)."""
    image = Image.new("RGB", (WIDTH, HEIGHT), (255, 255, 255))
    draw = ImageDraw.Draw(image)
    font = _font()
    x0, x1 = MARGIN_LEFT, WIDTH - MARGIN_RIGHT
    y0, y1 = MARGIN_TOP, HEIGHT - MARGIN_BOTTOM

    def text(xy: tuple[float, float], words: str, fill, centred: bool = False, right: bool = False) -> None:
        width = draw.textlength(words, font=font)
        x = min(max(xy[0] - (width / 2 if centred else width if right else 0.0), 2.0), WIDTH - width - 2.0)
        draw.text((x, xy[1]), words, fill=fill, font=font)

    text((4, 4), title, (20, 20, 20))
    values = np.asarray(theta_deg, dtype=float)
    wrapped = (values + 180.0) % 360.0 - 180.0 if wrap else values
    omega = np.asarray(omega_deg, dtype=float)
    finite = np.isfinite(omega)
    top = float(np.max(np.abs(omega[finite]))) if finite.any() else 1.0
    top = max(top * 1.1, 1.0)
    if wrap:
        left, right, x_ticks = -180.0, 180.0, [-180.0, -90.0, 0.0, 90.0, 180.0]
    else:
        shown = values[np.isfinite(values)]
        low, high = (float(shown.min()), float(shown.max())) if shown.size else (0.0, 1.0)
        pad = max(0.05 * (high - low), 1e-9)
        left, right = low - pad, high + pad
        x_ticks = _ticks(left, right, 4)

    def px(theta: np.ndarray, w: np.ndarray) -> np.ndarray:
        return np.column_stack([x0 + (theta - left) / (right - left) * (x1 - x0),
                                y1 - (w + top) / (2 * top) * (y1 - y0)])

    for value in x_ticks:
        x = x0 + (value - left) / (right - left) * (x1 - x0)
        draw.line([(x, y0), (x, y1)], fill=(235, 235, 235))
        text((x, y1 + 4), f"{value:g}", (60, 60, 60), centred=True)
    for value in _ticks(-top, top):
        y = y1 - (value + top) / (2 * top) * (y1 - y0)
        draw.line([(x0, y), (x1, y)], fill=(235, 235, 235))
        text((x0 - 4, y - TEXT_PX / 2 - 1), f"{value:g}", (60, 60, 60), right=True)
    draw.rectangle([x0, y0, x1, y1], outline=(120, 120, 120))
    text(((x0 + x1) / 2, HEIGHT - TEXT_PX - 6), x_label, (40, 40, 40), centred=True)
    if wrapped.ndim == 2 and len(wrapped) >= 2:
        for bar in range(wrapped.shape[1]):
            points = px(wrapped[:, bar], omega[:, bar])
            breaks = np.flatnonzero(np.abs(np.diff(wrapped[:, bar])) > 180.0) + 1 if wrap else np.zeros(0, int)
            for segment in np.split(np.arange(len(points)), breaks):
                if len(segment) >= 2:
                    draw.line([tuple(p) for p in points[segment]], fill=BAR_COLORS[bar % len(BAR_COLORS)], width=2)
            name = legend[bar] if legend is not None else f"bar {bar + 1}"
            if legend is None:  # a chain's bars along the plot's top, right to left, in rows when many
                per_row = max(1, int((x1 - x0 - 8) // LEGEND_STEP))
                slot = wrapped.shape[1] - 1 - bar
                xy = (x1 - LEGEND_STEP * (slot % per_row + 1), y0 + 2 + (TEXT_PX + 3) * (slot // per_row))
            else:
                xy = (x0 + 6, y1 - TEXT_PX - 6 - (TEXT_PX + 3) * bar)
            text(xy, name, BAR_COLORS[bar % len(BAR_COLORS)])
    return np.asarray(image)
