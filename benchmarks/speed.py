"""Speed of Linkage Lab's physics against the seed's approach, measured side by side in one run.

    python -m benchmarks.speed [--quick] [--out speed.json] [--sections seed,rhs,derive,process]

Without ``--out`` the JSON goes into a new private temporary folder (mkdtemp: mode 0700, a fresh name), never
to a fixed name in the shared temporary folder, where another user could have planted a file or a link; the
last line names the file.

Sections (BENCHMARKS.md quotes their output with the command and the machine):

* ``seed``: the seed's three 20 s cases at its settings (RK45, rtol = atol = 1e-6, 200 samples), baseline
  (physics/studies/seed_baseline.py: sympy + simplify + lambdify + numpy.linalg.solve + solve_ivp) against
  ``physics.simulate`` on the compiled RK45 path, for Lagrange and the DAE. Derivation excluded on both sides
  (warmed up first). Calls are interleaved (baseline, ours, ours with scipy, the bare compiled kernel, in a
  rotating order) and each is timed alone with ``time.perf_counter`` and the garbage collector paused, as
  ``timeit`` does; medians are reported. Also checks that both give the same tip trajectory and step count.
* ``rhs``: one right-hand-side call of the triple pendulum per formulation (the generated ``accel`` called
  from Python with preallocated arrays, and the same call from inside compiled code), the batched call per
  state for a batch of 1000, and the baseline's right-hand side.
* ``derive``: derivation + code generation + numba compile of ``accel`` per formulation for n = 1..12
  (``--quick``: 1..4), each in a fresh subprocess: cold (empty ``LINKAGE_LAB_CACHE``) then warm (same folder).
* ``process``: wall time of ``python -m physics simulate --preset triple-a`` with a warm cache (median of 5
  subprocesses), and whether sympy is imported on that path.

The machine is shared (2 cores, other jobs running): the load average is recorded with the results.
"""

from __future__ import annotations

import argparse
import datetime
import gc
import json
import os
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO_ROOT = Path(__file__).resolve().parent.parent
SECTIONS = ("seed", "rhs", "derive", "process")
SEED_PRESETS = {"A": "triple-a", "B": "triple-b", "C": "triple-c"}
BASELINE_FORMULATIONS = ("lagrange", "dae")
SPEEDUP_TARGET = 30.0
# The baseline and ours take the same RK45 steps; their tip trajectories differ only by rounding in the
# right-hand side, amplified by the chaotic motion. Agreement is declared within 100 x atol of the seed run.
TIP_AGREEMENT = 1e-4
COLD_N10_TARGET_S = 60.0
WARM_N3_TARGET_S = 0.5
PROCESS_TARGET_S = 1.5
CHILD_TIMEOUT_S = 1800


# ---------------------------------------------------------------------------------------------------------------
# Timing helpers


def _time_once(fn) -> tuple[float, float]:
    """Wall seconds (``perf_counter``) and CPU seconds of this process (``process_time``) for one call, garbage
    collector paused (as timeit does). CPU time is the figure less disturbed by other jobs on a shared machine."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        cpu_start = time.process_time()
        start = time.perf_counter()
        fn()
        wall = time.perf_counter() - start
        return wall, time.process_time() - cpu_start
    finally:
        if was_enabled:
            gc.enable()


def _time_per_call(fn, number: int) -> float:
    """Wall seconds per call averaged over ``number`` back-to-back calls (for sub-microsecond calls)."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        start = time.perf_counter()
        for _ in range(number):
            fn()
        return (time.perf_counter() - start) / number
    finally:
        if was_enabled:
            gc.enable()


def _summary(samples: list[float], cpu_samples: list[float] | None = None) -> dict:
    quartiles = statistics.quantiles(samples, n=4) if len(samples) >= 2 else [samples[0]] * 3
    summary = {
        "median_s": statistics.median(samples),
        "p25_s": quartiles[0],
        "p75_s": quartiles[2],
        "min_s": min(samples),
        "count": len(samples),
    }
    if cpu_samples:
        summary["cpu_median_s"] = statistics.median(cpu_samples)
    return summary


