"""The stability study of a general mechanism: where each method and stabilisation keeps a mechanism's joints
closed, and what each does near a singular pose (``python -m physics.stability --preset slider-crank`` or
``--mechanism FILE``; docs/stability.md, "A general mechanism").

Two of the chain study's five cases carry over to any mechanism, run through
:func:`physics.mechanism.simulate.simulate_mechanism` (the general engine):

1. :func:`mechanism_drift`: the largest constraint residual against time for every method x stabilisation
   (none, Baumgarte, projection), with the peak Jacobian condition of each run (how near it passed a singular
   pose) and, for a mechanism without motors, its energy drift.
3. :func:`mechanism_singular_approach`: the change-point four-bar written as a mechanism (four bars' worth of
   bodies and pins, no chain formulas), released ever closer to the pose where its links line up: status,
   message, peak condition and time reached for each method, and the condition against time.

The others need what a general mechanism does not have: one integrator to compare with others (case 2), a chain's
named bars to degrade (case 4) and a chaotic chain (case 5: a mobility-2 mechanism's divergence is the chaos map's).
"""

from __future__ import annotations

import math
import re

import numpy as np

from ..chain_presets import get_preset
from ..mechanism.chains import chain_mechanism
from ..mechanism.description import Mechanism
from .charts import DASHES, PALETTE, Series, line_chart
from .mechanism_cases import FORMULATIONS, REDUCED, STABILIZATIONS, Outcome, mobility, run_case
from .stability_figures import figure_condition, figure_peak_condition, floor_for_log

MECHANISM_CASES = (1, 3)
_TIME = re.compile(r"t = ([-+0-9.eE]+) s")


def _t_reached(outcome: Outcome, t_end: float) -> float | None:
    """The end of a run, or the time its failure names (None when it names none)."""
    if outcome.success:
        return t_end
    found = _TIME.search(outcome.message)
    return float(found.group(1)) if found else None


def _energy_drift(mechanism: Mechanism, outcome: Outcome) -> float | None:
    """Largest |E - E0| over the scale (|E0|, or the largest |T| or |V|), as the chains' Trajectory.energy_drift;
    None for a run with motors (they do work) or a failed one."""
    if outcome.run is None or mechanism.drivers:
        return None
    run = outcome.run
    energy = run.energy
    scale = max(abs(float(energy[0])), float(np.max(np.abs(run.kinetic))), float(np.max(np.abs(run.potential))),
                1e-300)
    return float(np.max(np.abs(energy - energy[0])) / scale)


def mechanism_drift(mechanism: Mechanism, t_end: float = 20.0, samples: int = 401, tolerance: float = 1e-8,
                    methods=FORMULATIONS, stabilizations=STABILIZATIONS) -> dict:
    """Every method x stabilisation from the mechanism's assembled sketch: the residual against time."""
    integrate = mobility(mechanism) == 0  # a driven mechanism integrated all the same: the drift is the question
    runs = []
    for stabilization in stabilizations:
        for method in methods:
            options: dict = {"integrate": True} if integrate else {}
            outcome = run_case(mechanism, t_end, samples, method=method, stabilization=stabilization,
                               rtol=tolerance, atol=tolerance, **options)
            run = outcome.run
            residual = run.residual if run is not None else np.zeros(0)
            runs.append({
                "method": method, "stabilization": stabilization, "status": int(outcome.status),
                "message": outcome.message, "seconds": outcome.seconds,
                "t": [] if run is None else run.t.tolist(), "residual": residual.tolist(),
                "max_residual": float(residual.max()) if residual.size else None,
                "final_residual": float(residual[-1]) if residual.size else None,
                "peak_condition": float(np.max(run.condition)) if run is not None and run.condition.size else None,
                "energy_drift": _energy_drift(mechanism, outcome),
                "t_reached": _t_reached(outcome, t_end),
            })
    return {"case": 1, "mechanism": mechanism.name, "mobility": mobility(mechanism), "t_end": t_end,
            "tolerance": tolerance, "integrator": "DOP853", "runs": runs}


