"""The work-precision study: error against wall time for every formulation x integrator x tolerance, on the
seed cases and the four-bar, with the seed-style baseline beside them (``python -m physics bench``).

Error: the distance between the tip and the reference tip at the horizon ``T`` (and, for robustness, the
largest distance over 11 samples in [0, T]); for the four-bar, whose tip is pinned, the coupler point. The
reference is DOP853 (compiled) at rtol = atol = 1e-14 with the Lagrange formulation, cross-checked against
DOP853 at the same tolerance with Newton-Euler (another derivation) and against DOP853 at 1e-13: the largest
difference is the reference's uncertainty, stated in the output. Horizons are shorter than each case's
predictability horizon (docs/stability.md, case 5): 5 s for the seed cases (case C diverges at the 0.1 level
after ~18 s at tolerance 1e-6), 20 s for the four-bar (one degree of freedom, not chaotic).

The charts, tables and files it leaves are written by :mod:`physics.studies.work_precision_report`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from functools import partial

import numpy as np

from ..chain_presets import get_preset
from ..errors import LinkageError
from ..model import Settings, check_state
from ..registry import (
    ADAPTIVE_INTEGRATORS,
    COMPILED,
    FIXED_STEP_INTEGRATORS,
    FORMULATION_NAMES,
    INTEGRATOR_NAMES,
    INTEGRATORS,
    METHODS,
    SCIPY,
    backend_for,
    integrators_for,
)
from ..simulate import simulate
from ..status import Status
from .report import TIME_BUDGET, Progress, machine_note, timed
from .work_precision_chart import SEED_BASELINE, chart

SEED_CASES = ("triple-a", "triple-b", "triple-c")
ALL_CASES = SEED_CASES + ("four-bar",)
HORIZON = {"triple-a": 5.0, "triple-b": 5.0, "triple-c": 5.0, "four-bar": 20.0}
REFERENCE_TOLERANCE = 1e-14
CHECK_TOLERANCE = 1e-13
TOLERANCES = tuple(10.0**-k for k in range(3, 13))
MIDPOINT_STEPS = (0.1, 0.03, 0.01, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5)
FORMULATIONS = FORMULATION_NAMES
HEADLINE_CASE = "triple-c"
HEADLINE_ACCURACIES = tuple(10.0**-k for k in range(3, 11))
SAMPLES = 11

QUICK = dict(
    cases=("triple-c",),
    formulations=("lagrange", "dae"),
    integrators=INTEGRATOR_NAMES,
    tolerances=(1e-3, 1e-5, 1e-7, 1e-9),
    midpoint_steps=(0.05, 0.01, 2e-3),
    baseline_formulations=("lagrange",),
    baseline_tolerances=(1e-3, 1e-5, 1e-7, 1e-9),
    repeats=3,
    budget=0.3,
)
FULL = dict(
    cases=ALL_CASES,
    formulations=FORMULATIONS,
    integrators=ADAPTIVE_INTEGRATORS + FIXED_STEP_INTEGRATORS,
    tolerances=TOLERANCES,
    midpoint_steps=MIDPOINT_STEPS,
    baseline_formulations=("lagrange", "dae"),
    baseline_tolerances=TOLERANCES,
    repeats=5,
    budget=TIME_BUDGET,
)


@dataclass
class Curve:
    """One configuration swept over its accuracy knob (tolerance, or step for midpoint)."""

    label: str
    formulation: str
    integrator: str
    backend: str
    knob: str  # "tolerance" or "step"
    points: list = field(default_factory=list)

    def as_dict(self) -> dict:
        return {
            "label": self.label,
            "formulation": self.formulation,
            "integrator": self.integrator,
            "backend": self.backend,
            "knob": self.knob,
            "points": self.points,
        }


def _tip_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.hypot(a[..., 0] - b[..., 0], a[..., 1] - b[..., 1])


def _case_setup(name: str):
    preset = get_preset(name)
    return preset.chain, preset.theta0, preset.omega0, preset.trace


def _probe(trajectory) -> np.ndarray:
    """The point whose error is measured: the tip of an open chain; the traced coupler point of a closed
    one (its tip is pinned, so its error says nothing)."""
    return trajectory.trace_xy if trajectory.constraint_xy.shape[1] == 2 else trajectory.tip_xy


def _settings(chain, horizon, method, integrator, tolerance=None, step=None, trace=None):
    fields = dict(method=method, integrator=integrator, t_end=horizon, samples=SAMPLES)
    if chain.pinned:
        fields["stabilization"] = "projection"
        fields["trace"] = trace
    fields["backend"] = backend_for(integrator)
    if tolerance is not None:
        fields.update(rtol=tolerance, atol=tolerance)
    if step is not None:
        fields["step"] = step
    return Settings(**fields)


def reference(name: str) -> dict:
    """The reference tip path of a named case and its uncertainty."""
    chain, theta0, omega0, trace = _case_setup(name)
    return reference_for(chain, theta0, omega0, trace, HORIZON[name], name)


def reference_for(chain, theta0, omega0, trace, horizon: float, name: str = "this case") -> dict:
    """The reference probe path (tip, or coupler point of a closed chain) and its uncertainty: the largest
    difference to two cross-checks (another derivation, and a 10x looser tolerance)."""
    runs = {}
    for key, method, tol in (
        ("reference", "lagrange", REFERENCE_TOLERANCE),
        ("other_formulation", "newton_euler", REFERENCE_TOLERANCE),
        ("looser", "lagrange", CHECK_TOLERANCE),
    ):
        trajectory = simulate(chain, theta0, omega0, _settings(chain, horizon, method, "DOP853", tol, trace=trace))
        if not trajectory.success:
            raise LinkageError(f"the reference run for {name} failed: {trajectory.message}")
        runs[key] = trajectory
    tip = _probe(runs["reference"])
    checks = {key: float(np.max(_tip_distance(_probe(runs[key]), tip))) for key in ("other_formulation", "looser")}
    return {
        "tip": tip,
        "t": runs["reference"].t,
        "uncertainty": max(checks.values()),
        "checks": checks,
        "description": (
            f"DOP853 compiled, lagrange, rtol = atol = {REFERENCE_TOLERANCE:g}; cross-checked with newton_euler at "
            f"{REFERENCE_TOLERANCE:g} and lagrange at {CHECK_TOLERANCE:g}"
        ),
    }


def _point(trajectory, ref_tip, seconds, runs, knob_value, knob) -> dict:
    point = {
        knob: knob_value,
        "seconds": seconds,
        "timed_runs": runs,
        # a mechanism's run that stopped has no count (Outcome.n_rhs is None): the point records its failure
        "n_rhs": None if getattr(trajectory, "n_rhs", None) is None else int(trajectory.n_rhs),
        "status": int(trajectory.status),
        "message": trajectory.message,
    }
    probe = _probe(trajectory) if hasattr(trajectory, "constraint_xy") else trajectory.tip_xy
    if trajectory.success and len(probe) == len(ref_tip):
        distance = _tip_distance(probe, ref_tip)
        point["error"] = float(distance[-1])
        point["error_max"] = float(np.max(distance))
    else:
        point["error"] = None
        point["error_max"] = None
    return point


def _our_curves(name, formulations, integrators, tolerances, midpoint_steps):
    chain, _, _, trace = _case_setup(name)
    return curves_for(chain, trace, HORIZON[name], formulations, integrators, tolerances, midpoint_steps)


def curves_for(chain, trace, horizon, formulations, integrators, tolerances, midpoint_steps):
    """(curve, knob values, settings factory) for every configuration of ours that applies to the chain."""
    # Beside the formulations, the branch-switching reduced model where the chain has one (a four-bar).
    methods = list(formulations) + [name for name, spec in METHODS.items()
                                    if spec.reduced and spec.switches_branch and spec.available_for(chain.pinned, chain.n)]
    plan = []
    for method in methods:
        for integrator in integrators_for(method, integrators):
            spec = INTEGRATORS[integrator]
            if METHODS[method].reduced:  # the reduced model integrates with scipy's DOP853 only
                curve = Curve(f"{method} / {integrator} (scipy)", method, integrator, SCIPY, "tolerance")
                plan.append((curve, tolerances, lambda tol, m=method, i=integrator: _settings(chain, horizon, m, i, tol, trace=trace)))
                continue
            if spec.fixed_step:
                curve = Curve(f"{method} / {integrator} (fixed step)", method, integrator, COMPILED, "step")
                plan.append((curve, midpoint_steps,
                             lambda h, m=method, i=integrator: _settings(chain, horizon, m, i, step=h, trace=trace)))
                continue
            backend = backend_for(integrator)
            curve = Curve(f"{method} / {integrator} ({backend})", method, integrator, backend, "tolerance")
            plan.append((curve, tolerances,
                         lambda tol, m=method, i=integrator: _settings(chain, horizon, m, i, tol, trace=trace)))
    return plan


class _BaselineResult:
    """The baseline's run in the shape _point expects."""

    def __init__(self, solution, tip):
        self.status = Status.OK if solution.success else Status.INTEGRATOR_FAILED
        self.message = "ok" if solution.success else str(solution.message)
        self.n_rhs = int(solution.nfev)
        self.tip_xy = tip

    @property
    def success(self):
        return self.status == Status.OK


