"""The stability study: where each formulation and integrator keeps working and where it fails, as five
functions (one per case of docs/stability.md), their figures, and the "cheapest model" measurements.

``python -m physics.stability --out docs/stability [--case 1,2,3,4,5] [--quick]`` writes every figure (SVG)
and ``stability.json``; docs/stability.md shows them with their numbers. Each case function takes its sizes
as arguments, so the tests run the same code on shorter horizons.

1. :func:`closed_loop_drift`: the four-bar's tip distance from its pin over 100 s without stabilisation,
   with Baumgarte and with projection.
2. :func:`energy_drift`: relative energy error over 1000 s per integrator (bounded for the variational
   integrator, growing for the others; the implicit midpoint rule is bounded only on a single bar).
3. :func:`singular_approach`: the change-point four-bar released ever closer to its singular position: the
   condition number of each formulation's system against time, and what each method does.
4. :func:`degenerate`: bars without inertia, very light tips, extreme mass ratios: which method and
   integrator keep working, which fail, and the status and message they fail with.
5. :func:`chaos_divergence`: divergence between formulations and between tolerances, and the
   predictability horizon of each seed case against tolerance.
"""

from __future__ import annotations

import json
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from .errors import LinkageError
from .model import FIXED_STEP_INTEGRATORS, FORMULATION_NAMES, INTEGRATOR_NAMES, Settings

FLOOR = 1e-17  # values plotted on log axes are clamped to this (an exact zero has no logarithm)


def _run(chain, theta0, omega0, **fields):
    """simulate() and its wall time (a failure midway comes back in status and message)."""
    from .simulate import simulate

    start = time.perf_counter()
    trajectory = simulate(chain, theta0, omega0, Settings(**fields))
    return trajectory, time.perf_counter() - start


def _knob(integrator: str, tolerance: float, step: float) -> dict:
    """Settings fields for an integrator's accuracy knob: a fixed step, or rtol = atol (scipy-only ones on scipy)."""
    if integrator in FIXED_STEP_INTEGRATORS:
        return {"step": step}
    fields = {"rtol": tolerance, "atol": tolerance}
    if integrator in ("Radau", "LSODA"):
        fields["backend"] = "scipy"
    return fields


def _knob_label(integrator: str, tolerance: float, step: float) -> str:
    return f"step {step:g} s" if integrator in FIXED_STEP_INTEGRATORS else f"tol {tolerance:g}"


def _floor(values) -> list[float]:
    return [max(float(v), FLOOR) if np.isfinite(v) else float("nan") for v in np.asarray(values, float)]


def _dist(xy) -> np.ndarray:
    xy = np.asarray(xy, float)
    return np.hypot(xy[:, 0], xy[:, 1]) if xy.size else np.zeros(0)


# ------------------------------------------------------------------------------------------------
# Case 1: closed-loop drift


def closed_loop_drift(t_end: float = 100.0, samples: int = 1001, tolerance: float = 1e-8,
                      methods=FORMULATION_NAMES, integrator: str = "DOP853") -> dict:
    """Four-bar, every formulation x {none, baumgarte, projection}: |tip - pin| against time."""
    from .presets import get_preset

    preset = get_preset("four-bar")
    runs = []
    t = None
    for stabilization in ("none", "baumgarte", "projection"):
        for method in methods:
            trajectory, seconds = _run(preset.chain, preset.theta0, preset.omega0, method=method,
                                       integrator=integrator, rtol=tolerance, atol=tolerance, t_end=t_end,
                                       samples=samples, stabilization=stabilization)
            distance = _dist(trajectory.constraint_xy)
            t = trajectory.t if t is None or len(trajectory.t) > len(t) else t
            runs.append({
                "method": method, "stabilization": stabilization, "status": trajectory.status,
                "message": trajectory.message, "seconds": seconds, "t": trajectory.t.tolist(),
                "distance": distance.tolist(),
                "max_distance": float(distance.max()) if distance.size else None,
                "final_distance": float(distance[-1]) if distance.size else None,
                "energy_drift": trajectory.energy_drift(),
            })
    return {"case": 1, "preset": "four-bar", "t_end": t_end, "tolerance": tolerance, "integrator": integrator,
            "runs": runs}