def change_point_mechanism(distance: float) -> tuple[Mechanism, np.ndarray]:
    """The change-point four-bar written as a mechanism and sketched at rest ``distance`` rad short of its
    singular pose (the chain study's case 3 start); returns it and the release angles."""
    preset = get_preset("change-point")
    theta1 = math.pi / 2 - distance
    theta = np.array([theta1, math.pi / 2, theta1 + math.pi])
    mechanism = chain_mechanism(preset.chain, theta)
    return mechanism.model_copy(update={"name": f"change-point four-bar, {distance:g} rad"}), theta


def mechanism_singular_approach(distances=(0.05, 1e-2, 1e-3, 1e-4), t_end: float = 20.0, samples: int = 2001,
                                methods=FORMULATIONS + (REDUCED,)) -> dict:
    """For each release distance and method: status, message, peak condition, time reached; for the first
    distance the condition against time (the general engine's Jacobian condition at every sample)."""
    runs, curves = [], []
    for index, distance in enumerate(distances):
        mechanism, _ = change_point_mechanism(distance)
        for method in methods:
            outcome = run_case(mechanism, t_end, samples, method=method)
            run = outcome.run
            condition = run.condition if run is not None else np.zeros(0)
            runs.append({
                "distance": distance, "method": method, "status": int(outcome.status), "message": outcome.message,
                "seconds": outcome.seconds, "t_reached": _t_reached(outcome, t_end),
                "peak_condition": float(np.max(condition)) if condition.size else None,
                "max_residual": float(np.max(run.residual)) if run is not None else None,
            })
            if index == 0 and run is not None and condition.size:
                curves.append({"method": method, "t": run.t.tolist(), "condition": condition.tolist()})
    return {"case": 3, "mechanism": "change-point four-bar (as a mechanism)", "t_end": t_end,
            "distances": list(distances), "runs": runs, "curves": curves}


def figure_mechanism_drift(result: dict) -> str:
    colour = {"none": PALETTE[2], "baumgarte": PALETTE[0], "projection": PALETTE[4]}
    dash = {"newton_euler": DASHES[1], "lagrange": DASHES[0], "dae": DASHES[2]}
    series = [Series(f"{r['stabilization']}, {r['method']}" + ("" if r["status"] == 0 else " (failed)"), r["t"],
                     floor_for_log(r["residual"]), color=colour[r["stabilization"]], dash=dash[r["method"]],
                     marker=None) for r in result["runs"]]
    return line_chart(series, title=f"{result['mechanism']}: largest constraint residual ({result['integrator']}, "
                      f"tol {result['tolerance']:g})", x_label="t (s)", y_label="max |Phi(q, t)|", log_y=True,
                      note="the general engine (simulate_mechanism)")


def run_mechanism_cases(mechanism: Mechanism, cases, quick: bool = False) -> tuple[dict, dict[str, str]]:
    """The mechanism's cases (1 and/or 3): ``(summary by case, {file name: SVG})``."""
    summary: dict = {}
    figures: dict[str, str] = {}
    for case in cases:
        if case == 1:
            result = mechanism_drift(mechanism, t_end=5.0 if quick else 20.0, samples=201 if quick else 401)
            figures[f"mechanism-drift-{_file_name(mechanism.name)}.svg"] = figure_mechanism_drift(result)
        else:
            result = mechanism_singular_approach(distances=(0.05, 1e-3) if quick else (0.05, 1e-2, 1e-3, 1e-4),
                                                 t_end=5.0 if quick else 20.0, samples=501 if quick else 2001)
            figures["mechanism-singular-condition.svg"] = figure_condition(result)
            figures["mechanism-singular-peak.svg"] = figure_peak_condition(result)
        summary[f"case{case}"] = result
    return summary, figures


def _file_name(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_-]+", "-", name).strip("-") or "mechanism"
