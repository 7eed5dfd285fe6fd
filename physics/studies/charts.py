"""Charts without a plotting library: SVG line charts (linear or log axes), an SVG status grid, a
self-contained HTML page that embeds them, and PNG images of scalar fields (via Pillow, which viser
already brings).

Why hand-written: the benchmark and the stability study must run in CI and on a bare install, and a chart
is a few hundred lines of SVG; matplotlib would be a heavy extra dependency for that. Everything here is
pure text generation over plain floats, so it is deterministic and testable.
"""

from __future__ import annotations

import colorsys
import html
import io
import math
import textwrap
from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np
from PIL import Image

# Ten well-separated colours (Tableau 10) and dash patterns: colour tells one attribute of a curve
# (for example the integrator), dash another (the formulation).
PALETTE = (
    "#4e79a7", "#f28e2b", "#e15759", "#76b7b2", "#59a14f",
    "#edc948", "#b07aa1", "#ff9da7", "#9c755f", "#bab0ac",
)
DASHES = ("", "6,3", "2,3", "8,3,2,3", "1,2")
MARKERS = ("circle", "square", "triangle", "diamond", "cross")


@dataclass
class Series:
    """One curve: points ``(x[i], y[i])`` joined in order. Points that cannot be drawn (non-finite, or not
    positive on a log axis) are left out and break the line there."""

    label: str
    x: Sequence[float]
    y: Sequence[float]
    color: Optional[str] = None
    dash: str = ""
    marker: Optional[str] = "circle"
    width: float = 1.6
    point_labels: Optional[Sequence[str]] = None  # tooltips (SVG <title>) per point


@dataclass
class _Axis:
    lo: float
    hi: float
    log: bool
    pixel_lo: float
    pixel_hi: float
    ticks: list = field(default_factory=list)

    def to_pixel(self, value: float) -> float:
        a, b, v = self.lo, self.hi, value
        if self.log:
            a, b, v = math.log10(a), math.log10(b), math.log10(v)
        fraction = 0.5 if b == a else (v - a) / (b - a)
        return self.pixel_lo + fraction * (self.pixel_hi - self.pixel_lo)


def _drawable(value: float, log: bool) -> bool:
    return value is not None and math.isfinite(value) and (value > 0.0 or not log)


def _nice_step(span: float, target: int) -> float:
    raw = span / max(target, 1)
    power = 10.0 ** math.floor(math.log10(raw))
    for multiple in (1.0, 2.0, 2.5, 5.0, 10.0):
        if multiple * power >= raw:
            return multiple * power
    return 10.0 * power


def _format_tick(value: float, log: bool) -> str:
    if log:
        exponent = round(math.log10(value))
        if abs(math.log10(value) - exponent) < 1e-9:
            return f"1e{exponent}" if not -2 <= exponent <= 3 else f"{value:g}"
        return f"{value:.2g}"
    if value == 0:
        return "0"
    if abs(value) >= 1e4 or abs(value) < 1e-3:
        return f"{value:.1e}"
    return f"{value:.6g}"


def _make_axis(values: list[float], log: bool, pixel_lo: float, pixel_hi: float, limits=None,
               most: int | None = None) -> _Axis:
    """The axis over ``values`` (or ``limits``) with round ticks: about 6 steps (8 decades on a log axis), or at
    most ``most`` when given (a narrow figure's ticks at a readable size must not touch)."""
    if limits is not None:
        lo, hi = limits
    elif values:
        lo, hi = min(values), max(values)
    else:
        lo, hi = (1.0, 10.0) if log else (0.0, 1.0)
    if log:
        lo = 10.0 ** math.floor(math.log10(lo) + 1e-9)
        hi = 10.0 ** math.ceil(math.log10(hi) - 1e-9)
        if hi <= lo:
            hi = lo * 10.0
        decades = int(round(math.log10(hi / lo)))
        stride = max(1, int(math.ceil(decades / (most or 8))))
        ticks = [lo * 10.0**k for k in range(0, decades + 1, stride)]
    else:
        if hi <= lo:
            lo, hi = lo - 0.5 * (abs(lo) or 1.0), hi + 0.5 * (abs(hi) or 1.0)
        step = _nice_step(hi - lo, min(6, most or 6))
        lo = math.floor(lo / step + 1e-9) * step
        hi = math.ceil(hi / step - 1e-9) * step
        count = int(round((hi - lo) / step))
        ticks = [lo + k * step for k in range(count + 1)]
    return _Axis(lo, hi, log, pixel_lo, pixel_hi, ticks)