def figure_drift(result: dict) -> str:
    from .charts import DASHES, PALETTE, Series, line_chart

    colour = {"none": PALETTE[2], "baumgarte": PALETTE[0], "projection": PALETTE[4]}
    dash = {"newton_euler": DASHES[1], "lagrange": DASHES[0], "dae": DASHES[2]}
    series = [Series(f"{r['stabilization']}, {r['method']}", r["t"], _floor(r["distance"]),
                     color=colour[r["stabilization"]], dash=dash[r["method"]], marker=None) for r in result["runs"]]
    return line_chart(series, title=f"Case 1: four-bar tip distance from its pin ({result['integrator']}, "
                      f"tol {result['tolerance']:g})", x_label="t (s)", y_label="|tip - pin|", log_y=True,
                      note=f"values below {FLOOR:g} drawn at {FLOOR:g}")


# ------------------------------------------------------------------------------------------------
# Case 2: energy drift per integrator


def energy_drift(preset_name: str = "triple-a", t_end: float = 1000.0, samples: int = 4001,
                 tolerance: float = 1e-8, step: float = 0.005, integrators=INTEGRATOR_NAMES,
                 method: str = "lagrange") -> dict:
    """|E(t) - E(0)| / scale for each integrator (scale: |E0|, or the largest |T| or |V| if larger, so that
    E0 = 0 is fine). ``growth`` = the median error in [t_end/2, t_end] over the median in [t_end/10, t_end/5]:
    about 5 for a secular (linear) drift, about 1 for a bounded one. ``slope``: the log-log slope of the
    windowed medians (:func:`binned_median`) over the last decade of time: 1 for a linear drift, 0.5 for a
    random walk, 0 for a bounded error. Medians, not maxima: a symplectic integrator's energy error is an
    oscillation whose peaks follow the fastest states the motion happens to visit (spiky on chaotic motion),
    while a drift moves the whole distribution; ``max_error`` reports the peak."""
    from .presets import get_preset

    preset = get_preset(preset_name)
    runs = []
    for integrator in integrators:
        trajectory, seconds = _run(preset.chain, preset.theta0, preset.omega0, method=method, integrator=integrator,
                                   t_end=t_end, samples=samples, **_knob(integrator, tolerance, step))
        # As Trajectory.energy_drift: relative to |E0|, or to the largest |T| or |V| when E0 is near zero.
        scale = max(abs(float(trajectory.energy[0])), float(np.max(np.abs(trajectory.kinetic))),
                    float(np.max(np.abs(trajectory.potential))), 1e-300) if trajectory.energy.size else 1.0
        error = np.abs(trajectory.energy - trajectory.energy[0]) / scale if trajectory.energy.size else np.zeros(0)
        t = trajectory.t
        early = error[(t >= t_end / 10) & (t <= t_end / 5)]
        late = error[t >= t_end / 2]
        growth = float(np.median(late) / max(np.median(early), 1e-300)) if early.size and late.size else None
        centres, medians = binned_median(t, error)
        fit = (centres >= t_end / 10) & (medians > 0)
        slope = float(np.polyfit(np.log10(centres[fit]), np.log10(medians[fit]), 1)[0]) if fit.sum() >= 3 else None
        runs.append({
            "integrator": integrator, "setting": _knob_label(integrator, tolerance, step),
            "status": trajectory.status, "message": trajectory.message, "seconds": seconds, "n_rhs": trajectory.n_rhs,
            "t": t.tolist(), "error": error.tolist(), "max_error": float(error.max()) if error.size else None,
            "growth": growth, "slope": slope,
        })
    return {"case": 2, "preset": preset_name, "method": method, "t_end": t_end, "runs": runs}


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
    from .charts import Series, line_chart

    series = []
    for r in result["runs"]:
        centres, maxima = binned_median(r["t"], r["error"])
        series.append(Series(f"{r['integrator']} ({r['setting']})", centres, _floor(maxima), marker=None))
    return line_chart(series, title=f"Case 2: energy error over {result['t_end']:g} s, {result['preset']} "
                      f"({result['method']})", x_label="t (s)",
                      y_label="median |E - E0| / scale in the window", log_x=True, log_y=True,
                      note="each point: the median error in a log-spaced time window (flat = bounded, rising = drift)")


