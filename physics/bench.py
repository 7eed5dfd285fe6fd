"""``python -m physics bench``: work-precision diagrams (error against wall time) for every formulation x
integrator x tolerance, on the seed cases and the four-bar, with the seed-style baseline beside them.

Why a benchmark command and not timed tests: wall time on a shared machine is noisy, so it is measured
here (median of repeats, stated with the machine's load) and recorded in BENCHMARKS.md, while the tests
only check that the command runs and that its numbers are sane.

Error: the distance between the tip and the reference tip at the horizon ``T`` (and, for robustness, the
largest distance over 11 samples in [0, T]); for the four-bar, whose tip is pinned, the coupler point. The reference is DOP853 (compiled) at rtol = atol = 1e-14 with
the Lagrange formulation, cross-checked against DOP853 at the same tolerance with Newton-Euler (another
derivation) and against DOP853 at 1e-13: the largest difference is the reference's uncertainty, stated in
the output. Horizons are shorter than each case's predictability horizon (docs/stability.md, case 5): 5 s
for the seed cases (case C diverges at the 0.1 level after ~18 s at tolerance 1e-6), 20 s for the four-bar
(one degree of freedom, not chaotic).

Suites: ``work-precision`` (default), ``ensemble`` (pendulum-steps per second, physics.ensemble),
``chaos`` (chaos-map pixels per second, 1 and 2 workers), ``models`` (the cheapest model for each question).
"""

from __future__ import annotations

import argparse
import html
import json
import math
import os
import platform
import statistics
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import LinkageError

SEED_CASES = ("triple-a", "triple-b", "triple-c")
ALL_CASES = SEED_CASES + ("four-bar",)
HORIZON = {"triple-a": 5.0, "triple-b": 5.0, "triple-c": 5.0, "four-bar": 20.0}
REFERENCE_TOLERANCE = 1e-14
CHECK_TOLERANCE = 1e-13
TOLERANCES = tuple(10.0**-k for k in range(3, 13))
MIDPOINT_STEPS = (0.1, 0.03, 0.01, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5)
ADAPTIVE_INTEGRATORS = ("RK45", "DOP853", "Radau", "LSODA")
FIXED_STEP = ("midpoint", "variational")
FORMULATIONS = ("newton_euler", "lagrange", "dae")
HEADLINE_CASE = "triple-c"
HEADLINE_ACCURACIES = tuple(10.0**-k for k in range(3, 11))
SAMPLES = 11
TIME_BUDGET = 2.0  # seconds of repeats per point at most (after the first, untimed, run)

QUICK = dict(
    cases=("triple-c",),
    formulations=("lagrange", "dae"),
    integrators=("RK45", "DOP853", "Radau", "LSODA", "midpoint", "variational"),
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
    integrators=ADAPTIVE_INTEGRATORS + FIXED_STEP,
    tolerances=TOLERANCES,
    midpoint_steps=MIDPOINT_STEPS,
    baseline_formulations=("lagrange", "dae"),
    baseline_tolerances=TOLERANCES,
    repeats=5,
    budget=TIME_BUDGET,
)


# ------------------------------------------------------------------------------------------------
# Progress


class Progress:
    """A progress bar on stderr: tqdm when installed (it comes with viser), else a one-line counter."""

    def __init__(self, total: int, description: str, enabled: bool = True):
        self.total, self.done, self.description, self.enabled = total, 0, description, enabled
        self._bar = None
        if enabled:
            try:
                from tqdm import tqdm

                self._bar = tqdm(total=total, desc=description, file=sys.stderr, unit="run", leave=True)
            except ImportError:
                self._bar = None

    def step(self, label: str = "") -> None:
        self.done += 1
        if not self.enabled:
            return
        if self._bar is not None:
            self._bar.set_postfix_str(label[:40], refresh=False)
            self._bar.update(1)
        else:
            width = 30
            filled = int(width * self.done / max(self.total, 1))
            sys.stderr.write(f"\r{self.description} [{'#' * filled}{'.' * (width - filled)}] {self.done}/{self.total} {label[:40]:40s}")
            sys.stderr.flush()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
        elif self.enabled:
            sys.stderr.write("\n")


# ------------------------------------------------------------------------------------------------
# Timing


MIN_TIMED = 0.2  # fast runs are repeated until this many seconds are spent, for a steadier median


