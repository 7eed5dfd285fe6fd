"""The seed report's figures replayed at its own settings, beside converged runs (``python -m physics seed-report``).

The course report (docs/seed-report.md) integrates with MATLAB's ``ode45`` at ``RelTol = AbsTol = 1e-6`` on
``tspan = linspace(0, dur, 200)``. Each of its figures is recomputed twice: with ``ode45`` (MATLAB's controller,
error norm and first step as published, :mod:`physics.kernels.ode45`: the report's own run as closely as it can
be followed without MATLAB) and with scipy's ``RK45`` (the same Dormand-Prince pair under scipy's controller),
and next to them a converged run (DOP853 at 1e-12, whose own error is measured against a second one at 1e-13):

* Figures 9-11, the tip path of cases A, B, C over 20 s: how far the report's tip is from the converged one,
  and when it first leaves it by more than :data:`TIP_DEPARTURE` (the curve is then not the true motion).
* Figures 12-13, ``x_NE - x_DAE`` and ``x_NE - x_Lagrange``: the three formulations take the same steps on the
  same equations, so these differences measure rounding only. The difference that measures error is each
  method against the converged run, drawn beside them.
* The four-bar (DAE, constraint imposed on accelerations only, 1e-6, 100 s): how far the tip drifts off its pin,
  how much energy drifts, and when theta1 leaves the converged run by more than :data:`ANGLE_DEPARTURE`; and
  the same run with the constraint stabilised (projection after every accepted step and every sample).

ode45's steps depend on ``tspan`` only through its first spacing (``htspan`` bounds the first step; the outputs
are interpolated), so the ode45 replays are run with the report's first spacing ``dur / 199`` and read on the
study's finer grid: the same steps as ``ode45(f, linspace(0, dur, 200), z0, options)``.

Every number is computed here; nothing is typed in. The sizes are arguments so the tests can run the same
code on shorter horizons.
"""

from __future__ import annotations

import functools
import json
from pathlib import Path
from typing import TextIO

import numpy as np

from .chain_presets import get_preset
from .fbd import fbd_svg, free_body_at
from .file_io import write_atomically
from .kernels import ode45
from .model import FORMULATION_NAMES, Settings, validated
from .simulate import Trajectory, simulate
from .simulate.chain_prepared import stabilization_gains
from .simulate.chain_system import chain_system
from .status import Status
from .studies.charts import DASHES, PALETTE, PANEL_TEXT_PX, Series, panel_line_chart

# The report's settings: ode45 with odeset('RelTol', 1e-6, 'AbsTol', 1e-6) on tspan = linspace(0, dur, 200).
REPORT_INTEGRATOR = "ode45"  # MATLAB's controller (physics/kernels/ode45.py): the report's own method
SCIPY_INTEGRATOR = "RK45"  # the same pair with scipy's controller: what this replay used before ode45 existed
REPLAY_INTEGRATORS = (REPORT_INTEGRATOR, SCIPY_INTEGRATOR)
REPORT_TOLERANCE = 1e-6
REPORT_POINTS = 200  # the report's npoints: its tspan's first spacing bounds ode45's first step
# The converged runs: an eighth-order method six orders tighter; CHECK_TOLERANCE measures their own error.
REFERENCE_INTEGRATOR = "DOP853"
REFERENCE_TOLERANCE = 1e-12
CHECK_TOLERANCE = 1e-13
# A tip more than this far (length units; the triple pendulum reaches 3) from the converged one draws a
# visibly different curve: the figure has stopped showing the true motion.
TIP_DEPARTURE = 0.1
# The four-bar's crank angle off the converged one by more than this (radians, about half a degree).
ANGLE_DEPARTURE = 0.01
# Below this a value on a log axis is drawn at it (an exact zero has no logarithm).
FLOOR = 1e-17
# Points per curve in a figure (every k-th sample): enough for the eye, and the SVG files stay small.
FIGURE_POINTS = 2000
# Figures and numbers are documentation: readable by everyone, like the rest of the repository.
OUTPUT_MODE = 0o644