# ------------------------------------------------------------------------------------------------
# Case 3: approaching the singular position of a change-point four-bar


def _change_point_start(distance: float):
    """The change-point preset released at rest ``distance`` rad short of its singular position."""
    from .presets import get_preset

    preset = get_preset("change-point")
    theta1 = math.pi / 2 - distance
    return preset.chain, np.array([theta1, math.pi / 2, theta1 + math.pi]), np.zeros(3)


def singular_approach(distances=(0.05, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6), t_end: float = 20.0, samples: int = 2001,
                      methods=FORMULATION_NAMES + ("reduced",)) -> dict:
    """For each release distance and method: status, message, peak condition number, time reached; for the
    first distance (the preset's 0.05 rad) the condition number against time."""
    from .assembly import loop_condition

    runs = []
    curves = []
    for index, distance in enumerate(distances):
        chain, theta0, omega0 = _change_point_start(distance)
        for method in methods:
            trajectory, seconds = _run(chain, theta0, omega0, method=method, integrator="DOP853", t_end=t_end,
                                       samples=samples)
            condition = np.asarray(trajectory.condition, float)
            runs.append({
                "distance": distance, "method": method, "status": trajectory.status, "message": trajectory.message,
                "seconds": seconds, "t_reached": float(trajectory.t[-1]) if trajectory.t.size else 0.0,
                "peak_condition": float(np.nanmax(condition)) if condition.size else None,
                "max_tip_gap": float(_dist(trajectory.constraint_xy).max()) if trajectory.t.size else None,
                "energy_drift": trajectory.energy_drift() if trajectory.t.size else None,
                "switches": trajectory.stats.get("n_switches") if trajectory.stats else None,
            })
            if index == 0:
                curves.append({"method": method, "t": trajectory.t.tolist(), "condition": condition.tolist()})
        if index == 0 and curves and curves[0]["t"]:
            theta = None
            trajectory, _ = _run(chain, theta0, omega0, method="lagrange", integrator="DOP853", t_end=t_end,
                                 samples=samples)
            theta = trajectory.theta
            curves.append({"method": "loop Jacobian J (2 x 3)", "t": trajectory.t.tolist(),
                           "condition": np.asarray(loop_condition(chain.array("L"), theta), float).tolist()})
    return {"case": 3, "preset": "change-point", "t_end": t_end, "distances": list(distances), "runs": runs,
            "curves": curves}


def figure_condition(result: dict) -> str:
    from .charts import Series, line_chart

    series = [Series(c["method"], c["t"], _floor(c["condition"]), marker=None) for c in result["curves"]]
    return line_chart(series, title=f"Case 3: condition number, change-point four-bar released "
                      f"{result['distances'][0]:g} rad from its singular position", x_label="t (s)",
                      y_label="2-norm condition number", log_y=True)


def figure_peak_condition(result: dict) -> str:
    from .charts import Series, line_chart

    series = []
    for method in dict.fromkeys(r["method"] for r in result["runs"]):
        rows = [r for r in result["runs"] if r["method"] == method]
        series.append(Series(
            method, [r["distance"] for r in rows],
            [r["peak_condition"] if (r["status"] == 0 and r["peak_condition"]) else float("nan") for r in rows],
            point_labels=[f"{method}, {r['distance']:g} rad: {r['message']}" for r in rows],
        ))
    return line_chart(series, title="Case 3: peak condition number against release distance (gaps: the run failed)",
                      x_label="release distance from the singular position (rad)", y_label="peak condition number",
                      log_x=True, log_y=True)


# ------------------------------------------------------------------------------------------------
# Case 4: degenerate parameters