def timed(run, repeats: int, budget: float = TIME_BUDGET):
    """Run once untimed (warm-up: caches, JIT), then at least ``repeats`` timed runs unless ``budget`` seconds
    run out first, and more (up to 20 x repeats) while less than MIN_TIMED seconds were spent; return
    ``(result, median seconds, runs timed)``."""
    result = run()
    times = []
    spent = 0.0
    while len(times) < 20 * max(1, repeats):
        start = time.perf_counter()
        run()
        elapsed = time.perf_counter() - start
        times.append(elapsed)
        spent += elapsed
        if spent > budget or (len(times) >= repeats and spent > MIN_TIMED):
            break
    return result, statistics.median(times), len(times)


def machine_note() -> dict:
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    return {
        "python": platform.python_version(),
        "machine": platform.machine(),
        "cpus": os.cpu_count(),
        "load_average_1_5_15": [round(v, 2) for v in load],
    }


def write_report(out: Path, stem: str, document: dict, markdown: str) -> list[Path]:
    """``<stem>.json`` and ``<stem>.md`` in ``out`` (created), and the table printed: what each suite leaves."""
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{stem}.json"
    path.write_text(json.dumps(document, indent=1))
    md = out / f"{stem}.md"
    md.write_text(markdown)
    print(markdown)
    return [path, md]


# ------------------------------------------------------------------------------------------------
# Work-precision


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
    from .presets import get_preset

    preset = get_preset(name)
    return preset.chain, preset.theta0, preset.omega0, preset.trace


def _probe(trajectory) -> np.ndarray:
    """The point whose error is measured: the tip of an open chain; the traced coupler point of a closed
    one (its tip is pinned, so its error says nothing)."""
    return trajectory.trace_xy if trajectory.constraint_xy.shape[1] == 2 else trajectory.tip_xy


def _settings(chain, horizon, method, integrator, tolerance=None, step=None, trace=None):
    from .model import Settings

    fields = dict(method=method, integrator=integrator, t_end=horizon, samples=SAMPLES)
    if chain.pinned:
        fields["stabilization"] = "projection"
        fields["trace"] = trace
    if integrator in ("Radau", "LSODA"):
        fields["backend"] = "scipy"
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
    from .simulate import simulate

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
        "n_rhs": int(trajectory.n_rhs) if hasattr(trajectory, "n_rhs") else None,
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
    methods = list(formulations)
    if chain.pinned and chain.n == 3:
        methods.append("reduced")
    plan = []
    for method in methods:
        for integrator in integrators:
            if method == "reduced":
                if integrator != "DOP853":
                    continue  # the reduced model integrates with scipy's DOP853 only
                curve = Curve("reduced / DOP853 (scipy)", method, integrator, "scipy", "tolerance")
                plan.append((curve, tolerances, lambda tol, m=method: _settings(chain, horizon, m, "DOP853", tol, trace=trace)))
                continue
            if integrator in FIXED_STEP:
                if integrator == "variational" and method != "lagrange":
                    continue  # it discretises the Lagrangian: defined on the Lagrange formulation only
                curve = Curve(f"{method} / {integrator} (fixed step)", method, integrator, "compiled", "step")
                plan.append((curve, midpoint_steps,
                             lambda h, m=method, i=integrator: _settings(chain, horizon, m, i, step=h, trace=trace)))
                continue
            backend = "scipy" if integrator in ("Radau", "LSODA") else "compiled"
            curve = Curve(f"{method} / {integrator} ({backend})", method, integrator, backend, "tolerance")
            plan.append((curve, tolerances,
                         lambda tol, m=method, i=integrator: _settings(chain, horizon, m, i, tol, trace=trace)))
    return plan


class _BaselineResult:
    """The baseline's run in the shape _point expects."""

    def __init__(self, solution, tip):
        self.status = 0 if solution.success else -5
        self.message = "ok" if solution.success else str(solution.message)
        self.n_rhs = int(solution.nfev)
        self.tip_xy = tip

    @property
    def success(self):
        return self.status == 0