def interleaved(candidates: dict, repeats: int, calls_per_round: dict | None = None) -> dict:
    """Time every candidate in rounds, rotating their order each round; returns name -> summary.

    ``calls_per_round[name]`` individually timed calls per round (default 1): fast candidates get more
    samples without the slow ones dominating the wall time."""
    calls_per_round = calls_per_round or {}
    names = list(candidates)
    wall = {name: [] for name in names}
    cpu = {name: [] for name in names}
    for round_index in range(repeats):
        shift = round_index % len(names)
        for name in names[shift:] + names[:shift]:
            for _ in range(calls_per_round.get(name, 1)):
                seconds, cpu_seconds = _time_once(candidates[name])
                wall[name].append(seconds)
                cpu[name].append(cpu_seconds)
    return {name: _summary(wall[name], cpu[name]) for name in names}


# ---------------------------------------------------------------------------------------------------------------
# Machine


def machine_info() -> dict:
    import numba
    import scipy
    import sympy

    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {
        "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "cpu": cpu,
        "cores": os.cpu_count(),
        "load_average_at_start": os.getloadavg(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "sympy": sympy.__version__,
        "numba": numba.__version__,
        "platform": platform.platform(),
    }


# ---------------------------------------------------------------------------------------------------------------
# Section seed: the seed's 20 s cases, baseline against ours


def _seed_setup(case: str):
    import physics
    from physics.studies import seed_baseline

    preset = physics.get_preset(SEED_PRESETS[case])
    params = preset.chain.params()
    # The baseline and the preset must describe the same run.
    if not np.allclose(params[: 4 * 3 + 1], seed_baseline.SEED_PARAMS, rtol=0, atol=0):
        raise RuntimeError(f"preset {preset.name} parameters {params} differ from the seed's")
    if not np.allclose(preset.theta0, seed_baseline.SEED_CASES[case], rtol=0, atol=0) or np.any(preset.omega0):
        raise RuntimeError(f"preset {preset.name} start differs from the seed's case {case}")
    return preset


def _settings(method: str, backend: str):
    import physics
    from physics.studies import seed_baseline as sb

    return physics.Settings(
        method=method, integrator="RK45", backend=backend, rtol=sb.SEED_RTOL, atol=sb.SEED_ATOL,
        t_end=sb.SEED_T_END, samples=sb.SEED_SAMPLES,
    )


def bench_seed(repeats: int, fast_calls: int) -> list[dict]:
    import physics
    from physics.studies import seed_baseline as sb

    rows = []
    for formulation in BASELINE_FORMULATIONS:
        derive_seconds = sb.derived(formulation).derive_seconds  # once, outside every timing
        compiled = physics.load_compiled(formulation, 3)
        for case in SEED_PRESETS:
            preset = _seed_setup(case)
            chain, theta0, omega0 = preset.chain, preset.theta0, preset.omega0
            compiled_settings = _settings(formulation, "compiled")
            scipy_settings = _settings(formulation, "scipy")
            params = chain.params()
            y0 = np.concatenate([theta0, omega0])
            t_eval = np.linspace(0.0, sb.SEED_T_END, sb.SEED_SAMPLES)
            y_out = np.empty((sb.SEED_SAMPLES, 6))
            cond_out = np.empty(sb.SEED_SAMPLES)

            def run_baseline():
                return sb.simulate(formulation, theta0, omega0)

            def run_ours():
                return physics.simulate(chain, theta0, omega0, compiled_settings)

            def run_ours_scipy():
                return physics.simulate(chain, theta0, omega0, scipy_settings)

            def run_kernel():
                # The compiled loop alone: what physics.simulate calls, without validation and post-processing.
                return compiled.integrate_rk45(
                    y0, 0.0, sb.SEED_T_END, t_eval, params, sb.SEED_RTOL, sb.SEED_ATOL, 0.0, 0.0, False,
                    10_000_000, y_out, cond_out,
                )

            for _ in range(2):  # warm-up: numba's first calls, caches, branch predictors
                baseline_sol = run_baseline()
                ours = run_ours()
                ours_scipy = run_ours_scipy()
                kernel_result = run_kernel()

            base_tip = sb.tip_xy(baseline_sol.y[:3].T)
            tip_diff = float(np.max(np.abs(base_tip - ours.tip_xy)))
            scipy_tip_diff = float(np.max(np.abs(ours_scipy.tip_xy - ours.tip_xy)))
            times = interleaved(
                {"baseline": run_baseline, "ours": run_ours, "ours_scipy": run_ours_scipy, "kernel": run_kernel},
                repeats,
                {"ours": fast_calls, "kernel": fast_calls},
            )
            ratio = times["baseline"]["median_s"] / times["ours"]["median_s"]
            rows.append({
                "formulation": formulation,
                "case": case,
                "preset": preset.name,
                "baseline_derive_s": derive_seconds,
                "baseline": times["baseline"],
                "ours": times["ours"],
                "ours_scipy": times["ours_scipy"],
                "kernel": times["kernel"],
                "speedup": ratio,
                "speedup_cpu_time": times["baseline"]["cpu_median_s"] / times["ours"]["cpu_median_s"],
                "speedup_kernel_only": times["baseline"]["median_s"] / times["kernel"]["median_s"],
                "speedup_scipy_backend": times["baseline"]["median_s"] / times["ours_scipy"]["median_s"],
                "meets_target": ratio >= SPEEDUP_TARGET,
                "baseline_nfev": int(baseline_sol.nfev),
                "ours_n_rhs": int(ours.n_rhs),
                "ours_n_steps": int(ours.n_steps),
                "ours_scipy_n_rhs": int(ours_scipy.n_rhs),
                "kernel_n_rhs": int(kernel_result[2]),
                "same_steps": int(baseline_sol.nfev) == int(ours.n_rhs) == int(ours_scipy.n_rhs),
                "tip_max_abs_diff_vs_baseline": tip_diff,
                "tip_max_abs_diff_scipy_backend": scipy_tip_diff,
                "agree": tip_diff <= TIP_AGREEMENT and scipy_tip_diff <= TIP_AGREEMENT,
                "status": ours.message,
            })
            print(_seed_line(rows[-1]), flush=True)
    return rows


def _ms(summary: dict) -> str:
    return f"{summary['median_s'] * 1e3:8.3f}"


def _seed_line(row: dict) -> str:
    return (
        f"  {row['formulation']:9s} {row['case']}  baseline {_ms(row['baseline'])} ms  ours {_ms(row['ours'])} ms"
        f"  ratio {row['speedup']:6.1f}x (CPU time {row['speedup_cpu_time']:6.1f}x)"
        f"  (kernel {_ms(row['kernel'])} ms, {row['speedup_kernel_only']:6.1f}x;"
        f" scipy backend {_ms(row['ours_scipy'])} ms)  nfev {row['baseline_nfev']}/{row['ours_n_rhs']}"
        f"  |d tip| {row['tip_max_abs_diff_vs_baseline']:.1e}"
    )


# ---------------------------------------------------------------------------------------------------------------
# Section rhs: one right-hand-side call


def _compiled_loop():
    """Compiled loops that call a mechanism's right-hand side (its generated ``assemble`` and the kernels'
    solve, as the integrators do) ``count`` times: its cost without the Python-to-numba dispatch."""
    from numba import njit

    from physics.kernels.system import assemble_into, make_system, solve_accel

    @njit
    def loop(assemble, layout, theta, omega, params, theta_ddot, count):
        system = make_system(assemble, layout)
        total = 0.0
        for _ in range(count):
            theta[0] += 1e-12  # a changing input, so nothing is hoisted out of the loop
            solve_accel(system, theta, omega, params, 0.0, 0.0, theta_ddot)
            total += theta_ddot[0]
        return total

    @njit
    def loop_assemble(assemble, layout, theta, omega, params, count):
        system = make_system(assemble, layout)
        total = 0.0
        for _ in range(count):
            theta[0] += 1e-12
            assemble_into(system, theta, omega, params, 0.0, 0.0)
            total += system[3][0]
        return total

    return loop, loop_assemble


def bench_rhs(repeats: int, batch: int = 1000) -> list[dict]:
    import physics
    from physics.studies import seed_baseline as sb

    rng = np.random.default_rng(7)
    preset = physics.get_preset("triple-a")
    params = preset.chain.params()
    theta = rng.uniform(-np.pi, np.pi, 3)
    omega = rng.uniform(-2, 2, 3)
    theta_batch = rng.uniform(-np.pi, np.pi, (batch, 3))
    omega_batch = rng.uniform(-2, 2, (batch, 3))
    loop, loop_assemble = _compiled_loop()
    rows = []
    for formulation in physics.FORMULATION_NAMES:
        compiled = physics.load_compiled(formulation, 3)
        theta_ddot = np.empty(3)

        def single():
            compiled.accel(theta, omega, params)

        def batched():
            compiled.accel_batch(theta_batch, omega_batch, params)

        inner_count = 20_000
        theta_loop = theta.copy()

        def in_compiled():
            loop(compiled.assemble_function, compiled.layout, theta_loop, omega, params, theta_ddot, inner_count)

        def assemble_in_compiled():
            loop_assemble(compiled.assemble_function, compiled.layout, theta_loop, omega, params, inner_count)

        single(), batched(), in_compiled(), assemble_in_compiled()  # compile / load
        single_s, batch_s, inner_s, assemble_s = [], [], [], []
        for _ in range(repeats):
            single_s.append(_time_per_call(single, 20_000))
            batch_s.append(_time_per_call(batched, 20) / batch)
            inner_s.append(_time_once(in_compiled)[0] / inner_count)
            assemble_s.append(_time_once(assemble_in_compiled)[0] / inner_count)
        row = {
            "formulation": formulation,
            "n_unknowns": compiled.n_unknowns,
            "accel_call_us": statistics.median(single_s) * 1e6,
            "accel_in_compiled_loop_us": statistics.median(inner_s) * 1e6,
            "assemble_in_compiled_loop_us": statistics.median(assemble_s) * 1e6,
            "accel_batch_per_state_us": statistics.median(batch_s) * 1e6,
            "batch": batch,
        }
        if formulation in BASELINE_FORMULATIONS:
            rhs = sb.make_rhs(sb.derived(formulation), params[:13])
            z = np.concatenate([theta, omega])
            rhs(0.0, z)
            row["baseline_rhs_us"] = statistics.median(
                _time_per_call(lambda: rhs(0.0, z), 2_000) for _ in range(repeats)
            ) * 1e6
        rows.append(row)
        print(
            f"  {formulation:12s} accel {row['accel_call_us']:7.3f} us (from Python), "
            f"{row['accel_in_compiled_loop_us']:7.3f} us (inside compiled code, of which assemble "
            f"{row['assemble_in_compiled_loop_us']:6.3f}); batch of {batch}: "
            f"{row['accel_batch_per_state_us']:7.3f} us/state"
            + (f"; baseline rhs {row['baseline_rhs_us']:7.1f} us" if "baseline_rhs_us" in row else ""),
            flush=True,
        )
    return rows


# ---------------------------------------------------------------------------------------------------------------
# Section derive: derivation + code generation + numba compile, cold and warm, in subprocesses

_DERIVE_CHILD = r"""
import json, sys, time
start = time.perf_counter()
import numpy as np
from physics.codegen import load_compiled
from physics.codegen.cache import generator_digest
imported = time.perf_counter()
formulation, n = sys.argv[1], int(sys.argv[2])
compiled = load_compiled(formulation, n, False)
loaded = time.perf_counter()
params = np.concatenate([np.ones(n), 0.5 * np.ones(n), np.ones(n), 0.1 * np.ones(n), [1.0, 0.0, 0.0, 0.0]])
compiled.accel(np.linspace(0.1, 0.5, n), np.zeros(n), params)
called = time.perf_counter()
print(json.dumps({
    "import_s": imported - start,
    "load_compiled_s": loaded - imported,
    "accel_first_call_s": called - loaded,
    "total_s": called - imported,
    "from_cache": compiled.from_cache,
    "sympy_imported": "sympy" in sys.modules,
    "generator_digest": generator_digest(),
}))
"""


def _child_env(cache: str) -> dict:
    env = dict(os.environ)
    env["LINKAGE_LAB_CACHE"] = cache
    env["PYTHONPATH"] = str(REPO_ROOT) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    return env


def _children_cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _run_timed(args: list[str], env: dict, timeout: float | None = None):
    """Run ``python *args``; return the finished process, its wall seconds and its CPU seconds (user + sys,
    from the children's resource usage: the figure other jobs on the machine disturb least)."""
    cpu_start = _children_cpu_seconds()
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, *args], env=env, cwd=REPO_ROOT, capture_output=True, text=True, timeout=timeout
    )
    return done, time.perf_counter() - start, _children_cpu_seconds() - cpu_start


