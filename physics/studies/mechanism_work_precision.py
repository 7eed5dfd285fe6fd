"""The work-precision study of a general mechanism (``python -m physics bench --preset slider-crank`` or
``--mechanism FILE``): error against wall time for every method (the maximal-coordinate DAE, Lagrange and
Newton-Euler on a spanning tree, and the reduced model in one joint coordinate where the mobility is 1) and
every stabilisation (none, Baumgarte, projection), swept over the tolerance.

Error: the distance between the probe point (the traced point; else the last body's last point) and the
reference's at the horizon (``error``), and the largest over the samples (``error_max``), as the chain study
measures its tip. The reference is the DAE with projection at :data:`REFERENCE_TOLERANCE`, cross-checked against
Lagrange with projection at the same tolerance (another derivation) and the DAE at a 10x looser tolerance: the
largest difference is the reference's uncertainty. A mechanism its motors fully drive (mobility 0) is integrated
all the same (``integrate=True``, the motor's angle held as a constraint), and the reference is cross-checked
against its position analysis too. The case's document has the chain cases' shape, so the same chart, tables
and files (:mod:`physics.studies.work_precision_report`) serve both; each curve also names its stabilisation.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from functools import partial

from ..errors import LinkageError
from ..mechanism.description import Mechanism
from ..status import Status
from .mechanism_cases import (
    FORMULATIONS,
    MECHANISM_INTEGRATORS,
    REDUCED,
    STABILIZATIONS,
    methods_for,
    mobility,
    probe_reference,
    run_case,
)
from .report import Progress, timed
from .work_precision import HEADLINE_ACCURACIES, SAMPLES, Curve, _point, _tip_distance, winners

REFERENCE_TOLERANCE = 1e-12  # 1e-14 cost minutes per run on the Python-stepped engine, and 1e-12 is far below
# every tolerance swept (the cross-checks state what the reference is worth)
CHECK_TOLERANCE = 1e-11
HORIZON = 2.0  # s: a few swings of a mechanism under gravity (none of the presets is chaotic)
TOLERANCES = tuple(10.0**-k for k in range(3, 11))
MECHANISM_QUICK = dict(tolerances=(1e-4, 1e-6, 1e-8), repeats=1, budget=0.3, horizon=1.0)
MECHANISM_FULL = dict(tolerances=TOLERANCES, repeats=3, budget=1.0, horizon=HORIZON)


@dataclass
class MechanismCurve(Curve):
    """A chain study's curve that also names how the closures are held."""

    stabilization: str = "projection"

    def as_dict(self) -> dict:
        return dict(super().as_dict(), stabilization=self.stabilization)


def _options(integrate: bool, method: str, stabilization: str, tolerance: float, integrator: str = "DOP853") -> dict:
    options = dict(method=method, rtol=tolerance, atol=tolerance, integrator=integrator)
    if method != REDUCED:  # the reduced model closes its loops by position analysis: no stabilisation applies
        options["stabilization"] = stabilization
        if integrate:
            options["integrate"] = True
    return options


def mechanism_reference(mechanism: Mechanism, horizon: float, name: str = "this mechanism") -> dict:
    """The reference path of the probe point and its uncertainty (the largest difference to the cross-checks)."""
    probe = probe_reference(mechanism)
    integrate = mobility(mechanism) == 0
    checks = [("reference", "dae", REFERENCE_TOLERANCE), ("other_formulation", "lagrange", REFERENCE_TOLERANCE),
              ("looser", "dae", CHECK_TOLERANCE)]
    runs = {}
    for key, method, tolerance in checks:
        outcome = run_case(mechanism, horizon, SAMPLES, probe=probe,
                           **_options(integrate, method, "projection", tolerance))
        if not outcome.success:
            raise LinkageError(f"the reference run for {name} failed: {outcome.message}")
        runs[key] = outcome
    if integrate:  # a driven mechanism: its position analysis is exact to the assembly's tolerance
        analysis = run_case(mechanism, horizon, SAMPLES, probe=probe, method="dae")
        if analysis.success:
            runs["position_analysis"] = analysis
    path = runs["reference"].tip_xy
    differences = {key: float(max(_tip_distance(run.tip_xy, path))) for key, run in runs.items() if key != "reference"}
    return {
        "tip": path,
        "uncertainty": max(differences.values()),
        "checks": differences,
        "description": (f"DOP853, dae with projection, rtol = atol = {REFERENCE_TOLERANCE:g}; cross-checked with "
                        f"lagrange at {REFERENCE_TOLERANCE:g} and dae at {CHECK_TOLERANCE:g}"
                        + ("; and the position analysis (the motors fix every body)" if integrate else "")),
    }