TRIPLE_CASES = (("A", "triple-a", 9), ("B", "triple-b", 10), ("C", "triple-c", 11))
TEXT_READINGS = (("B (text)", "triple-b-text"), ("C (text)", "triple-c-text"))
TRIPLE_T_END = 20.0  # the report's dur = 20
FOUR_BAR_T_END = 100.0  # the report's dur = 100
SAMPLES_PER_SECOND = 100  # output grid only: neither controller's steps depend on it (ode45: see the docstring)
# The report's free-body diagrams, computed: triple pendulum (its Figures 6-8) at an instant in motion, and the
# four-bar (Figures 15-17) at its start. (preset, time in s, report's figure numbers of bars 1..3)
FREE_BODY_DIAGRAMS = (("triple-a", 2.5, (6, 7, 8)), ("four-bar", 0.0, (15, 16, 17)))


def _ode45_as_called(preset_name: str, settings: Settings) -> Trajectory:
    """ode45 with the report's ``tspan = linspace(0, t_end, 200)``, read at ``settings.samples`` equally spaced
    times: the steps depend on that tspan only through its first spacing (``htspan``, the first step's bound),
    which is handed to the kernel; the samples are interpolated (ntrp45) as MATLAB does at tspan points."""
    preset = get_preset(preset_name)
    chain = preset.chain
    # the system physics.simulate integrates: the chain written as a mechanism
    system = chain_system(chain, settings.method, settings.damping)
    alpha, beta, project = stabilization_gains(chain, settings)
    t_eval = np.linspace(0.0, settings.t_end, settings.samples)
    y_out = np.full((len(t_eval), 2 * chain.n), np.nan)
    y0 = system.state(preset.theta0, preset.omega0)
    status, n_steps, n_rhs, t_reached, _ = ode45.integrate_ode45_htspan(
        system.compiled.assemble_function, system.layout, y0, 0.0, settings.t_end, t_eval,
        settings.t_end / (REPORT_POINTS - 1), system.params, settings.rtol, settings.atol, alpha, beta, project,
        settings.max_steps, y_out, np.empty(0))
    if status != Status.OK:
        raise RuntimeError(f"{preset_name} {settings.method} ode45: {Status.describe(int(status), t_reached, '')}")
    run = system.trajectory(chain, settings, t_eval, y_out, alpha, beta)
    run.status = Status.OK
    run.n_steps, run.n_rhs = int(n_steps), int(n_rhs)
    return run


@functools.lru_cache(maxsize=32)
def _run(preset_name: str, method: str, integrator: str, tolerance: float, t_end: float, samples: int,
         stabilization: str = "projection") -> Trajectory:
    """One run (kept: both replays compare with the same converged runs). ode45 as the report called it."""
    preset = get_preset(preset_name)
    settings = validated(Settings, method=method, integrator=integrator, rtol=tolerance, atol=tolerance,
                         t_end=t_end, samples=samples, stabilization=stabilization)
    if integrator == REPORT_INTEGRATOR:
        return _ode45_as_called(preset_name, settings)
    run = simulate(preset.chain, preset.theta0, preset.omega0, settings)
    if not run.success:
        raise RuntimeError(f"{preset_name} {method} {integrator} {tolerance:g}: {run.message}")
    return run


def first_time_above(t: np.ndarray, values: np.ndarray, threshold: float) -> float | None:
    """The first sample time where ``values`` exceeds ``threshold`` (None if never)."""
    over = np.flatnonzero(np.asarray(values) > threshold)
    return float(t[over[0]]) if over.size else None


def _distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.hypot(a[:, 0] - b[:, 0], a[:, 1] - b[:, 1])