def _run_child(args: list[str], env: dict, timeout: float) -> tuple[dict | None, str]:
    """A child that prints one JSON line last: (that JSON plus its wall and CPU seconds, or None; error)."""
    try:
        done, wall, cpu = _run_timed(args, env, timeout)
    except subprocess.TimeoutExpired:
        return None, f"timed out after {timeout:.0f} s"
    if done.returncode != 0:
        return None, (done.stderr.strip().splitlines() or ["exit %d" % done.returncode])[-1]
    result = json.loads(done.stdout.strip().splitlines()[-1])
    result["process_wall_s"] = wall
    result["process_cpu_s"] = cpu
    return result, ""


def bench_derive(max_links: int, timeout: float) -> list[dict]:
    import physics

    rows = []
    for formulation in physics.FORMULATION_NAMES:
        for n in range(1, max_links + 1):
            for attempt in range(2):
                row = _derive_pair(formulation, n, timeout)
                # A warm run that had to derive means the generator's sources changed between the two runs
                # (someone edited physics/ meanwhile): measure the pair again.
                if row.get("warm", {}).get("from_cache", True) or attempt == 1:
                    break
            rows.append(row)
            print(_derive_line(row), flush=True)
    return rows


def _derive_pair(formulation: str, n: int, timeout: float) -> dict:
    """Cold then warm, in one fresh cache folder that is removed afterwards."""
    cache = tempfile.mkdtemp(prefix=f"llc-bench-{formulation}-{n}-")
    try:
        env = _child_env(cache)
        row = {"formulation": formulation, "n": n}
        for label in ("cold", "warm"):
            result, error = _run_child(["-c", _DERIVE_CHILD, formulation, str(n)], env, timeout)
            row[label] = result if result is not None else {"error": error}
            if result is None:
                break
        return row
    finally:
        shutil.rmtree(cache, ignore_errors=True)