def _baseline_plan(name, formulations, tolerances):
    if name not in SEED_CASES or not formulations:
        return []
    from .presets import get_preset

    preset = get_preset(name)
    horizon = HORIZON[name]
    plan = []
    for formulation in formulations:
        curve = Curve(f"seed baseline: {formulation} / RK45 (sympy+lambdify+numpy.solve+scipy)", formulation,
                      "RK45", "seed-baseline", "tolerance")

        def run_factory(tol, f=formulation):
            from benchmarks import seed_baseline

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
    from .simulate import simulate

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
                        lambda s=settings: simulate(chain, theta0, omega0, s), options["repeats"], options["budget"]
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
                         title: str = "current parameters") -> tuple[dict, str]:
    """A small work-precision sweep for any chain and start (what the app shows for its current parameters):
    returns the case document (as in the JSON) and its SVG chart. A few seconds for a triple pendulum."""
    from .model import check_state
    from .simulate import simulate

    if not (math.isfinite(horizon) and 0.0 < horizon <= 100.0):
        raise LinkageError(f"horizon = {horizon}: allowed range 0 < horizon <= 100 s")
    theta0, omega0 = check_state(chain.n, theta0, omega0)
    ref = reference_for(chain, theta0, omega0, trace, horizon, title)
    curves = []
    for curve, knobs, make in curves_for(chain, trace, horizon, formulations, integrators, tolerances, midpoint_steps):
        for value in knobs:
            settings = make(value)
            trajectory, seconds, runs = timed(lambda s=settings: simulate(chain, theta0, omega0, s), repeats, budget)
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
    return case, chart(title, case)


def _reaching(curves, accuracy: float, resolvable: float):
    """The fastest measured point over ``curves`` whose error is at most ``accuracy`` (ok status only)."""
    best = None
    if accuracy < resolvable:
        return None
    for curve in curves:
        points = curve["points"] if isinstance(curve, dict) else curve.points
        label = curve["label"] if isinstance(curve, dict) else curve.label
        for point in points:
            if point["status"] == 0 and point["error"] is not None and point["error"] <= accuracy:
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
        row = {"accuracy": accuracy, "ours": None, "baseline": None, "speedup": None}
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


# ------------------------------------------------------------------------------------------------
# Output


_INTEGRATOR_COLOURS = {"RK45": 0, "DOP853": 1, "Radau": 2, "LSODA": 3, "midpoint": 4, "variational": 5}
_FORMULATION_DASH = {"newton_euler": 1, "lagrange": 0, "dae": 2, "reduced": 3}


def _probe_name(case: dict) -> str:
    return case.get("probe", "tip")


def chart(case_name: str, case: dict) -> str:
    from .charts import DASHES, MARKERS, PALETTE, Series, line_chart

    series = []
    for curve in case["curves"] + case["baseline"]:
        points = [p for p in curve["points"] if p["error"] is not None]
        if curve["backend"] == "seed-baseline":
            color, dash, marker = "#222222", DASHES[_FORMULATION_DASH[curve["formulation"]]], "cross"
        else:
            color = PALETTE[_INTEGRATOR_COLOURS[curve["integrator"]]]
            dash = DASHES[_FORMULATION_DASH[curve["formulation"]]]
            marker = MARKERS[_FORMULATION_DASH[curve["formulation"]] % len(MARKERS)]
        labels = [f"{curve['label']} {curve['knob']}={p[curve['knob']]:g}: {p['seconds'] * 1e3:.3g} ms, "
                  f"error {p['error']:.2e}" for p in points]
        series.append(Series(curve["label"].split(" (sympy")[0], [p["seconds"] for p in points],
                             [max(p["error"], 1e-16) for p in points], color=color, dash=dash, marker=marker,
                             point_labels=labels))
    uncertainty = case["reference"]["uncertainty"]
    return line_chart(
        series,
        title=f"Work-precision: {case_name}, {_probe_name(case)} error at t = {case['horizon']:g} s",
        x_label="wall time per run (s), median",
        y_label=f"{_probe_name(case)} position error",
        log_x=True,
        log_y=True,
        width=980,
        height=560,
        hlines=[(max(uncertainty, 1e-16), "reference uncertainty")],
        note="colour: integrator; dash/marker: formulation; black crosses: seed-style baseline",
    )


def _fmt_seconds(value) -> str:
    if value is None:
        return "-"
    return f"{value * 1e3:.3g} ms"