def _baseline_plan(name, formulations, tolerances):
    if name not in SEED_CASES or not formulations:
        return []
    preset = get_preset(name)
    horizon = HORIZON[name]
    plan = []
    for formulation in formulations:
        curve = Curve(f"seed baseline: {formulation} / RK45 (sympy+lambdify+numpy.solve+scipy)", formulation,
                      "RK45", SEED_BASELINE, "tolerance")

        def run_factory(tol, f=formulation):
            # sympy boundary: the baseline derives with sympy, imported only when the baseline runs.
            from . import seed_baseline  # noqa: PLC0415

            params = np.concatenate([preset.chain.params()[:12], [preset.chain.g]])

            def run():
                solution = seed_baseline.simulate(
                    f, preset.theta0, preset.omega0, params=params, t_end=horizon, samples=SAMPLES, rtol=tol, atol=tol
                )
                tip = seed_baseline.tip_xy(solution.y.T[:, :3], params) if solution.success else np.zeros((0, 2))
                return _BaselineResult(solution, tip)

            return run

        plan.append((curve, tolerances, run_factory))
    return plan


def work_precision(options: dict, progress_enabled: bool = True) -> dict:
    """Run the sweep described by ``options`` (QUICK or FULL, possibly narrowed) and return the JSON document."""
    cases = options["cases"]
    plans = {}
    total = 0
    for name in cases:
        ours = _our_curves(name, options["formulations"], options["integrators"], options["tolerances"],
                           options["midpoint_steps"])
        baseline = _baseline_plan(name, options["baseline_formulations"], options["baseline_tolerances"])
        plans[name] = (ours, baseline)
        total += sum(len(knobs) for _, knobs, _ in ours) + sum(len(knobs) for _, knobs, _ in baseline) + 1
    progress = Progress(total, "work-precision", progress_enabled)
    document = {
        "kind": "work-precision",
        "machine": machine_note(),
        "error_definition": "distance between the tip (four-bar: the coupler point, as its tip is pinned) and "
        f"the reference's at t = horizon (error); largest over {SAMPLES} samples in [0, horizon] (error_max)",
        "time_definition": "median wall time of repeated complete simulate() calls (first call untimed; at least "
        f"{options['repeats']} repeats, more for fast runs, fewer past {options['budget']:g} s per point)",
        "repeats": options["repeats"],
        "cases": {},
    }
    started = time.perf_counter()
    try:
        for name in cases:
            chain, theta0, omega0, _ = _case_setup(name)
            ref = reference(name)
            progress.step(f"{name} reference")
            curves = []
            ours, baseline = plans[name]
            for curve, knobs, make in ours:
                for value in knobs:
                    settings = make(value)
                    trajectory, seconds, runs = timed(
                        partial(simulate, chain, theta0, omega0, settings), options["repeats"], options["budget"]
                    )
                    curve.points.append(_point(trajectory, ref["tip"], seconds, runs, value, curve.knob))
                    progress.step(f"{name} {curve.label} {value:g}")
                curves.append(curve)
            baseline_curves = []
            for curve, knobs, run_factory in baseline:
                for value in knobs:
                    result, seconds, runs = timed(run_factory(value), options["repeats"], options["budget"])
                    curve.points.append(_point(result, ref["tip"], seconds, runs, value, curve.knob))
                    progress.step(f"{name} baseline {value:g}")
                baseline_curves.append(curve)
            document["cases"][name] = {
                "horizon": HORIZON[name],
                "probe": "coupler point" if chain.pinned else "tip",
                "reference": {k: v for k, v in ref.items() if k not in ("tip", "t")},
                "reference_tip_at_horizon": [float(v) for v in ref["tip"][-1]],
                "curves": [c.as_dict() for c in curves],
                "baseline": [c.as_dict() for c in baseline_curves],
                "winners": winners(curves, HEADLINE_ACCURACIES, ref["uncertainty"]),
            }
    finally:
        progress.close()
    if HEADLINE_CASE in document["cases"] and document["cases"][HEADLINE_CASE]["baseline"]:
        document["headline"] = headline(document["cases"][HEADLINE_CASE])
    document["elapsed_seconds"] = time.perf_counter() - started
    return document