def _derive_line(row: dict) -> str:
    parts = [f"  {row['formulation']:12s} n={row['n']:2d}"]
    for label in ("cold", "warm"):
        item = row.get(label)
        if item is None:
            continue
        if "error" in item:
            parts.append(f"{label}: FAILED ({item['error']})")
        else:
            parts.append(
                f"{label}: {item['total_s']:7.2f} s (load {item['load_compiled_s']:6.2f} + accel compile "
                f"{item['accel_first_call_s']:6.2f}; process CPU {item['process_cpu_s']:6.2f}; "
                f"cached={item['from_cache']}, sympy={item['sympy_imported']})"
            )
    return "  ".join(parts)


# ---------------------------------------------------------------------------------------------------------------
# Section process: the whole CLI run with a warm cache

_SYMPY_CHILD = r"""
import contextlib, io, json, sys, time
start = time.perf_counter()
from physics.cli import main
imported = time.perf_counter()
with contextlib.redirect_stdout(io.StringIO()) as out:
    code = main(["simulate", "--preset", "triple-a"])
done = time.perf_counter()
print(json.dumps({
    "exit_code": code,
    "csv_lines": out.getvalue().count("\n"),
    "sympy_imported": sorted(m for m in sys.modules if m == "sympy" or m.startswith("sympy.")),
    "import_physics_cli_s": imported - start,
    "simulate_command_s": done - imported,
}))
"""