def triple_case(preset_name: str, t_end: float = TRIPLE_T_END, samples: int | None = None,
                integrator: str = REPORT_INTEGRATOR) -> dict:
    """One triple-pendulum case at the report's settings (all three formulations, with ``integrator``: ode45 or
    RK45) against the converged run.

    Returns numbers (JSON-able) and, under ``"series"``, the curves the figures draw (arrays)."""
    samples = samples or int(t_end * SAMPLES_PER_SECOND) + 1
    report = {m: _run(preset_name, m, integrator, REPORT_TOLERANCE, t_end, samples) for m in FORMULATION_NAMES}
    reference = _run(preset_name, "lagrange", REFERENCE_INTEGRATOR, REFERENCE_TOLERANCE, t_end, samples)
    check = _run(preset_name, "newton_euler", REFERENCE_INTEGRATOR, CHECK_TOLERANCE, t_end, samples)
    t = reference.t
    tip_error = _distance(report["newton_euler"].tip_xy, reference.tip_xy)
    x_error = {m: np.abs(run.tip_xy[:, 0] - reference.tip_xy[:, 0]) for m, run in report.items()}
    ne_x = report["newton_euler"].tip_xy[:, 0]
    ne_minus_dae = np.abs(ne_x - report["dae"].tip_xy[:, 0])
    ne_minus_lagrange = np.abs(ne_x - report["lagrange"].tip_xy[:, 0])
    reference_error = _distance(check.tip_xy, reference.tip_xy)
    return {
        "preset": preset_name,
        "integrator": integrator,
        "theta0": get_preset(preset_name).theta0.tolist(),
        "t_end": t_end,
        "tip_error_max": float(tip_error.max()),
        "tip_error_at_end": float(tip_error[-1]),
        "departure_time": first_time_above(t, tip_error, TIP_DEPARTURE),
        "ne_minus_dae_max": float(ne_minus_dae.max()),
        "ne_minus_lagrange_max": float(ne_minus_lagrange.max()),
        "x_error_max": {m: float(v.max()) for m, v in x_error.items()},
        "x_error_departure": {m: first_time_above(t, v, TIP_DEPARTURE) for m, v in x_error.items()},
        "steps": {m: run.n_steps for m, run in report.items()},
        "reference_error_max": float(reference_error.max()),
        "series": {
            "t": t, "report_tip": report["newton_euler"].tip_xy, "reference_tip": reference.tip_xy,
            "tip_error": tip_error, "ne_minus_dae": ne_minus_dae, "ne_minus_lagrange": ne_minus_lagrange,
            "x_error": x_error, "reference_error": reference_error,
        },
    }


def four_bar_case(t_end: float = FOUR_BAR_T_END, samples: int | None = None,
                  integrator: str = REPORT_INTEGRATOR) -> dict:
    """The four-bar at the report's settings (DAE, acceleration-level constraint, ``integrator`` at 1e-6), the same
    with the constraint projected back after every accepted step and every sample, and the converged run."""
    samples = samples or int(t_end * SAMPLES_PER_SECOND) + 1
    report = _run("four-bar", "dae", integrator, REPORT_TOLERANCE, t_end, samples, stabilization="none")
    projected = _run("four-bar", "dae", integrator, REPORT_TOLERANCE, t_end, samples)
    reference = _run("four-bar", "dae", REFERENCE_INTEGRATOR, REFERENCE_TOLERANCE, t_end, samples)
    check = _run("four-bar", "dae", REFERENCE_INTEGRATOR, CHECK_TOLERANCE, t_end, samples)
    t = reference.t

    def summary(run: Trajectory) -> dict:
        pin_gap = np.hypot(run.constraint_xy[:, 0], run.constraint_xy[:, 1])
        energy_error = np.abs(run.energy - run.energy[0]) / abs(run.energy[0])
        theta1_error = np.abs(run.theta[:, 0] - reference.theta[:, 0])
        return {
            "pin_gap_max": float(pin_gap.max()), "pin_gap_at_end": float(pin_gap[-1]),
            "energy_error_max": float(energy_error.max()),
            "theta1_error_max": float(theta1_error.max()),
            "theta1_departure": first_time_above(t, theta1_error, ANGLE_DEPARTURE),
            "steps": run.n_steps,
            "series": {"pin_gap": pin_gap, "energy_error": energy_error, "theta1": run.theta[:, 0],
                       "theta1_error": theta1_error},
        }

    return {
        "t_end": t_end,
        "integrator": integrator,
        "energy0": float(reference.energy[0]),
        "report": summary(report),
        "projected": summary(projected),
        "reference": summary(reference),
        "reference_theta_error_max": float(np.max(np.abs(check.theta - reference.theta))),
        "series": {"t": t},
    }


# ------------------------------------------------------------------------------------------------
# Figures


def _floor(values) -> list[float]:
    return [max(float(v), FLOOR) for v in np.asarray(values, dtype=float)]