def work_precision_chain(chain, theta0, omega0, trace=None, horizon: float = 5.0, formulations=("lagrange",),
                         integrators=("RK45", "DOP853", "midpoint", "variational"),
                         tolerances=(1e-3, 1e-5, 1e-7, 1e-9), midpoint_steps=(0.05, 0.01, 2e-3), repeats: int = 1, budget: float = 0.2,
                         title: str = "current parameters", narrow: bool = False) -> tuple[dict, str]:
    """A small work-precision sweep for any chain and start (what the app shows for its current parameters):
    returns the case document (as in the JSON) and its SVG chart. A few seconds for a triple pendulum."""
    if not (math.isfinite(horizon) and 0.0 < horizon <= 100.0):
        raise LinkageError(f"horizon = {horizon}: allowed range 0 < horizon <= 100 s")
    theta0, omega0 = check_state(chain.n, theta0, omega0)
    ref = reference_for(chain, theta0, omega0, trace, horizon, title)
    curves = []
    for curve, knobs, make in curves_for(chain, trace, horizon, formulations, integrators, tolerances, midpoint_steps):
        for value in knobs:
            settings = make(value)
            trajectory, seconds, runs = timed(partial(simulate, chain, theta0, omega0, settings), repeats, budget)
            curve.points.append(_point(trajectory, ref["tip"], seconds, runs, value, curve.knob))
        curves.append(curve)
    case = {
        "horizon": horizon,
        "probe": "coupler point" if chain.pinned else "tip",
        "reference": {k: v for k, v in ref.items() if k not in ("tip", "t")},
        "curves": [c.as_dict() for c in curves],
        "baseline": [],
        "winners": winners(curves, HEADLINE_ACCURACIES, ref["uncertainty"]),
    }
    return case, chart(title, case, narrow=narrow)