def _import_costs(stderr: str) -> dict:
    """Cumulative import time (s) of each top-level package in ``python -X importtime`` output (the 12 largest)."""
    costs = {}
    for line in stderr.splitlines():
        fields = line.removeprefix("import time:").split("|")
        if not line.startswith("import time:") or len(fields) != 3 or not fields[1].strip().isdigit():
            continue
        name = fields[2].strip()
        if "." not in name:
            costs[name] = max(costs.get(name, 0.0), int(fields[1]) / 1e6)
    return dict(sorted(costs.items(), key=lambda item: -item[1])[:12])


def bench_process(runs: int = 5) -> dict:
    from physics.codegen import cache_dir

    env = _child_env(str(cache_dir()))
    command = ["-m", "physics", "simulate", "--preset", "triple-a"]
    for _ in range(2):  # warm: the first run fills the cache if the generator changed, the second loads it
        subprocess.run([sys.executable, *command], env=env, cwd=REPO_ROOT, capture_output=True, check=True)
    walls, cpus = [], []
    for _ in range(runs):
        done, wall, cpu = _run_timed(command, env)
        walls.append(wall)
        cpus.append(cpu)
        if done.returncode != 0:
            raise RuntimeError(f"python -m physics simulate failed: {done.stderr.strip()}")
    importtime = subprocess.run(
        [sys.executable, "-X", "importtime", *command], env=env, cwd=REPO_ROOT, capture_output=True, text=True
    )
    sympy_lines = [line for line in importtime.stderr.splitlines() if "sympy" in line]
    check, error = _run_child(["-c", _SYMPY_CHILD], env, 300)
    startup, startup_cpu = [], []
    for _ in range(runs):
        _, wall, cpu = _run_timed(["-c", "pass"], env)
        startup.append(wall)
        startup_cpu.append(cpu)
    result = {
        "command": "python -m physics simulate --preset triple-a",
        "wall": _summary(walls, cpus),
        "python_startup_wall_s": statistics.median(startup),
        "python_startup_cpu_s": statistics.median(startup_cpu),
        "importtime_sympy_lines": len(sympy_lines),
        "top_level_import_costs_s": _import_costs(importtime.stderr),
        "in_process": check if check is not None else {"error": error},
        "meets_target": statistics.median(walls) < PROCESS_TARGET_S,
    }
    print(
        f"  wall median {result['wall']['median_s']:.3f} s, CPU median {result['wall']['cpu_median_s']:.3f} s over "
        f"{runs} runs (target < {PROCESS_TARGET_S} s); python startup alone {result['python_startup_wall_s']:.3f} s "
        f"wall, {result['python_startup_cpu_s']:.3f} s CPU; sympy lines in -X importtime: "
        f"{len(sympy_lines)}; in-process check: {result['in_process']}",
        flush=True,
    )
    return result