def markdown_summary(document: dict) -> str:
    """The tables BENCHMARKS.md quotes: winners per case and the headline."""
    lines = []
    machine = document["machine"]
    lines.append(f"`{document.get('command', 'python -m physics bench')}`; machine: {machine['cpus']} CPUs, load "
                 f"average {machine['load_average_1_5_15']}, Python "
                 f"{machine['python']}; {document['time_definition']}.")
    for name, case in document["cases"].items():
        lines.append("")
        lines.append(f"**{name}** ({_probe_name(case)} error at t = {case['horizon']:g} s; reference uncertainty "
                     f"{case['reference']['uncertainty']:.1e})")
        lines.append("")
        lines.append("| accuracy | fastest configuration | setting | time | runner-up | its time |")
        lines.append("| --- | --- | --- | --- | --- | --- |")
        for row in case["winners"]:
            if row["winner"] is None:
                lines.append(f"| {row['accuracy']:.0e} | {row.get('reason', 'not reached')} | | | | |")
                continue
            lines.append(
                f"| {row['accuracy']:.0e} | {row['winner']} | {row['knob']:g} | {_fmt_seconds(row['seconds'])} | "
                f"{row['runner_up'] or '-'} | {_fmt_seconds(row['runner_up_seconds'])} |"
            )
    if "headline" in document:
        lines.append("")
        lines.append(f"**Headline** ({HEADLINE_CASE}, tip error at t = {HORIZON[HEADLINE_CASE]:g} s): ours vs the "
                     "seed-style baseline, both measured in this run")
        lines.append("")
        lines.append("| accuracy | ours | time | baseline | time | speed-up |")
        lines.append("| --- | --- | --- | --- | --- | --- |")
        for row in document["headline"]:
            ours, base = row["ours"], row["baseline"]
            lines.append(
                f"| {row['accuracy']:.0e} | {ours['label'] + ' @ ' + format(ours['knob'], 'g') if ours else 'not reached'} | "
                f"{_fmt_seconds(ours['seconds'] if ours else None)} | "
                f"{base['label'].split(' (sympy')[0] + ' @ ' + format(base['tolerance'], 'g') if base else 'not reached'} | "
                f"{_fmt_seconds(base['seconds'] if base else None)} | "
                f"{format(row['speedup'], '.0f') + 'x' if row['speedup'] else '-'} |"
            )
    return "\n".join(lines) + "\n"


def _html(document: dict, charts: dict) -> str:
    from .charts import html_page, html_table

    sections = []
    if "headline" in document:
        rows = []
        for row in document["headline"]:
            ours, base = row["ours"], row["baseline"]
            rows.append([
                f"{row['accuracy']:.0e}",
                ours["label"] if ours else "not reached",
                _fmt_seconds(ours["seconds"]) if ours else "-",
                base["label"].split(" (sympy")[0] + f" @ {base['tolerance']:g}" if base else "not reached",
                _fmt_seconds(base["seconds"]) if base else "-",
                f"{row['speedup']:.0f}x" if row["speedup"] else "-",
            ])
        sections.append((f"Headline: {HEADLINE_CASE}, ours vs the seed-style baseline",
                         html_table(["accuracy", "ours (fastest)", "time", "baseline (fastest)", "time", "speed-up"], rows)))
    for name, case in document["cases"].items():
        rows = [[f"{r['accuracy']:.0e}", r["winner"] or r.get("reason", "not reached"), _fmt_seconds(r.get("seconds")),
                 r.get("runner_up") or "-", _fmt_seconds(r.get("runner_up_seconds"))] for r in case["winners"]]
        text = (f"<p>Reference: {case['reference']['description']}; uncertainty "
                f"{case['reference']['uncertainty']:.2e}. Horizon {case['horizon']:g} s.</p>")
        sections.append((f"{name}", charts[name] + text +
                         html_table(["accuracy", "fastest", "time", "runner-up", "time"], rows)))
    machine = document["machine"]
    intro = (f"Error: {document['error_definition']}. Time: {document['time_definition']}. Machine: "
             f"{machine['cpus']} CPUs, load average {machine['load_average_1_5_15']}. "
             f"Made by <code>{html.escape(document.get('command', 'python -m physics bench'))}</code> in "
             f"{document['elapsed_seconds']:.0f} s.")
    return html_page("Linkage Lab: work-precision", sections, intro)