SCENARIOS = (
    ("seed values (control)", {}),
    ("bar 2: I2 = d2 = 0 (point mass at joint 1)", {"I2": 0.0, "d2": 0.0}),
    ("bar 2 massless: m2 = I2 = 0", {"m2": 0.0, "I2": 0.0}),
    ("bar 3 nearly inertia-free: I3 = 1e-9, d3 = 1e-6", {"I3": 1e-9, "d3": 1e-6}),
    ("bar 3 without inertia: I3 = d3 = 0", {"I3": 0.0, "d3": 0.0}),
    ("very light tip: m3 = 1e-6, I3 = 4e-7", {"m3": 1e-6, "I3": 4e-7}),
    ("heavy base, light tip: m = 1e4, 1, 1e-4", {"m1": 1e4, "I1": 2e3, "m3": 1e-4, "I3": 4e-5}),
    ("light base, heavy tip: m = 1e-4, 1, 1e4", {"m1": 1e-4, "I1": 2e-5, "m3": 1e4, "I3": 4e3}),
)


def degenerate(scenarios=SCENARIOS, methods=FORMULATION_NAMES, integrators=INTEGRATOR_NAMES, t_end: float = 10.0,
               tolerance: float = 1e-8, step: float = 1e-3, max_steps: int = 50_000,
               preset_name: str = "triple-b") -> dict:
    """Every scenario x method x integrator from the preset's start; the outcome of each cell."""
    from .model import apply_overrides
    from .presets import get_preset

    preset = get_preset(preset_name)
    rows = []
    for label, overrides in scenarios:
        row = {"scenario": label, "overrides": overrides, "cells": [], "rejected": None}
        try:
            chain, theta0, omega0 = apply_overrides(preset.chain, preset.theta0, preset.omega0, overrides)
        except LinkageError as error:
            row["rejected"] = str(error)
            rows.append(row)
            continue
        for method in methods:
            for integrator in integrators:
                if integrator == "variational" and method != "lagrange":
                    continue  # it discretises the Lagrangian: defined on the Lagrange formulation only
                trajectory, seconds = _run(chain, theta0, omega0, method=method, integrator=integrator, t_end=t_end,
                                           samples=101, max_steps=max_steps, **_knob(integrator, tolerance, step))
                row["cells"].append({
                    "method": method, "integrator": integrator, "status": trajectory.status,
                    "message": trajectory.message, "seconds": seconds, "n_rhs": trajectory.n_rhs,
                    "t_reached": float(trajectory.t[-1]) if trajectory.t.size else 0.0,
                    "energy_drift": trajectory.energy_drift() if trajectory.t.size else None,
                    "peak_condition": float(np.nanmax(trajectory.condition)) if trajectory.t.size else None,
                })
        rows.append(row)
    return {"case": 4, "preset": preset_name, "t_end": t_end, "tolerance": tolerance, "step": step,
            "max_steps": max_steps, "rows": rows}


_SHORT_STATUS = {-1: "singular", -2: "non-finite", -3: "step < min", -4: "max steps", -5: "failed"}


def cell_outcome(cell: dict) -> tuple[str, str]:
    """``(text, colour)`` for a grid cell: green ok, amber ok but energy off by > 1e-5, red failed."""
    if cell["status"] != 0:
        return f"{_SHORT_STATUS.get(cell['status'], 'failed')} @{cell['t_reached']:.2g}s", "#f4a6a6"
    drift = cell["energy_drift"]
    if drift is None or not drift <= 1e-5:
        return f"dE {drift:.0e}", "#f6d88a"
    return f"ok {cell['n_rhs']:.2g} RHS", "#b9e3b0"


def figure_degenerate(result: dict) -> str:
    from .charts import grid_chart

    columns = None
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


# ------------------------------------------------------------------------------------------------
# Case 5: chaos