# ---------------------------------------------------------------------------------------------------------------
# Report


def print_tables(results: dict) -> None:
    if "seed" in results:
        print("\nSeed cases, 20 s, RK45 rtol = atol = 1e-6, 200 samples (medians; ratio = baseline / ours)")
        print("| formulation | case | baseline ms | ours ms | ratio | ratio (CPU time) | kernel-only ms | "
              "ours (scipy backend) ms | nfev base/ours/scipy | max abs tip diff | >= 30x |")
        print("|---|---|---|---|---|---|---|---|---|---|---|")
        for row in results["seed"]:
            print(
                f"| {row['formulation']} | {row['case']} | {row['baseline']['median_s'] * 1e3:.2f} | "
                f"{row['ours']['median_s'] * 1e3:.3f} | {row['speedup']:.1f}x | {row['speedup_cpu_time']:.1f}x | "
                f"{row['kernel']['median_s'] * 1e3:.3f} | "
                f"{row['ours_scipy']['median_s'] * 1e3:.2f} | {row['baseline_nfev']}/{row['ours_n_rhs']}/"
                f"{row['ours_scipy_n_rhs']} | {row['tip_max_abs_diff_vs_baseline']:.1e} | "
                f"{'yes' if row['meets_target'] else 'NO'} |"
            )
    if "rhs" in results:
        print("\nOne right-hand side, triple pendulum (medians)")
        print("| formulation | unknowns | accel from Python us | accel inside compiled code us | "
              "of which assemble us | batch of 1000, per state us | baseline rhs us |")
        print("|---|---|---|---|---|---|---|")
        for row in results["rhs"]:
            base = f"{row['baseline_rhs_us']:.1f}" if "baseline_rhs_us" in row else "-"
            print(f"| {row['formulation']} | {row['n_unknowns']} | {row['accel_call_us']:.3f} | "
                  f"{row['accel_in_compiled_loop_us']:.3f} | {row['assemble_in_compiled_loop_us']:.3f} | "
                  f"{row['accel_batch_per_state_us']:.3f} | {base} |")
    if "derive" in results:
        print("\nDerivation + code generation + numba compile of accel (s), subprocess each")
        formulations = list(dict.fromkeys(row["formulation"] for row in results["derive"]))
        print("| n | " + " | ".join(f"{f} cold | {f} warm" for f in formulations) + " |")
        print("|---|" + "---|---|" * len(formulations))
        by_key = {(row["formulation"], row["n"]): row for row in results["derive"]}
        for n in sorted({row["n"] for row in results["derive"]}):
            cells = []
            for f in formulations:
                row = by_key.get((f, n), {})
                for label in ("cold", "warm"):
                    item = row.get(label, {})
                    cells.append(f"{item['total_s']:.2f}" if "total_s" in item else item.get("error", "-"))
            print(f"| {n} | " + " | ".join(cells) + " |")
    if "process" in results:
        p = results["process"]
        print(f"\nWhole process, warm cache: `{p['command']}`: median {p['wall']['median_s']:.3f} s "
              f"(p25 {p['wall']['p25_s']:.3f}, p75 {p['wall']['p75_s']:.3f}), CPU {p['wall']['cpu_median_s']:.3f} s; "
              f"sympy imported: "
              f"{p['in_process'].get('sympy_imported')}; import costs: {p['top_level_import_costs_s']}")


