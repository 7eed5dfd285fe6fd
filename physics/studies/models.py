"""The cheapest model for each question (``python -m physics bench --suite models``): the one-coordinate
reduced four-bar against the full formulations, the cost of one right-hand side (generated code against the
seed's lambdify + numpy.linalg.solve), and ensembles against the real-time frame budget.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..chain_presets import get_preset
from ..ensemble import DEFAULT_STEP
from ..model import FORMULATION_NAMES, Settings
from ..registry import METHODS
from ..simulate import simulate
from ..simulate.chain_system import chain_system
from .ensemble_bench import BENCH_COUNTS, realtime_frame, throughput
from .report import Progress, machine_note, median_time, write_report


def _dist(xy) -> np.ndarray:
    """Lengths of the rows of ``xy`` (T, 2); empty for an open chain's (T, 0)."""
    xy = np.asarray(xy, float)
    return np.hypot(xy[:, 0], xy[:, 1]) if xy.size else np.zeros(0)


def four_bar_models(t_end: float = 100.0, tolerance: float = 1e-9, repeats: int = 3) -> list[dict]:
    """The seed four-bar for ``t_end`` s: the one-coordinate reduced model against each full formulation."""
    preset = get_preset("four-bar")
    rows = []
    # The branch-switching reduced model (one coordinate) against every full formulation.
    reduced = [name for name, spec in METHODS.items() if spec.reduced and spec.switches_branch]
    for method in (*reduced, *FORMULATION_NAMES):
        settings = Settings(method=method, integrator="DOP853", rtol=tolerance, atol=tolerance, t_end=t_end, samples=1001)
        trajectory = simulate(preset.chain, preset.theta0, preset.omega0, settings)
        seconds = median_time(lambda: simulate(preset.chain, preset.theta0, preset.omega0, settings), repeats)
        # the unknowns of the system the run solved (the chain written as a mechanism)
        size = 1 if METHODS[method].reduced else chain_system(preset.chain, method).compiled.n_unknowns
        rows.append({"method": method, "unknowns": size, "seconds": seconds, "status": trajectory.status,
                     "tip_gap": float(_dist(trajectory.constraint_xy).max()), "energy_drift": trajectory.energy_drift(),
                     "n_rhs": trajectory.n_rhs})
    return rows


def rhs_costs(batch: int = 1000) -> list[dict]:
    """Microseconds per acceleration evaluation, triple pendulum: the generated scalar code with its inline
    LU (one state, and per state in a batch), against the same generated A, b solved by numpy.linalg.solve,
    against the seed's lambdify + numpy.linalg.solve."""
    preset = get_preset("triple-c")
    params = preset.chain.params()  # the chain's numbers (the seed baseline's)
    theta, omega = preset.theta0 + 0.1, np.array([0.3, -0.2, 0.1])
    rows = []
    for method in FORMULATION_NAMES:
        # the generated system physics.simulate integrates, its state and parameters in its own terms
        generated = chain_system(preset.chain, method)
        compiled = generated.compiled
        state_theta, state_omega = generated.coordinates(theta), generated.coordinates(omega)
        k = compiled.n_unknowns
        index = compiled.theta_ddot_index
        loops = 2000

        def single():
            for _ in range(loops):
                compiled.accel(state_theta, state_omega, generated.params)

        def numpy_solve():
            for _ in range(loops // 10):
                A, b = compiled.matrix(state_theta, state_omega, generated.params)
                np.linalg.solve(A, b)[index]

        thetas = np.tile(state_theta, (batch, 1))
        omegas = np.tile(state_omega, (batch, 1))
        rows.append({
            "method": method, "unknowns": k,
            "generated_accel_us": median_time(single) / loops * 1e6,
            "generated_accel_batch_us_per_state": median_time(
                lambda: compiled.accel_batch(thetas, omegas, generated.params)) / batch * 1e6,
            "generated_assemble_numpy_solve_us": median_time(numpy_solve) / (loops // 10) * 1e6,
        })
    # sympy boundary: the baseline derives with sympy, imported only when its cost is measured.
    from . import seed_baseline  # noqa: PLC0415

    for method in seed_baseline.FORMULATIONS:
        system = seed_baseline.derived(method)
        rhs = seed_baseline.make_rhs(system, np.concatenate([params[:12], [params[12]]]))
        z = np.concatenate([theta, omega])
        loops = 200

        def baseline():
            for _ in range(loops):
                rhs(0.0, z)

        rows.append({"method": f"seed baseline {method}", "unknowns": system.n_unknowns,
                     "lambdify_numpy_solve_us": median_time(baseline) / loops * 1e6})
    return rows


def benchmark(out: Path, quick: bool = False, progress: bool = True) -> list[Path]:
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