def mechanism_curves(mechanism: Mechanism, horizon: float, formulations=FORMULATIONS,
                     stabilizations=STABILIZATIONS, tolerances=TOLERANCES, integrators=MECHANISM_INTEGRATORS):
    """(curve dict, tolerances, run factory) for every method x stabilisation x integrator that applies."""
    integrate = mobility(mechanism) == 0
    probe = probe_reference(mechanism)
    plan = []
    for method in methods_for(mechanism, formulations):
        for integrator in integrators:
            if method == REDUCED and integrator != "DOP853":  # the reduced model integrates with scipy's DOP853
                continue
            for stabilization in (("position analysis",) if method == REDUCED else stabilizations):
                curve = MechanismCurve(f"{method} / {integrator} ({stabilization})", method, integrator, "scipy",
                                       "tolerance", stabilization=stabilization)

                def make(tolerance, m=method, s=stabilization, i=integrator):
                    return partial(run_case, mechanism, horizon, SAMPLES, probe=probe,
                                   **_options(integrate, m, s, tolerance, i))

                plan.append((curve, tolerances, make))
    return plan


def mechanism_case(mechanism: Mechanism, *, horizon: float = HORIZON, formulations=FORMULATIONS,
                   stabilizations=STABILIZATIONS, tolerances=TOLERANCES, integrators=MECHANISM_INTEGRATORS,
                   repeats: int = 3, budget: float = 1.0, progress: Progress | None = None,
                   name: str | None = None) -> dict:
    """One case of the work-precision document for ``mechanism`` (the chain cases' keys, plus ``mechanism``,
    ``mobility`` and each curve's ``stabilization``)."""
    if not (math.isfinite(horizon) and 0.0 < horizon <= 100.0):
        raise LinkageError(f"horizon = {horizon}: allowed range 0 < horizon <= 100 s")
    name = name or mechanism.name
    reference = mechanism_reference(mechanism, horizon, name)
    if progress:
        progress.step(f"{name} reference")
    curves = []
    for curve, knobs, make in mechanism_curves(mechanism, horizon, formulations, stabilizations, tolerances,
                                               integrators):
        for tolerance in knobs:
            outcome, seconds, runs = timed(make(tolerance), repeats, budget)
            curve.points.append(_point(outcome, reference["tip"], seconds, runs, tolerance, curve.knob))
            if progress:
                progress.step(f"{name} {curve.label} {tolerance:g}")
        curves.append(curve)
    return {
        "horizon": horizon,
        "probe": f"point {probe_reference(mechanism)}",
        "mechanism": mechanism.name,
        "mobility": mobility(mechanism),
        "reference": {k: v for k, v in reference.items() if k != "tip"},
        "reference_tip_at_horizon": [float(v) for v in reference["tip"][-1]],
        "curves": [c.as_dict() for c in curves],
        "baseline": [],
        "winners": winners(curves, HEADLINE_ACCURACIES, reference["uncertainty"]),
        "failures": sum(1 for c in curves for p in c.points if p["status"] != Status.OK),
    }


def runs_in_case(mechanism: Mechanism, formulations, stabilizations, tolerances, integrators) -> int:
    """Progress steps of :func:`mechanism_case`: the reference and every point."""
    plan = mechanism_curves(mechanism, 1.0, formulations, stabilizations, tolerances, integrators)
    return 1 + sum(len(knobs) for _, knobs, _ in plan)


def mechanism_document(cases: dict[str, Mechanism], options: dict, progress_enabled: bool = True) -> dict:
    """The work-precision document (the chain study's keys) for named mechanisms."""
    from .report import machine_note  # noqa: PLC0415 - the same note as the chain study's

    total = sum(runs_in_case(m, options["formulations"], options["stabilizations"], options["tolerances"],
                             options["integrators"]) for m in cases.values())
    progress = Progress(total, "work-precision", progress_enabled)
    started = time.perf_counter()
    document: dict = {
        "kind": "work-precision",
        "machine": machine_note(),
        "error_definition": "distance between the probe point (the traced point, else the last body's last point) "
        f"and the reference's at t = horizon (error); largest over {SAMPLES} samples in [0, horizon] (error_max)",
        "time_definition": "median wall time of repeated complete simulate_mechanism() calls (first call untimed; "
        f"at least {options['repeats']} repeats, fewer past {options['budget']:g} s per point)",
        "repeats": options["repeats"],
        "cases": {},
    }
    try:
        for name, mechanism in cases.items():
            document["cases"][name] = mechanism_case(
                mechanism, horizon=options["horizon"], formulations=options["formulations"],
                stabilizations=options["stabilizations"], tolerances=options["tolerances"],
                integrators=options["integrators"], repeats=options["repeats"], budget=options["budget"],
                progress=progress, name=name)
    finally:
        progress.close()
    document["elapsed_seconds"] = time.perf_counter() - started
    return document