def default_out() -> Path:
    """``speed.json`` in a folder made for this run alone (see the module's docstring)."""
    return Path(tempfile.mkdtemp(prefix="linkage-lab-speed-")) / "speed.json"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.speed", description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats; derivation for n = 1..4 only")
    parser.add_argument("--out", default=None,
                        help="where to write the JSON results (default: speed.json in a new private temporary folder)")
    parser.add_argument("--sections", default=",".join(SECTIONS), help=f"comma-separated subset of {SECTIONS}")
    parser.add_argument("--max-links", type=int, default=None, help="largest n for the derive section")
    parser.add_argument("--timeout", type=float, default=CHILD_TIMEOUT_S, help="per-subprocess limit (s)")
    args = parser.parse_args(argv)
    sections = [s.strip() for s in args.sections.split(",") if s.strip()]
    unknown = sorted(set(sections) - set(SECTIONS))
    if unknown:
        parser.error(f"--sections: unknown {unknown}; allowed {', '.join(SECTIONS)}")
    repeats = 7 if args.quick else 31
    max_links = args.max_links or (4 if args.quick else 12)

    from physics.codegen import cache_dir

    results = {
        "command": "python -m benchmarks.speed " + " ".join(argv if argv is not None else sys.argv[1:]),
        "machine": machine_info(),
        "cache": str(cache_dir()),
        "repeats": repeats,
    }
    started = time.perf_counter()
    if "seed" in sections:
        print("seed cases:", flush=True)
        results["seed"] = bench_seed(repeats, fast_calls=5)
    if "rhs" in sections:
        print("right-hand side:", flush=True)
        results["rhs"] = bench_rhs(repeats)
    if "derive" in sections:
        print(f"derivation, n = 1..{max_links}:", flush=True)
        results["derive"] = bench_derive(max_links, args.timeout)
    if "process" in sections:
        print("whole process:", flush=True)
        results["process"] = bench_process()
    results["machine"]["load_average_at_end"] = os.getloadavg()
    results["wall_s"] = time.perf_counter() - started
    print_tables(results)
    out = Path(args.out) if args.out else default_out()
    out.write_text(json.dumps(results, indent=2) + "\n")
    print(f"\nwrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