def _thin(values) -> list[float]:
    """Every k-th sample (and the last), at most about FIGURE_POINTS of them."""
    array = np.asarray(values, dtype=float)
    stride = max(1, -(-len(array) // FIGURE_POINTS))
    index = np.unique(np.append(np.arange(0, len(array), stride), len(array) - 1))
    return [float(v) for v in array[index]]


def _leaves(case: dict) -> str:
    departure = case["departure_time"]
    return f"from t = {departure:.2f} s" if departure is not None else "never"


def figure_tip_path(label: str, number: int, case: dict, scipy_case: dict) -> str:
    s = case["series"]
    converged = Series(f"converged ({REFERENCE_INTEGRATOR} {REFERENCE_TOLERANCE:g})", _thin(s["reference_tip"][:, 0]),
                       _thin(s["reference_tip"][:, 1]), color=PALETTE[0], marker=None, width=2.4)
    replayed = Series(f"report's settings, {REPORT_INTEGRATOR} {REPORT_TOLERANCE:g}", _thin(s["report_tip"][:, 0]),
                      _thin(s["report_tip"][:, 1]), color=PALETTE[2], dash=DASHES[1], marker=None)
    other = scipy_case["series"]
    scipy_run = Series(f"same with scipy's {SCIPY_INTEGRATOR}", _thin(other["report_tip"][:, 0]),
                       _thin(other["report_tip"][:, 1]), color=PALETTE[4], dash=DASHES[2 % len(DASHES)], marker=None)
    note = (f"off the converged curve by > {TIP_DEPARTURE:g}: {REPORT_INTEGRATOR} {_leaves(case)}, "
            f"{SCIPY_INTEGRATOR} {_leaves(scipy_case)}")
    theta = ", ".join(f"{v:.4g}" for v in case["theta0"])
    return panel_line_chart([converged, replayed, scipy_run],
                            title=f"Figure {number}, case {label}: tip path over {case['t_end']:g} s (theta0 = {theta})",
                            x_label="x", y_label="y", plot_height=300, note=note)


def figure_differences(label: str, case: dict, scipy_case: dict) -> str:
    s = case["series"]
    t = _thin(s["t"])
    series = [
        Series("x_NE - x_DAE (report's Fig 12)", t, _floor(_thin(s["ne_minus_dae"])), color="#222222", marker=None),
        Series("x_NE - x_Lagrange (report's Fig 13)", t, _floor(_thin(s["ne_minus_lagrange"])), color="#888888",
               dash=DASHES[1], marker=None),
    ]
    for k, (method, error) in enumerate(s["x_error"].items()):
        series.append(Series(f"x_{method} - x_converged", t, _floor(_thin(error)), color=PALETTE[k + 1],
                             dash=DASHES[k % len(DASHES)], marker=None))
    series.append(Series(f"x_newton_euler - x_converged, {SCIPY_INTEGRATOR}", t,
                         _floor(_thin(scipy_case["series"]["x_error"]["newton_euler"])), color=PALETTE[6],
                         dash=DASHES[2 % len(DASHES)], marker=None))
    return panel_line_chart(series, title=f"Figures 12-13, case {label}: differences between methods vs error of each",
                            x_label="t (s)", y_label="|difference in tip x|", log_y=True,
                            hlines=[(TIP_DEPARTURE, f"{TIP_DEPARTURE:g}: visible on the report's plots")],
                            note=f"all at {REPORT_INTEGRATOR} {REPORT_TOLERANCE:g} but the last; converged = "
                                 f"{REFERENCE_INTEGRATOR} {REFERENCE_TOLERANCE:g}; values below {FLOOR:g} drawn at {FLOOR:g}")


def figure_four_bar(case: dict, scipy_case: dict, quantity: str) -> str:
    t = _thin(case["series"]["t"])
    runs = ((case["report"], f"report's settings ({REPORT_INTEGRATOR} {REPORT_TOLERANCE:g}, no stabilisation)",
             PALETTE[2], DASHES[1]),
            (scipy_case["report"], f"same with scipy's {SCIPY_INTEGRATOR}", PALETTE[6], DASHES[2 % len(DASHES)]),
            (case["projected"], f"{REPORT_INTEGRATOR}, constraint projected", PALETTE[4], DASHES[1]),
            (case["reference"], f"converged ({REFERENCE_INTEGRATOR} {REFERENCE_TOLERANCE:g}, projected)",
             PALETTE[0], ""))
    if quantity == "theta1":
        series = [Series(label, t, _thin(run["series"]["theta1"]), color=colour, marker=None, dash=dash)
                  for run, label, colour, dash in runs]
        return panel_line_chart(series, title="Four-bar: crank angle theta1", x_label="t (s)",
                                y_label="theta1 (rad)")
    y_label, title = {"pin_gap": ("|tip - pin|", "Four-bar: tip distance from its pin"),
                      "energy_error": ("|E - E0| / |E0|", "Four-bar: relative energy error")}[quantity]
    # The largest value so far: at rounding level the raw values flicker over decades and hide the curve.
    series = [Series(label, t, _floor(_thin(np.maximum.accumulate(run["series"][quantity]))), color=colour,
                     marker=None) for run, label, colour, _ in runs]
    return panel_line_chart(series, title=title, x_label="t (s)", y_label=f"{y_label}, largest so far", log_y=True,
                            note=f"values below {FLOOR:g} drawn at {FLOOR:g}")


# ------------------------------------------------------------------------------------------------
# The study


def _replay(integrator: str, quick: bool) -> dict:
    triple_t_end = 5.0 if quick else TRIPLE_T_END
    return {
        "triple": {label: triple_case(name, triple_t_end, integrator=integrator) for label, name, _ in TRIPLE_CASES},
        "text_readings": {label: triple_case(name, triple_t_end, integrator=integrator)
                          for label, name in TEXT_READINGS},
        "four_bar": four_bar_case(20.0 if quick else FOUR_BAR_T_END, integrator=integrator),
    }


def run_study(quick: bool = False) -> dict:
    """Every case with both controllers; ``quick`` shortens the horizons (5 s and 20 s) to check that it runs.

    The top-level ``triple``, ``text_readings`` and ``four_bar`` are the report's own method (ode45); the same
    under ``scipy_rk45`` are scipy's RK45."""
    replays = {integrator: _replay(integrator, quick) for integrator in REPLAY_INTEGRATORS}
    return {
        "settings": {"report_integrator": REPORT_INTEGRATOR, "report_tolerance": REPORT_TOLERANCE,
                     "report_points": REPORT_POINTS, "scipy_integrator": SCIPY_INTEGRATOR,
                     "reference_integrator": REFERENCE_INTEGRATOR, "reference_tolerance": REFERENCE_TOLERANCE,
                     "check_tolerance": CHECK_TOLERANCE, "tip_departure": TIP_DEPARTURE,
                     "angle_departure": ANGLE_DEPARTURE, "quick": quick},
        **replays[REPORT_INTEGRATOR],
        "scipy_rk45": replays[SCIPY_INTEGRATOR],
    }


def _without_series(value):
    if isinstance(value, dict):
        return {k: _without_series(v) for k, v in value.items() if k != "series"}
    return value


def write_study(out: Path, quick: bool = False) -> dict:
    """Run the study, write its figures (SVG) and ``seed-report.json`` (numbers only) into ``out``."""
    document = run_study(quick)
    scipy = document["scipy_rk45"]
    out.mkdir(exist_ok=True)
    figures = {}
    for label, name, number in TRIPLE_CASES:
        case, scipy_case = document["triple"][label], scipy["triple"][label]
        figures[f"figure-{number}-case-{label.lower()}.svg"] = figure_tip_path(label, number, case, scipy_case)
        figures[f"figures-12-13-case-{label.lower()}.svg"] = figure_differences(label, case, scipy_case)
    for quantity in ("pin_gap", "energy_error", "theta1"):
        figures[f"four-bar-{quantity.replace('_', '-')}.svg"] = figure_four_bar(document["four_bar"],
                                                                               scipy["four_bar"], quantity)
    for name, time, numbers in FREE_BODY_DIAGRAMS:
        preset = get_preset(name)
        for bar, number in enumerate(numbers, start=1):
            body = free_body_at(preset.chain, preset.theta0, preset.omega0, time, bar)
            title = f"{name}, bar {bar} at t = {time:g} s (the report's Figure {number})"
            figures[f"fbd-{name}-bar-{bar}.svg"] = fbd_svg(body, title=title, text_px=PANEL_TEXT_PX)
    for name, svg in figures.items():
        write_atomically(out / name, svg.encode("utf-8"), mode=OUTPUT_MODE)
    numbers = _without_series(document)
    numbers["figures"] = sorted(figures)
    write_atomically(out / "seed-report.json", (json.dumps(numbers, indent=2) + "\n").encode("utf-8"),
                     mode=OUTPUT_MODE)
    return numbers


def _departure(t: float | None, threshold: float, unit: str, t_end: float) -> str:
    if t is None:
        return f"never off by more than {threshold:g}{unit} within {t_end:g} s"
    return f"off by more than {threshold:g}{unit} from t = {t:.2f} s"


def _when(t: float | None) -> str:
    return "never" if t is None else f"{t:.2f} s"


def print_summary(numbers: dict, stream: TextIO) -> None:
    """The study's numbers as the docs quote them: each figure with ode45 and with RK45, then what differs."""
    s = numbers["settings"]
    replays = {s["report_integrator"]: numbers, s["scipy_integrator"]: numbers["scipy_rk45"]}

    def write(line: str = "") -> None:
        print(line, file=stream)

    write(f"Report's settings: rtol = atol = {s['report_tolerance']:g}, tspan = linspace(0, dur, "
          f"{s['report_points']}); {s['report_integrator']} = MATLAB's controller, {s['scipy_integrator']} = "
          f"scipy's; converged runs: {s['reference_integrator']} {s['reference_tolerance']:g} (checked against "
          f"{s['check_tolerance']:g})")
    write()
    write("Figures 9-11: tip of the triple pendulum, report's run against the converged run")
    for integrator, replay in replays.items():
        for label, case in {**replay["triple"], **replay["text_readings"]}.items():
            write(f"  {integrator:<5} case {label:<8} ({case['preset']}): off by up to {case['tip_error_max']:.3g} "
                  f"({case['tip_error_at_end']:.2g} at {case['t_end']:g} s); "
                  f"{_departure(case['departure_time'], s['tip_departure'], '', case['t_end'])}; converged run's "
                  f"own error {case['reference_error_max']:.1g}")
    write()
    write("Figures 12-13: differences between the formulations (same steps) and each one's own error in x")
    for integrator, replay in replays.items():
        for label, case in replay["triple"].items():
            errors = ", ".join(f"{m} {v:.2g}" for m, v in case["x_error_max"].items())
            write(f"  {integrator:<5} case {label}: {case['steps']['newton_euler']} steps; max |x_NE - x_DAE| = "
                  f"{case['ne_minus_dae_max']:.2g}, max |x_NE - x_Lagrange| = {case['ne_minus_lagrange_max']:.2g}; "
                  f"max |x - x_converged|: {errors}")
    write()
    four = numbers["four_bar"]
    write(f"Four-bar, DAE over {four['t_end']:g} s (E0 = {four['energy0']:.6g})")
    rows = []
    for integrator, replay in replays.items():
        rows += [(replay["four_bar"]["report"], f"{integrator}, report's settings (acceleration-level constraint)"),
                 (replay["four_bar"]["projected"], f"{integrator}, same tolerance, constraint projected")]
    rows.append((four["reference"], "converged run"))
    for r, what in rows:
        write(f"  {what}: tip off its pin by up to {r['pin_gap_max']:.2g} ({r['pin_gap_at_end']:.2g} at the end); "
              f"energy off by up to {100 * r['energy_error_max']:.2g} %; theta1 against the converged run: "
              f"{_departure(r['theta1_departure'], s['angle_departure'], ' rad', four['t_end'])}, "
              f"at most {r['theta1_error_max']:.2g} rad off")
    write(f"  converged run's own error in the angles: {four['reference_theta_error_max']:.1g} rad")
    write()
    ours, theirs = s["report_integrator"], s["scipy_integrator"]
    a, b = numbers, numbers["scipy_rk45"]
    write(f"What depends on the controller ({ours} vs {theirs})")
    for label in a["triple"]:
        write(f"  case {label} leaves the converged motion: {_when(a['triple'][label]['departure_time'])} vs "
              f"{_when(b['triple'][label]['departure_time'])}; off by up to {a['triple'][label]['tip_error_max']:.3g}"
              f" vs {b['triple'][label]['tip_error_max']:.3g}")
    ra, rb = a["four_bar"]["report"], b["four_bar"]["report"]
    write(f"  four-bar at the report's settings: pin drift {ra['pin_gap_max']:.2g} vs {rb['pin_gap_max']:.2g}; "
          f"energy {100 * ra['energy_error_max']:.2g} % vs {100 * rb['energy_error_max']:.2g} %; theta1 leaves "
          f"the converged run at {_when(ra['theta1_departure'])} vs {_when(rb['theta1_departure'])}")