def _esc(text) -> str:
    return html.escape(str(text), quote=True)


def _marker_svg(kind: str, x: float, y: float, color: str, tooltip: str | None) -> str:
    r = 3.2
    title = f"<title>{_esc(tooltip)}</title>" if tooltip else ""
    if kind == "square":
        shape = f'<rect x="{x - r:.1f}" y="{y - r:.1f}" width="{2 * r:.1f}" height="{2 * r:.1f}" fill="{color}">'
        return shape + title + "</rect>"
    if kind == "triangle":
        points = f"{x:.1f},{y - r - 0.8:.1f} {x - r - 0.5:.1f},{y + r:.1f} {x + r + 0.5:.1f},{y + r:.1f}"
        return f'<polygon points="{points}" fill="{color}">{title}</polygon>'
    if kind == "diamond":
        points = f"{x:.1f},{y - r - 1:.1f} {x + r + 1:.1f},{y:.1f} {x:.1f},{y + r + 1:.1f} {x - r - 1:.1f},{y:.1f}"
        return f'<polygon points="{points}" fill="{color}">{title}</polygon>'
    if kind == "cross":
        d = f"M{x - r:.1f},{y - r:.1f}L{x + r:.1f},{y + r:.1f}M{x - r:.1f},{y + r:.1f}L{x + r:.1f},{y - r:.1f}"
        return f'<path d="{d}" stroke="{color}" stroke-width="1.8">{title}</path>'
    return f'<circle cx="{x:.1f}" cy="{y:.1f}" r="{r:.1f}" fill="{color}">{title}</circle>'


def _curves_svg(series: Sequence[Series], x_axis: _Axis, y_axis: _Axis) -> list[str]:
    """Each series as paths (broken where a point cannot be drawn) and markers, clipped to the plot (``#plot``)."""
    log_x, log_y = x_axis.log, y_axis.log
    out: list[str] = []
    for index, s in enumerate(series):
        color = s.color or PALETTE[index % len(PALETTE)]
        segments, current, markers = [], [], []
        labels: list[str | None] = list(s.point_labels) if s.point_labels is not None else [None] * len(s.x)
        for x_value, y_value, point_label in zip(s.x, s.y, labels):
            xv, yv = float(x_value), float(y_value)
            if _drawable(xv, log_x) and _drawable(yv, log_y):
                point = (x_axis.to_pixel(xv), y_axis.to_pixel(yv))
                current.append(point)
                markers.append((point, point_label))
            elif current:
                segments.append(current)
                current = []
        if current:
            segments.append(current)
        group = [f'<g clip-path="url(#plot)"><title>{_esc(s.label)}</title>']
        for segment in segments:
            if len(segment) > 1:
                d = "M" + "L".join(f"{px:.1f},{py:.1f}" for px, py in segment)
                dash = f' stroke-dasharray="{s.dash}"' if s.dash else ""
                group.append(f'<path d="{d}" fill="none" stroke="{color}" stroke-width="{s.width}"{dash}/>')
        if s.marker and len(markers) <= 400:
            for (px, py), point_label in markers:
                group.append(_marker_svg(s.marker, px, py, color, point_label))
        group.append("</g>")
        out.extend(group)
    return out


