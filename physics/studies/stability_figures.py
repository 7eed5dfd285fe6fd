"""The stability study's figures (SVG), one function per figure of docs/stability.md, drawn from the result
dictionaries of :mod:`physics.studies.stability_study`.
"""

from __future__ import annotations

import math

import numpy as np

from ..status import Status
from .charts import DASHES, MARKERS, PALETTE, Series, grid_chart, line_chart

FLOOR = 1e-17  # values plotted on log axes are clamped to this (an exact zero has no logarithm)


def figure_drift(result: dict) -> str:
    colour = {"none": PALETTE[2], "baumgarte": PALETTE[0], "projection": PALETTE[4]}
    dash = {"newton_euler": DASHES[1], "lagrange": DASHES[0], "dae": DASHES[2]}
    series = [Series(f"{r['stabilization']}, {r['method']}", r["t"], floor_for_log(r["distance"]),
                     color=colour[r["stabilization"]], dash=dash[r["method"]], marker=None) for r in result["runs"]]
    return line_chart(series, title=f"Case 1: four-bar tip distance from its pin ({result['integrator']}, "
                      f"tol {result['tolerance']:g})", x_label="t (s)", y_label="|tip - pin|", log_y=True,
                      note=f"values below {FLOOR:g} drawn at {FLOOR:g}")


def binned_median(t, values, bins: int = 36) -> tuple[np.ndarray, np.ndarray]:
    """Median value in each of ``bins`` log-spaced time windows from t_end/1000 to t_end (window centres):
    flat for a bounded error, rising for a drift (a running maximum would hide the difference)."""
    t, values = np.asarray(t, float), np.asarray(values, float)
    if t.size < 2:
        return np.zeros(0), np.zeros(0)
    edges = np.geomspace(t[-1] / 1000.0, t[-1], bins + 1)
    centres, maxima = [], []
    for lo, hi in zip(edges[:-1], edges[1:]):
        inside = values[(t >= lo) & (t <= hi)]
        if inside.size:
            centres.append(math.sqrt(lo * hi))
            maxima.append(float(np.median(inside)))
    return np.array(centres), np.array(maxima)


def figure_energy(result: dict) -> str:
    series = []
    for r in result["runs"]:
        centres, maxima = binned_median(r["t"], r["error"])
        series.append(Series(f"{r['integrator']} ({r['setting']})", centres.tolist(), floor_for_log(maxima),
                             marker=None))
    return line_chart(series, title=f"Case 2: energy error over {result['t_end']:g} s, {result['preset']} "
                      f"({result['method']})", x_label="t (s)",
                      y_label="median |E - E0| / scale in the window", log_x=True, log_y=True,
                      note="each point: the median error in a log-spaced time window (flat = bounded, rising = drift)")


def figure_condition(result: dict) -> str:
    series = [Series(c["method"], c["t"], floor_for_log(c["condition"]), marker=None) for c in result["curves"]]
    return line_chart(series, title=f"Case 3: condition number, change-point four-bar released "
                      f"{result['distances'][0]:g} rad from its singular position", x_label="t (s)",
                      y_label="2-norm condition number", log_y=True)


def figure_peak_condition(result: dict) -> str:
    series = []
    for method in dict.fromkeys(r["method"] for r in result["runs"]):
        rows = [r for r in result["runs"] if r["method"] == method]
        series.append(Series(
            method, [r["distance"] for r in rows],
            [r["peak_condition"] if (r["status"] == Status.OK and r["peak_condition"]) else float("nan") for r in rows],
            point_labels=[f"{method}, {r['distance']:g} rad: {r['message']}" for r in rows],
        ))
    return line_chart(series, title="Case 3: peak condition number against release distance (gaps: the run failed)",
                      x_label="release distance from the singular position (rad)", y_label="peak condition number",
                      log_x=True, log_y=True)


def cell_outcome(cell: dict) -> tuple[str, str]:
    """``(text, colour)`` for a grid cell: green ok, amber ok but energy off by > 1e-5, red failed."""
    if cell["status"] != Status.OK:
        return f"{Status(cell['status']).short} @{cell['t_reached']:.2g}s", "#f4a6a6"
    drift = cell["energy_drift"]
    if drift is None or not drift <= 1e-5:
        return f"dE {drift:.0e}", "#f6d88a"
    return f"ok {cell['n_rhs']:.2g} RHS", "#b9e3b0"


def figure_degenerate(result: dict) -> str:
    columns: list[str] = []
    cells, labels = [], []
    for row in result["rows"]:
        if row["cells"]:
            columns = [f"{c['method']}\n{c['integrator']}" for c in row["cells"]]
    for row in result["rows"]:
        labels.append(row["scenario"])
        if row["rejected"]:
            cells.append([("rejected", "#cccccc")] * len(columns))
        else:
            cells.append([cell_outcome(c) for c in row["cells"]])
    return grid_chart(labels, columns, cells, title=f"Case 4: degenerate parameters ({result['preset']} start, "
                      f"{result['t_end']:g} s, tol {result['tolerance']:g}, midpoint step {result['step']:g})",
                      legend=[("ok (energy within 1e-5; RHS evaluations)", "#b9e3b0"), ("runs, energy off by > 1e-5", "#f6d88a"),
                              ("fails: status < 0", "#f4a6a6"), ("rejected by validation", "#cccccc")],
                      cell_width=84, row_label_width=300)


def figure_divergence(result: dict, preset_name: str = "triple-c") -> str:
    case = result["cases"][preset_name]
    series = [Series(f"{m} vs lagrange, both {result['reference_tolerance']:g}", case["t"], floor_for_log(v["distance"]),
                     color="#222222", dash=DASHES[k + 1], marker=None) for k, (m, v) in enumerate(case["methods"].items())]
    for tol, distance in case["tolerance_divergence"].items():
        series.append(Series(f"tol {tol} vs reference", case["t"], floor_for_log(distance), marker=None))
    return line_chart(series, title=f"Case 5: tip divergence, {preset_name} (DOP853; reference: lagrange at "
                      f"{result['reference_tolerance']:g})", x_label="t (s)", width=820,
                      y_label="tip distance (length units)", log_y=True,
                      hlines=[(result["threshold"], "predictability threshold")])


def figure_horizon(result: dict) -> str:
    series = []
    for k, (name, case) in enumerate(result["cases"].items()):
        for j, (integrator, rows) in enumerate(case["horizons"].items()):
            series.append(Series(
                f"{name} {integrator}", [r["tolerance"] for r in rows],
                [r["horizon"] if r["horizon"] is not None else result["t_end"] for r in rows], dash=DASHES[j],
                color=PALETTE[k % len(PALETTE)], marker=MARKERS[j % len(MARKERS)],
                point_labels=[f"{name} {integrator} tol {r['tolerance']:g}: "
                              f"{'>= ' if r['lower_bound'] else ''}{r['horizon'] or result['t_end']:g} s" for r in rows],
            ))
    return line_chart(series, title=f"Case 5: predictability horizon (tip off by > {result['threshold']:g})",
                      x_label="tolerance (rtol = atol)", y_label="horizon (s)", log_x=True,
                      y_limits=(0.0, result["t_end"]), note=f"points at {result['t_end']:g} s: no divergence within the run")


def floor_for_log(values) -> list[float]:
    return [max(float(v), FLOOR) if np.isfinite(v) else float("nan") for v in np.asarray(values, float)]