def _reaching(curves, accuracy: float, resolvable: float):
    """The fastest measured point over ``curves`` whose error is at most ``accuracy`` (ok status only)."""
    best = None
    if accuracy < resolvable:
        return None
    for curve in curves:
        points = curve["points"] if isinstance(curve, dict) else curve.points
        label = curve["label"] if isinstance(curve, dict) else curve.label
        for point in points:
            if point["status"] == Status.OK and point["error"] is not None and point["error"] <= accuracy:
                if best is None or point["seconds"] < best["seconds"]:
                    best = dict(point, label=label)
    return best


def winners(curves, accuracies, uncertainty) -> list:
    """For each accuracy, the fastest configuration reaching it, and the fastest of every other integrator.

    Accuracies below 10x the reference uncertainty are not judged (the reference cannot tell them apart)."""
    rows = []
    for accuracy in accuracies:
        best = _reaching(curves, accuracy, 10.0 * uncertainty)
        if best is None:
            reason = "below 10x the reference uncertainty" if accuracy < 10.0 * uncertainty else "not reached"
            rows.append({"accuracy": accuracy, "winner": None, "reason": reason})
            continue
        runner_up = None
        for curve in curves:
            label = curve["label"] if isinstance(curve, dict) else curve.label
            if label == best["label"]:
                continue
            candidate = _reaching([curve], accuracy, 10.0 * uncertainty)
            if candidate and (runner_up is None or candidate["seconds"] < runner_up["seconds"]):
                runner_up = candidate
        rows.append({
            "accuracy": accuracy,
            "winner": best["label"],
            "seconds": best["seconds"],
            "error": best["error"],
            "knob": best.get("tolerance", best.get("step")),
            "runner_up": runner_up["label"] if runner_up else None,
            "runner_up_seconds": runner_up["seconds"] if runner_up else None,
        })
    return rows


def headline(case: dict) -> list:
    """Ours (fastest of every configuration) against the seed-style baseline (fastest of its formulations and
    tolerances) at each accuracy: measured points only, no interpolation."""
    rows = []
    resolvable = 10.0 * case["reference"]["uncertainty"]
    for accuracy in HEADLINE_ACCURACIES:
        ours = _reaching(case["curves"], accuracy, resolvable)
        base = _reaching(case["baseline"], accuracy, resolvable)
        row: dict = {"accuracy": accuracy, "ours": None, "baseline": None, "speedup": None}
        if ours:
            row["ours"] = {"label": ours["label"], "seconds": ours["seconds"], "error": ours["error"],
                           "knob": ours.get("tolerance", ours.get("step"))}
        if base:
            row["baseline"] = {"label": base["label"], "seconds": base["seconds"], "error": base["error"],
                               "tolerance": base["tolerance"]}
        if ours and base:
            row["speedup"] = base["seconds"] / ours["seconds"]
        rows.append(row)
    return rows


