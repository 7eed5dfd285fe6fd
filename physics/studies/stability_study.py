"""The stability study: where each formulation and integrator keeps working and where it fails, as five
functions (one per case of docs/stability.md); their figures are drawn by physics.studies.stability_figures
(the "cheapest model" measurements are physics.studies.models).

``python -m physics.stability --out FOLDER [--case 1,2,3,4,5] [--quick]`` (``--out`` required; each file written is
printed; ``--out docs/stability`` refreshes the docs' own) writes every figure (SVG)
and ``stability.json``; docs/stability.md shows them with their numbers. With ``--preset NAME`` (a mechanism
preset) or ``--mechanism FILE`` the study of a general mechanism runs instead (cases 1 and 3,
physics.studies.mechanism_stability) and writes ``stability-mechanism.json`` beside its figures. Each case function takes its sizes
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
import sys
import time
from pathlib import Path

import numpy as np

from ..arguments import Parser
from ..chain_presets import get_preset
from ..errors import LinkageError
from ..loop_closure import loop_condition
from ..model import FORMULATION_NAMES, INTEGRATOR_NAMES, Settings, apply_overrides
from ..registry import INTEGRATORS, backend_for, integrators_for
from ..simulate import simulate
from ..status import Status
from .report import Progress
from .stability_figures import (
    binned_median,
    figure_condition,
    figure_degenerate,
    figure_divergence,
    figure_drift,
    figure_energy,
    figure_horizon,
    figure_peak_condition,
)

# Case 5: the reference every other run is compared with, and the formulation it is cross-checked against.
REFERENCE_METHOD = "lagrange"
REFERENCE_INTEGRATOR = "DOP853"
CROSS_CHECK_METHOD = "newton_euler"  # where the reference parts from this derivation, horizons are lower bounds



def _run(chain, theta0, omega0, **fields):
    """simulate() and its wall time (a failure midway comes back in status and message)."""
    start = time.perf_counter()
    trajectory = simulate(chain, theta0, omega0, Settings(**fields))
    return trajectory, time.perf_counter() - start


def _knob(integrator: str, tolerance: float, step: float) -> dict:
    """Settings fields for an integrator's accuracy knob: a fixed step, or rtol = atol (scipy-only ones on scipy)."""
    if INTEGRATORS[integrator].fixed_step:
        return {"step": step}
    return {"rtol": tolerance, "atol": tolerance, "backend": backend_for(integrator)}


def _knob_label(integrator: str, tolerance: float, step: float) -> str:
    return f"step {step:g} s" if INTEGRATORS[integrator].fixed_step else f"tol {tolerance:g}"


def _dist(xy) -> np.ndarray:
    xy = np.asarray(xy, float)
    return np.hypot(xy[:, 0], xy[:, 1]) if xy.size else np.zeros(0)


# ------------------------------------------------------------------------------------------------
# Case 1: closed-loop drift


def closed_loop_drift(t_end: float = 100.0, samples: int = 1001, tolerance: float = 1e-8,
                      methods=FORMULATION_NAMES, integrator: str = "DOP853") -> dict:
    """Four-bar, every formulation x {none, baumgarte, projection}: |tip - pin| against time."""
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


# ------------------------------------------------------------------------------------------------
# Case 3: approaching the singular position of a change-point four-bar


def _change_point_start(distance: float):
    """The change-point preset released at rest ``distance`` rad short of its singular position."""
    preset = get_preset("change-point")
    theta1 = math.pi / 2 - distance
    return preset.chain, np.array([theta1, math.pi / 2, theta1 + math.pi]), np.zeros(3)


def singular_approach(distances=(0.05, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6), t_end: float = 20.0, samples: int = 2001,
                      methods=FORMULATION_NAMES + ("reduced",)) -> dict:
    """For each release distance and method: status, message, peak condition number, time reached; for the
    first distance (the preset's 0.05 rad) the condition number against time."""
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


# ------------------------------------------------------------------------------------------------
# Case 4: degenerate parameters