def write_outputs(document: dict, out: Path) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    written = []
    charts = {}
    for name, case in document["cases"].items():
        charts[name] = chart(name, case)
        path = out / f"work_precision_{name}.svg"
        path.write_text(charts[name])
        written.append(path)
    path = out / "work_precision.json"
    path.write_text(json.dumps(document, indent=1))
    written.append(path)
    path = out / "work_precision.html"
    path.write_text(_html(document, charts))
    written.append(path)
    path = out / "work_precision.md"
    path.write_text(markdown_summary(document))
    written.append(path)
    return written


# ------------------------------------------------------------------------------------------------
# Command line


def _parse_list(text: str | None, allowed, field_name: str):
    if text is None:
        return None
    values = [v.strip() for v in text.split(",") if v.strip()]
    for value in values:
        if value not in allowed:
            raise LinkageError(f"{field_name} = {value!r}: allowed {', '.join(allowed)}")
    return tuple(values)


def _parse_tolerances(text: str | None):
    if text is None:
        return None
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise LinkageError(f"--tolerances = {text!r}: expected comma-separated numbers, e.g. 1e-3,1e-6") from None
    if not all(1e-14 <= v <= 0.1 for v in values):
        raise LinkageError(f"--tolerances = {text!r}: every tolerance must lie in 1e-14 <= tol <= 0.1")
    return values


def build_parser() -> argparse.ArgumentParser:
    from .cli import _Parser

    parser = _Parser(prog="python -m physics bench", description=__doc__.split("\n\n")[0])
    parser.add_argument("--suite", default="work-precision",
                        choices=("work-precision", "ensemble", "chaos", "models", "all"))
    parser.add_argument("--preset", default=None, metavar="NAME[,NAME]",
                        help=f"cases for work-precision (default: {', '.join(ALL_CASES)}; --quick: triple-c)")
    parser.add_argument("--quick", action="store_true", help="a small subset (about a minute), as CI runs it")
    parser.add_argument("--out", default="bench-results", help="folder for JSON, SVG, HTML and Markdown")
    parser.add_argument("--formulations", default=None, metavar="F[,F]")
    parser.add_argument("--integrators", default=None, metavar="I[,I]")
    parser.add_argument("--tolerances", default=None, metavar="TOL[,TOL]")
    parser.add_argument("--repeats", type=int, default=None)
    parser.add_argument("--no-baseline", action="store_true", help="skip the seed-style baseline")
    parser.add_argument("--no-progress", action="store_true")
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    out = Path(args.out)
    progress = not args.no_progress
    suites = ("work-precision", "ensemble", "chaos", "models") if args.suite == "all" else (args.suite,)
    if args.repeats is not None and not 1 <= args.repeats <= 100:
        raise LinkageError(f"--repeats = {args.repeats}: allowed range 1 <= repeats <= 100")
    for suite in suites:
        if suite == "work-precision":
            options = dict(QUICK if args.quick else FULL)
            cases = _parse_list(args.preset, ALL_CASES, "--preset")
            if cases:
                options["cases"] = cases
            options["formulations"] = _parse_list(args.formulations, FORMULATIONS, "--formulations") or options["formulations"]
            options["integrators"] = (_parse_list(args.integrators, ADAPTIVE_INTEGRATORS + FIXED_STEP, "--integrators")
                                      or options["integrators"])
            tolerances = _parse_tolerances(args.tolerances)
            if tolerances:
                options["tolerances"] = tolerances
                options["baseline_tolerances"] = tolerances
            if args.repeats:
                options["repeats"] = args.repeats
            if args.no_baseline:
                options["baseline_formulations"] = ()
            document = work_precision(options, progress)
            document["command"] = " ".join(["python -m physics bench", *(sys.argv[2:] if argv is None else argv)])
            written = write_outputs(document, out)
            print(markdown_summary(document))
        elif suite == "ensemble":
            from .ensemble import benchmark as ensemble_benchmark

            written = ensemble_benchmark(out, quick=args.quick, progress=progress)
        elif suite == "chaos":
            from .chaos import benchmark as chaos_benchmark

            written = chaos_benchmark(out, quick=args.quick, progress=progress)
        else:
            from .stability import model_benchmark

            written = model_benchmark(out, quick=args.quick, progress=progress)
        for path in written:
            print(f"wrote {path}", file=sys.stderr)
    return 0