def line_chart(
    series: Sequence[Series],
    *,
    title: str,
    x_label: str,
    y_label: str,
    log_x: bool = False,
    log_y: bool = False,
    width: int = 760,
    height: int = 480,
    x_limits: Optional[tuple[float, float]] = None,
    y_limits: Optional[tuple[float, float]] = None,
    hlines: Sequence[tuple[float, str]] = (),
    note: str = "",
    legend_below: bool = False,
) -> str:
    """An SVG line chart with axes, grid, ticks, a legend to the right (or, with ``legend_below``, under the
    plot, one entry per line: for a narrow panel), and optional horizontal reference lines ``(y, label)``.
    ``height`` is the plot's part; a legend below adds its own. Returns the SVG text (UTF-8, self-contained)."""
    longest = max((len(s.label) for s in series), default=0)
    legend_width = 0 if legend_below or not series else int(min(380, 50 + 6.3 * longest))
    legend_rows = len(series) if legend_below else 0
    plot_height = height
    height = plot_height + 17 * legend_rows + (8 if legend_rows else 0)
    left, right, top, bottom = 78, width - legend_width - 16, 40, plot_height - 58
    xs = [float(v) for s in series for v, w in zip(s.x, s.y) if _drawable(float(v), log_x) and _drawable(float(w), log_y)]
    ys = [float(w) for s in series for v, w in zip(s.x, s.y) if _drawable(float(v), log_x) and _drawable(float(w), log_y)]
    ys += [float(v) for v, _ in hlines if _drawable(float(v), log_y)]
    x_axis = _make_axis(xs, log_x, left, right, x_limits)
    y_axis = _make_axis(ys, log_y, bottom, top, y_limits)
    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
        f'viewBox="0 0 {width} {height}" font-family="Helvetica, Arial, sans-serif" font-size="12">',
        f'<rect x="0" y="0" width="{width}" height="{height}" fill="white"/>',
        f'<text x="12" y="22" font-size="15" font-weight="bold">{_esc(title)}</text>',
    ]
    # Grid and ticks.
    for tick in x_axis.ticks:
        px = x_axis.to_pixel(tick)
        out.append(f'<line x1="{px:.1f}" y1="{top}" x2="{px:.1f}" y2="{bottom}" stroke="#e3e3e3"/>')
        out.append(f'<text x="{px:.1f}" y="{bottom + 16}" text-anchor="middle">{_esc(_format_tick(tick, log_x))}</text>')
    for tick in y_axis.ticks:
        py = y_axis.to_pixel(tick)
        out.append(f'<line x1="{left}" y1="{py:.1f}" x2="{right}" y2="{py:.1f}" stroke="#e3e3e3"/>')
        out.append(f'<text x="{left - 6}" y="{py + 4:.1f}" text-anchor="end">{_esc(_format_tick(tick, log_y))}</text>')
    out.append(f'<rect x="{left}" y="{top}" width="{right - left}" height="{bottom - top}" fill="none" stroke="#444"/>')
    out.append(
        f'<text x="{(left + right) / 2:.1f}" y="{plot_height - 22}" text-anchor="middle" font-size="13">'
        f'{_esc(x_label)}</text>'
    )
    out.append(
        f'<text x="18" y="{(top + bottom) / 2:.1f}" text-anchor="middle" font-size="13" '
        f'transform="rotate(-90 18 {(top + bottom) / 2:.1f})">{_esc(y_label)}</text>'
    )
    if note:
        out.append(f'<text x="{left if not legend_below else 12}" y="{plot_height - 6}" font-size="10" '
                   f'fill="#666">{_esc(note)}</text>')
    out.append(f'<clipPath id="plot"><rect x="{left}" y="{top}" width="{right - left}" height="{bottom - top}"/></clipPath>')
    for value, label in hlines:
        if not _drawable(float(value), log_y):
            continue
        py = y_axis.to_pixel(float(value))
        out.append(f'<line x1="{left}" y1="{py:.1f}" x2="{right}" y2="{py:.1f}" stroke="#999" stroke-dasharray="4,4"/>')
        out.append(f'<text x="{right - 4}" y="{py - 4:.1f}" text-anchor="end" font-size="10" fill="#666">{_esc(label)}</text>')
    out.extend(_curves_svg(series, x_axis, y_axis))
    # Legend.
    if series:
        lx = 12 if legend_below else right + 18
        for index, s in enumerate(series):
            color = s.color or PALETTE[index % len(PALETTE)]
            ly = (plot_height + 10 + 17 * index) if legend_below else (top + 8 + 17 * index)
            dash = f' stroke-dasharray="{s.dash}"' if s.dash else ""
            out.append(f'<line x1="{lx}" y1="{ly}" x2="{lx + 26}" y2="{ly}" stroke="{color}" stroke-width="2"{dash}/>')
            if s.marker:
                out.append(_marker_svg(s.marker, lx + 13, ly, color, None))
            out.append(f'<text x="{lx + 32}" y="{ly + 4}" font-size="11">{_esc(s.label)}</text>')
    out.append("</svg>")
    return "\n".join(out) + "\n"


PANEL_WIDTH = 380
"""px: the natural width of a figure drawn for the app's panel (about the panel's width, 384 px at 1920 x 1080, so
it is shown at nearly 1:1 and its text keeps its size)."""
PANEL_TEXT_PX = 14
"""px: the smallest text of a figure drawn for the panel, at :data:`PANEL_WIDTH` (shown a little narrower than
drawn, it stays above 12 px)."""