SCENARIOS: tuple[tuple[str, dict[str, float]], ...] = (
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
            for integrator in integrators_for(method, integrators):  # e.g. variational: Lagrange only
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


# ------------------------------------------------------------------------------------------------
# Case 5: chaos


DIVERGENCE_TOLERANCES = tuple(10.0**-k for k in range(4, 13))


def chaos_divergence(presets=("triple-a", "triple-b", "triple-c"), tolerances=DIVERGENCE_TOLERANCES,
                     integrators=("DOP853", "RK45"), t_end: float = 60.0, samples: int = 1201,
                     threshold: float = 0.1, reference_tolerance: float = 1e-14) -> dict:
    """Tip divergence between formulations and between tolerances; predictability horizon = first time the
    tip is more than ``threshold`` away from the reference (DOP853, lagrange, ``reference_tolerance``). The
    reference's own horizon is where it parts from the same run with newton_euler: horizons beyond it are
    reported as lower bounds."""
    cases = {}
    for name in presets:
        preset = get_preset(name)
        chain, theta0, omega0 = preset.chain, preset.theta0, preset.omega0

        def tip(method=REFERENCE_METHOD, integrator=REFERENCE_INTEGRATOR, tol=reference_tolerance):
            trajectory, _ = _run(chain, theta0, omega0, method=method, integrator=integrator, rtol=tol, atol=tol,
                                 t_end=t_end, samples=samples)
            return trajectory.t, trajectory.tip_xy, trajectory.status

        t, reference, _ = tip()
        def horizon(distance):
            over = np.flatnonzero(distance > threshold)
            return float(t[over[0]]) if over.size else None

        methods = {}
        for method in (m for m in FORMULATION_NAMES if m != REFERENCE_METHOD):
            _, other, _ = tip(method=method)
            distance = _dist(other - reference)
            methods[method] = {"distance": distance.tolist(), "horizon": horizon(distance)}
        reference_horizon = methods[CROSS_CHECK_METHOD]["horizon"]
        divergence: dict[str, list] = {}
        horizons: dict[str, list] = {}
        for integrator in integrators:
            horizons[integrator] = []
            for tol in tolerances:
                _, other, status = tip(integrator=integrator, tol=tol)
                distance = _dist(other - reference) if status == Status.OK else np.full(len(t), np.nan)
                h = horizon(distance)
                bounded = reference_horizon is not None and (h is None or h >= reference_horizon)
                horizons[integrator].append({"tolerance": tol, "horizon": h, "lower_bound": h is None or bounded})
                if integrator == REFERENCE_INTEGRATOR:
                    divergence[f"{tol:g}"] = distance.tolist()
        cases[name] = {"t": t.tolist(), "methods": methods, "tolerance_divergence": divergence,
                       "horizons": horizons, "reference_horizon": reference_horizon}
    return {"case": 5, "t_end": t_end, "threshold": threshold, "reference_tolerance": reference_tolerance,
            "tolerances": list(tolerances), "cases": cases}


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


def run_cases(cases, out: Path, quick: bool = False, progress: bool = True, written: list[Path] | None = None) -> dict:
    """Run ``cases`` and write their figures and ``stability.json`` into ``out``; each path written is appended
    to ``written`` (the command prints them: the default folder holds tracked files)."""
    written = [] if written is None else written
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
            written.append(out / name)
        summary[f"case{case}"] = _strip_series(result)
        bar.step(f"case {case}")
    bar.close()
    (out / "stability.json").write_text(json.dumps(summary, indent=1))
    written.append(out / "stability.json")
    return summary


def _run_mechanism_study(args, cases: list[int], written: list[Path]) -> None:
    """Cases 1 and 3 for a general mechanism (physics.studies.mechanism_stability), written into ``--out``."""
    from . import mechanism_stability  # noqa: PLC0415 - loaded only for a mechanism's study
    from .mechanism_cases import load_case  # noqa: PLC0415

    other = [c for c in cases if c not in mechanism_stability.MECHANISM_CASES]
    if other:
        raise LinkageError(f"--case {other[0]}: a mechanism's study has cases 1 (residual drift per stabilisation) "
                           "and 3 (a singular pose); cases 2, 4 and 5 are the chains'")
    mechanism = load_case(args.preset, args.mechanism)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    bar = Progress(len(cases), "stability", not args.no_progress)
    summary, figures = {}, {}
    for case in cases:
        one, drawn = mechanism_stability.run_mechanism_cases(mechanism, [case], args.quick)
        summary.update(one)
        figures.update(drawn)
        bar.step(f"case {case}")
    bar.close()
    for name, svg in figures.items():
        (out / name).write_text(svg)
        written.append(out / name)
    path = out / "stability-mechanism.json"
    path.write_text(json.dumps({"mechanism": mechanism.name, **_strip_series(summary)}, indent=1))
    written.append(path)


def main(argv=None) -> int:
    parser = Parser(prog="python -m physics.stability", description="the stability study: figures and JSON")
    # No default: the study's own folder, docs/stability, holds tracked files; a run names where it writes.
    parser.add_argument("--out", required=True, metavar="FOLDER",
                        help="folder for the figures and stability.json (docs/stability to refresh the docs' own)")
    parser.add_argument("--case", default=None, help="comma-separated case numbers 1..5 (a mechanism: 1, 3)")
    parser.add_argument("--preset", default=None, help="a mechanism preset: its study instead of the chains'")
    parser.add_argument("--mechanism", default=None, metavar="FILE", help="a mechanism file: its study")
    parser.add_argument("--quick", action="store_true", help="shorter horizons and fewer cells")
    parser.add_argument("--no-progress", action="store_true")
    try:
        args = parser.parse_args(argv)
        mechanism_study = args.preset is not None or args.mechanism is not None
        text = args.case or ("1,3" if mechanism_study else "1,2,3,4,5")
        try:
            cases = [int(c) for c in text.split(",")]
        except ValueError:
            raise LinkageError(f"--case = {text!r}: expected numbers 1..5, e.g. --case 1,3") from None
        if not all(1 <= c <= 5 for c in cases):
            raise LinkageError(f"--case = {text!r}: allowed range 1 <= case <= 5")
        written: list[Path] = []
        if mechanism_study:
            _run_mechanism_study(args, cases, written)
        else:
            run_cases(cases, Path(args.out), args.quick, not args.no_progress, written)
        for path in written:
            print(f"wrote {path}")
    except LinkageError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