def chaos_divergence(presets=("triple-a", "triple-b", "triple-c"), tolerances=tuple(10.0**-k for k in range(4, 13)),
                     integrators=("DOP853", "RK45"), t_end: float = 60.0, samples: int = 1201,
                     threshold: float = 0.1, reference_tolerance: float = 1e-14) -> dict:
    """Tip divergence between formulations and between tolerances; predictability horizon = first time the
    tip is more than ``threshold`` away from the reference (DOP853, lagrange, ``reference_tolerance``). The
    reference's own horizon is where it parts from the same run with newton_euler: horizons beyond it are
    reported as lower bounds."""
    cases = {}
    for name in presets:
        from .presets import get_preset

        preset = get_preset(name)
        chain, theta0, omega0 = preset.chain, preset.theta0, preset.omega0

        def tip(method="lagrange", integrator="DOP853", tol=reference_tolerance):
            trajectory, _ = _run(chain, theta0, omega0, method=method, integrator=integrator, rtol=tol, atol=tol,
                                 t_end=t_end, samples=samples)
            return trajectory.t, trajectory.tip_xy, trajectory.status

        t, reference, _ = tip()
        def horizon(distance):
            over = np.flatnonzero(distance > threshold)
            return float(t[over[0]]) if over.size else None

        methods = {}
        for method in ("newton_euler", "dae"):
            _, other, _ = tip(method=method)
            distance = _dist(other - reference)
            methods[method] = {"distance": distance.tolist(), "horizon": horizon(distance)}
        reference_horizon = methods["newton_euler"]["horizon"]
        divergence = {}
        horizons = {}
        for integrator in integrators:
            horizons[integrator] = []
            for tol in tolerances:
                _, other, status = tip(integrator=integrator, tol=tol)
                distance = _dist(other - reference) if status == 0 else np.full(len(t), np.nan)
                h = horizon(distance)
                bounded = reference_horizon is not None and (h is None or h >= reference_horizon)
                horizons[integrator].append({"tolerance": tol, "horizon": h, "lower_bound": h is None or bounded})
                if integrator == "DOP853":
                    divergence[f"{tol:g}"] = distance.tolist()
        cases[name] = {"t": t.tolist(), "methods": methods, "tolerance_divergence": divergence,
                       "horizons": horizons, "reference_horizon": reference_horizon}
    return {"case": 5, "t_end": t_end, "threshold": threshold, "reference_tolerance": reference_tolerance,
            "tolerances": list(tolerances), "cases": cases}


def figure_divergence(result: dict, preset_name: str = "triple-c") -> str:
    from .charts import DASHES, Series, line_chart

    case = result["cases"][preset_name]
    series = [Series(f"{m} vs lagrange, both {result['reference_tolerance']:g}", case["t"], _floor(v["distance"]),
                     color="#222222", dash=DASHES[k + 1], marker=None) for k, (m, v) in enumerate(case["methods"].items())]
    for tol, distance in case["tolerance_divergence"].items():
        series.append(Series(f"tol {tol} vs reference", case["t"], _floor(distance), marker=None))
    return line_chart(series, title=f"Case 5: tip divergence, {preset_name} (DOP853; reference: lagrange at "
                      f"{result['reference_tolerance']:g})", x_label="t (s)", width=820,
                      y_label="tip distance (length units)", log_y=True,
                      hlines=[(result["threshold"], "predictability threshold")])


def figure_horizon(result: dict) -> str:
    from .charts import DASHES, MARKERS, PALETTE, Series, line_chart

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


# ------------------------------------------------------------------------------------------------
# The cheapest model for each question (``python -m physics bench --suite models``)


def _median_time(run, repeats: int = 5) -> float:
    run()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def four_bar_models(t_end: float = 100.0, tolerance: float = 1e-9, repeats: int = 3) -> list[dict]:
    """The seed four-bar for ``t_end`` s: the one-coordinate reduced model against each full formulation."""
    from .presets import get_preset
    from .simulate import simulate

    preset = get_preset("four-bar")
    rows = []
    for method in ("reduced",) + FORMULATION_NAMES:
        settings = Settings(method=method, integrator="DOP853", rtol=tolerance, atol=tolerance, t_end=t_end, samples=1001)
        trajectory = simulate(preset.chain, preset.theta0, preset.omega0, settings)
        seconds = _median_time(lambda: simulate(preset.chain, preset.theta0, preset.omega0, settings), repeats)
        from .codegen import load_compiled

        size = 1 if method == "reduced" else load_compiled(method, 3, True).n_unknowns
        rows.append({"method": method, "unknowns": size, "seconds": seconds, "status": trajectory.status,
                     "tip_gap": float(_dist(trajectory.constraint_xy).max()), "energy_drift": trajectory.energy_drift(),
                     "n_rhs": trajectory.n_rhs})
    return rows