def _lines(text: str, text_px: float, room: float, bold: bool = False) -> list[str]:
    """``text`` broken at spaces into lines that fit ``room`` px at ``text_px`` (a sans-serif character is about
    0.55 em wide on average, 0.6 em in bold)."""
    chars = max(8, int(room / ((0.6 if bold else 0.55) * text_px)))
    return textwrap.wrap(str(text), chars) or [""]


def _text_lines(lines: Sequence[str], x: float, y: float, step: float, attributes: str = "") -> str:
    spans = "".join(f'<tspan x="{x:.1f}" dy="{0 if k == 0 else step:.1f}">{_esc(line)}</tspan>'
                    for k, line in enumerate(lines))
    return f'<text x="{x:.1f}" y="{y:.1f}"{attributes}>{spans}</text>'


def panel_line_chart(
    series: Sequence[Series],
    *,
    title: str,
    x_label: str,
    y_label: str,
    log_x: bool = False,
    log_y: bool = False,
    width: int = PANEL_WIDTH,
    plot_height: int = 260,
    text_px: float = PANEL_TEXT_PX,
    x_limits: Optional[tuple[float, float]] = None,
    y_limits: Optional[tuple[float, float]] = None,
    hlines: Sequence[tuple[float, str]] = (),
    note: str = "",
) -> str:
    """:func:`line_chart` drawn for the app's panel: about the panel's width, every text at least ``text_px``,
    the title, legend and note wrapped to the width and stacked under one another, and no more ticks than fit
    side by side at that size. ``plot_height`` is the plot's frame; the figure is as tall as its text needs.

    Why a layout of its own: a chart drawn 900 px wide with 10-13 px text and shrunk to a 384-px panel shows its
    text 4-5 px tall; a figure is readable in the panel only if it is drawn for it."""
    f = float(text_px)
    line = 1.25 * f
    title_lines = _lines(title, f + 1, width - 20, bold=True)
    top = 8 + len(title_lines) * line + 0.7 * f + 6
    left, right = 1.6 * f + 5 * 0.6 * f + 10, width - 1.6 * f
    bottom = top + plot_height
    xs = [float(v) for s in series for v, w in zip(s.x, s.y) if _drawable(float(v), log_x) and _drawable(float(w), log_y)]
    ys = [float(w) for s in series for v, w in zip(s.x, s.y) if _drawable(float(v), log_x) and _drawable(float(w), log_y)]
    ys += [float(v) for v, _ in hlines if _drawable(float(v), log_y)]
    x_axis = _make_axis(xs, log_x, left, right, x_limits, most=max(2, int((right - left) // (4.2 * f))))
    y_axis = _make_axis(ys, log_y, bottom, top, y_limits, most=max(2, int((bottom - top) // (2.2 * f))))
    legend = [(k, s, _lines(s.label, f, width - 12 - 40)) for k, s in enumerate(series)]
    legend_top = bottom + 2 * f + 14 + line
    notes = _lines(note, f, width - 20) if note else []
    notes_top = legend_top + sum(len(lines) for _, _, lines in legend) * line + 4
    height = int(math.ceil(notes_top + len(notes) * line + 6))
    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
        f'viewBox="0 0 {width} {height}" font-family="Helvetica, Arial, sans-serif" font-size="{f:g}">',
        f'<rect x="0" y="0" width="{width}" height="{height}" fill="white"/>',
        _text_lines(title_lines, 10, 8 + f, line, f' font-size="{f + 1:g}" font-weight="bold"'),
    ]
    for tick in x_axis.ticks:
        px = x_axis.to_pixel(tick)
        out.append(f'<line x1="{px:.1f}" y1="{top:.1f}" x2="{px:.1f}" y2="{bottom:.1f}" stroke="#e3e3e3"/>')
        out.append(f'<text x="{px:.1f}" y="{bottom + f + 3:.1f}" text-anchor="middle">'
                   f'{_esc(_format_tick(tick, log_x))}</text>')
    for tick in y_axis.ticks:
        py = y_axis.to_pixel(tick)
        out.append(f'<line x1="{left:.1f}" y1="{py:.1f}" x2="{right:.1f}" y2="{py:.1f}" stroke="#e3e3e3"/>')
        out.append(f'<text x="{left - 4:.1f}" y="{py + 0.35 * f:.1f}" text-anchor="end">'
                   f'{_esc(_format_tick(tick, log_y))}</text>')
    out.append(f'<rect x="{left:.1f}" y="{top:.1f}" width="{right - left:.1f}" height="{bottom - top:.1f}" '
               'fill="none" stroke="#444"/>')
    out.append(f'<text x="{(left + right) / 2:.1f}" y="{bottom + 2 * f + 8:.1f}" text-anchor="middle">'
               f'{_esc(x_label)}</text>')
    middle = (top + bottom) / 2
    out.append(f'<text x="{f + 1:.1f}" y="{middle:.1f}" text-anchor="middle" '
               f'transform="rotate(-90 {f + 1:.1f} {middle:.1f})">{_esc(y_label)}</text>')
    out.append(f'<clipPath id="plot"><rect x="{left:.1f}" y="{top:.1f}" width="{right - left:.1f}" '
               f'height="{bottom - top:.1f}"/></clipPath>')
    for value, label in hlines:
        if not _drawable(float(value), log_y):
            continue
        py = y_axis.to_pixel(float(value))
        out.append(f'<line x1="{left:.1f}" y1="{py:.1f}" x2="{right:.1f}" y2="{py:.1f}" stroke="#999" '
                   'stroke-dasharray="4,4"/>')
        out.append(f'<text x="{right - 4:.1f}" y="{py - 4:.1f}" text-anchor="end" fill="#555">{_esc(label)}</text>')
    out.extend(_curves_svg(series, x_axis, y_axis))
    y = legend_top
    for index, s, lines in legend:
        color = s.color or PALETTE[index % len(PALETTE)]
        ly = y - 0.35 * f
        dash = f' stroke-dasharray="{s.dash}"' if s.dash else ""
        out.append(f'<line x1="10" y1="{ly:.1f}" x2="36" y2="{ly:.1f}" stroke="{color}" stroke-width="2"{dash}/>')
        if s.marker:
            out.append(_marker_svg(s.marker, 23, ly, color, None))
        out.append(_text_lines(lines, 42, y, line))
        y += len(lines) * line
    if notes:
        out.append(_text_lines(notes, 10, notes_top + f, line, ' fill="#555"'))
    out.append("</svg>")
    return "\n".join(out) + "\n"


def grid_chart(
    row_labels: Sequence[str],
    column_labels: Sequence[str],
    cells: Sequence[Sequence[tuple[str, str]]],
    *,
    title: str,
    legend: Sequence[tuple[str, str]] = (),
    cell_width: int = 92,
    row_label_width: int = 250,
) -> str:
    """A table as SVG: ``cells[r][c] = (text, color)``, e.g. the outcome of every (case, method) pair."""
    header_height = 70
    cell_height = 26
    width = row_label_width + cell_width * len(column_labels) + 20
    height = header_height + cell_height * len(row_labels) + 40 + (18 if legend else 0)
    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
        f'viewBox="0 0 {width} {height}" font-family="Helvetica, Arial, sans-serif" font-size="11">',
        f'<rect x="0" y="0" width="{width}" height="{height}" fill="white"/>',
        f'<text x="10" y="20" font-size="15" font-weight="bold">{_esc(title)}</text>',
    ]
    for c, label in enumerate(column_labels):
        cx = row_label_width + c * cell_width + cell_width / 2
        for k, part in enumerate(str(label).split("\n")):
            out.append(f'<text x="{cx:.1f}" y="{header_height - 24 + 13 * k}" text-anchor="middle">{_esc(part)}</text>')
    for r, label in enumerate(row_labels):
        y = header_height + r * cell_height
        out.append(f'<text x="10" y="{y + 17}">{_esc(label)}</text>')
        for c in range(len(column_labels)):
            text, color = cells[r][c]
            x = row_label_width + c * cell_width
            out.append(
                f'<rect x="{x + 1}" y="{y + 1}" width="{cell_width - 2}" height="{cell_height - 2}" fill="{color}">'
                f"<title>{_esc(text)}</title></rect>"
            )
            out.append(f'<text x="{x + cell_width / 2:.1f}" y="{y + 17}" text-anchor="middle">{_esc(text)}</text>')
    if legend:
        y = header_height + len(row_labels) * cell_height + 24
        x = 10
        for text, color in legend:
            out.append(f'<rect x="{x}" y="{y - 11}" width="14" height="14" fill="{color}"/>')
            out.append(f'<text x="{x + 19}" y="{y}">{_esc(text)}</text>')
            x += 30 + 7 * len(text)
    out.append("</svg>")
    return "\n".join(out) + "\n"


def html_table(header: Sequence[str], rows: Sequence[Sequence]) -> str:
    cells = "".join(f"<th>{_esc(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{_esc(v)}</td>" for v in row) + "</tr>" for row in rows)
    return f"<table><thead><tr>{cells}</tr></thead><tbody>{body}</tbody></table>"


def html_page(title: str, sections: Sequence[tuple[str, str]], intro: str = "") -> str:
    """A self-contained HTML page: ``sections`` are ``(heading, html_or_svg)``; SVG is embedded inline, so the
    file needs nothing else to display."""
    style = (
        "body{font-family:Helvetica,Arial,sans-serif;max-width:1100px;margin:2em auto;color:#222}"
        "table{border-collapse:collapse;margin:0.5em 0 1.5em;font-size:13px}"
        "td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}th{background:#f3f3f3}"
        "p.intro{color:#444}"
    )
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{_esc(title)}</title><style>{style}</style></head><body>",
        f"<h1>{_esc(title)}</h1>",
    ]
    if intro:
        parts.append(f'<p class="intro">{intro}</p>')
    for heading, content in sections:
        parts.append(f"<h2>{_esc(heading)}</h2>")
        parts.append(content)
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


# ------------------------------------------------------------------------------------------------
# Images

# Control points of a perceptually ordered colour map (viridis, sampled at 9 points), interpolated linearly.
_VIRIDIS = np.array(
    [
        [68, 1, 84], [71, 44, 122], [59, 81, 139], [44, 113, 142], [33, 144, 141],
        [39, 173, 129], [92, 200, 99], [170, 220, 50], [253, 231, 37],
    ],
    dtype=float,
)


def colormap(values: np.ndarray, missing_rgb=(0, 0, 0)) -> np.ndarray:
    """Map ``values`` in [0, 1] to RGB ``uint8`` (shape ``values.shape + (3,)``); NaN gets ``missing_rgb``."""
    values = np.asarray(values, dtype=float)
    valid = np.isfinite(values)
    scaled = np.clip(np.where(valid, values, 0.0), 0.0, 1.0) * (len(_VIRIDIS) - 1)
    low = np.minimum(np.floor(scaled).astype(int), len(_VIRIDIS) - 2)
    fraction = (scaled - low)[..., None]
    rgb = _VIRIDIS[low] * (1.0 - fraction) + _VIRIDIS[low + 1] * fraction
    rgb[~valid] = missing_rgb
    return np.round(rgb).astype(np.uint8)


def png_bytes(rgb: np.ndarray) -> bytes:
    """An ``(H, W, 3)`` uint8 image encoded as PNG (Pillow, a dependency of viser)."""
    buffer = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(rgb, dtype=np.uint8)).save(buffer, format="PNG")
    return buffer.getvalue()


def write_png(path, rgb: np.ndarray) -> None:
    """Write an ``(H, W, 3)`` uint8 image as PNG with Pillow (a dependency of viser)."""
    Image.fromarray(np.ascontiguousarray(rgb, dtype=np.uint8)).save(path, format="PNG")


def fan_picture(joints: np.ndarray, alive: np.ndarray, size: int = 600) -> np.ndarray:
    """``(size, size, 3)`` picture of every copy's links from joints ``(N, n + 1, 2)`` (one hue per copy; copies
    not ``alive`` left out), the pivot in the middle: an ensemble's fan, for ``python -m physics ensemble``."""
    finite = np.abs(joints[np.isfinite(joints)])  # a failed copy's points may be NaN (it is not drawn)
    reach = max(float(finite.max()) if finite.size else 0.0, 1e-9) * 1.05
    image = np.full((size, size, 3), 255, dtype=np.uint8)
    count = joints.shape[0]
    samples = np.linspace(0.0, 1.0, 2 * size)[:, None]
    for k in np.flatnonzero(alive):
        colour = np.array(colorsys.hsv_to_rgb(k / max(count, 1), 0.8, 0.8)) * 255.0
        for a, b in zip(joints[k, :-1], joints[k, 1:]):
            points = a + samples * (b - a)
            col = np.clip(((points[:, 0] / reach + 1.0) * 0.5 * (size - 1)).round().astype(int), 0, size - 1)
            row = np.clip(((1.0 - (points[:, 1] / reach + 1.0) * 0.5) * (size - 1)).round().astype(int), 0, size - 1)
            image[row, col] = colour.astype(np.uint8)
    centre = size // 2
    image[centre - 3:centre + 4, centre - 3:centre + 4] = 0
    return image