def rhs_costs(batch: int = 1000) -> list[dict]:
    """Microseconds per acceleration evaluation, triple pendulum: the generated scalar code with its inline
    LU (one state, and per state in a batch), against the same generated A, b solved by numpy.linalg.solve,
    against the seed's lambdify + numpy.linalg.solve."""
    from .codegen import load_compiled
    from .presets import get_preset

    preset = get_preset("triple-c")
    params = preset.chain.params()
    theta, omega = preset.theta0 + 0.1, np.array([0.3, -0.2, 0.1])
    rows = []
    for method in FORMULATION_NAMES:
        compiled = load_compiled(method, 3, False)
        k = compiled.n_unknowns
        index = compiled.theta_ddot_index
        loops = 2000

        def single():
            for _ in range(loops):
                compiled.accel(theta, omega, params)

        def numpy_solve():
            for _ in range(loops // 10):
                A, b = compiled.matrix(theta, omega, params)
                np.linalg.solve(A, b)[index]

        thetas = np.tile(theta, (batch, 1))
        omegas = np.tile(omega, (batch, 1))
        rows.append({
            "method": method, "unknowns": k,
            "generated_accel_us": _median_time(single) / loops * 1e6,
            "generated_accel_batch_us_per_state": _median_time(
                lambda: compiled.accel_batch(thetas, omegas, params)) / batch * 1e6,
            "generated_assemble_numpy_solve_us": _median_time(numpy_solve) / (loops // 10) * 1e6,
        })
    try:
        from benchmarks import seed_baseline
    except ImportError:
        return rows
    for method in seed_baseline.FORMULATIONS:
        system = seed_baseline.derived(method)
        rhs = seed_baseline.make_rhs(system, np.concatenate([params[:12], [params[12]]]))
        z = np.concatenate([theta, omega])
        loops = 200

        def baseline():
            for _ in range(loops):
                rhs(0.0, z)

        rows.append({"method": f"seed baseline {method}", "unknowns": system.n_unknowns,
                     "lambdify_numpy_solve_us": _median_time(baseline) / loops * 1e6})
    return rows


def model_benchmark(out: Path, quick: bool = False, progress: bool = True) -> list[Path]:
    from .bench import Progress, machine_note, write_report
    from .ensemble import BENCH_COUNTS, DEFAULT_STEP, realtime_frame, throughput

    bar = Progress(3, "models", progress)
    four_bar = four_bar_models(t_end=20.0 if quick else 100.0, repeats=1 if quick else 3)
    bar.step("four-bar")
    costs = rhs_costs()
    bar.step("rhs")
    counts = BENCH_COUNTS[:3] if quick else BENCH_COUNTS
    ensembles = [throughput("triple-c", "lagrange", n, DEFAULT_STEP, 0.3 if quick else 1.0) for n in counts]
    ensembles.append(realtime_frame("triple-c", "lagrange", 100, DEFAULT_STEP))
    ensembles.append(realtime_frame("triple-c", "lagrange", 1000, DEFAULT_STEP))
    bar.step("ensembles")
    bar.close()
    document = {"kind": "models", "machine": machine_note(), "four_bar": four_bar, "rhs": costs,
                "ensembles": ensembles}
    return write_report(out, "models", document, models_markdown(document))


def models_markdown(document: dict) -> str:
    lines = ["| four-bar model | unknowns | wall time | max tip gap | energy drift | RHS calls |",
             "| --- | --- | --- | --- | --- | --- |"]
    for r in document["four_bar"]:
        lines.append(f"| {r['method']} | {r['unknowns']} | {r['seconds'] * 1e3:.3g} ms | {r['tip_gap']:.1e} | "
                     f"{r['energy_drift']:.1e} | {r['n_rhs']} |")
    lines += ["", "| triple pendulum RHS | unknowns | generated accel (us) | batched, per state (us) | "
              "generated A, b + numpy.linalg.solve (us) | lambdify + numpy.linalg.solve (us) |",
              "| --- | --- | --- | --- | --- | --- |"]
    for r in document["rhs"]:
        def cell(key):
            return f"{r[key]:.3g}" if key in r else "-"

        lines.append(f"| {r['method']} | {r['unknowns']} | {cell('generated_accel_us')} | "
                     f"{cell('generated_accel_batch_us_per_state')} | {cell('generated_assemble_numpy_solve_us')} | "
                     f"{cell('lambdify_numpy_solve_us')} |")
    lines += ["", "| ensemble | pendulum-steps / s or frame time |", "| --- | --- |"]
    for r in document["ensembles"]:
        if "pendulum_steps_per_second" in r:
            lines.append(f"| N = {r['count']} | {r['pendulum_steps_per_second']:.3g} steps/s |")
        else:
            lines.append(f"| N = {r['count']}, one 1/30 s frame | {r['frame_seconds'] * 1e3:.3g} ms "
                         f"({100 * r['budget_fraction']:.0f} % of the frame) |")
    machine = document["machine"]
    lines += ["", f"Machine: {machine['cpus']} CPUs, load average {machine['load_average_1_5_15']}."]
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------------------------------------
# Command line: every case, its figure(s) and the JSON


def _strip_series(result):
    """The JSON keeps the summaries; long sample arrays are dropped (the SVGs hold the curves)."""
    if isinstance(result, dict):
        return {k: _strip_series(v) for k, v in result.items()
                if not (isinstance(v, list) and len(v) > 50 and all(isinstance(x, (int, float)) for x in v[:5]))}
    if isinstance(result, list):
        return [_strip_series(v) for v in result]
    return result


def run_cases(cases, out: Path, quick: bool = False, progress: bool = True) -> dict:
    from .bench import Progress

    out.mkdir(parents=True, exist_ok=True)
    bar = Progress(len(cases), "stability", progress)
    # A partial run (--case 2) updates its cases and keeps the others' numbers.
    existing = out / "stability.json"
    try:
        summary = json.loads(existing.read_text()) if existing.exists() else {}
    except (OSError, ValueError):
        summary = {}
    for case in cases:
        if case == 1:
            result = closed_loop_drift(t_end=20.0 if quick else 100.0)
            figures = {"case1-drift.svg": figure_drift(result)}
        elif case == 2:
            integrators = ("RK45", "DOP853", "midpoint", "variational") if quick else INTEGRATOR_NAMES
            result = {"case": 2, "presets": {}}
            figures = {}
            for preset_name, suffix in (("triple-a", ""), ("single", "-single")):
                one = energy_drift(preset_name, t_end=100.0 if quick else 1000.0, integrators=integrators)
                result["presets"][preset_name] = one
                figures[f"case2-energy{suffix}.svg"] = figure_energy(one)
        elif case == 3:
            result = singular_approach(distances=(0.05, 1e-3, 1e-6) if quick else (0.05, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6))
            figures = {"case3-condition.svg": figure_condition(result), "case3-peak.svg": figure_peak_condition(result)}
        elif case == 4:
            result = degenerate(scenarios=SCENARIOS[:3] if quick else SCENARIOS)
            figures = {"case4-degenerate.svg": figure_degenerate(result)}
        else:
            result = chaos_divergence(t_end=30.0 if quick else 60.0)
            figures = {"case5-divergence.svg": figure_divergence(result), "case5-horizon.svg": figure_horizon(result)}
        for name, svg in figures.items():
            (out / name).write_text(svg)
        summary[f"case{case}"] = _strip_series(result)
        bar.step(f"case {case}")
    bar.close()
    (out / "stability.json").write_text(json.dumps(summary, indent=1))
    return summary


def main(argv=None) -> int:
    from .cli import _Parser

    parser = _Parser(prog="python -m physics.stability", description="the stability study: figures and JSON")
    parser.add_argument("--out", default="docs/stability")
    parser.add_argument("--case", default="1,2,3,4,5", help="comma-separated case numbers 1..5")
    parser.add_argument("--quick", action="store_true", help="shorter horizons and fewer cells")
    parser.add_argument("--no-progress", action="store_true")
    try:
        args = parser.parse_args(argv)
        try:
            cases = [int(c) for c in args.case.split(",")]
        except ValueError:
            raise LinkageError(f"--case = {args.case!r}: expected numbers 1..5, e.g. --case 1,3") from None
        if not all(1 <= c <= 5 for c in cases):
            raise LinkageError(f"--case = {args.case!r}: allowed range 1 <= case <= 5")
        run_cases(cases, Path(args.out), args.quick, not args.no_progress)
    except LinkageError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
