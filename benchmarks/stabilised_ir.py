"""Stabilised runs on the drivers generated as LLVM IR ("Stabilised runs without numba" in BENCHMARKS.md): whole
processes on an empty cache, this tree against an older one side by side, and the projecting run's per-call
speed, IR against the numba kernel.

    python -m benchmarks.stabilised_ir --before ../before [--rounds 3] [--repeats 21]
    python -m benchmarks.stabilised_ir --per-call-only [--repeats 21]

* ``four_bar``: ``python -m physics simulate --preset four-bar`` (its default: DAE, DOP853, held by projection
  onto the pin), with a fresh empty ``LINKAGE_LAB_CACHE``; wall seconds (interpreter start included) and the
  child's CPU seconds, as the machine is shared;
* ``jansen``: ``python -m physics mechanism --preset jansen-leg --t-end 10`` (driven by its crank motor:
  position analysis by the projection, then the samples), each in its own empty cache;
* per call (this tree only, machine code loaded, one call before; the IR and the kernel alternating call by call):
  ``four_bar_projection_<method>``: the four-bar, 10 s, 301 samples, rtol 1e-10, atol 1e-10, projection, by
  ``native_integrators.integrate`` and by ``explicit_rk``'s kernel; ``four_bar_baumgarte_DOP853``: the same
  with alpha = beta = 5; ``slider_crank_projection_DOP853``: the slider-crank's DAE in maximal coordinates with
  its projection weights, 2 s, 41 samples, and ``slider_crank_none_DOP853`` the same unstabilised (the IR
  drivers answered it before). Medians in milliseconds, with whether both gave the same bits.

Rounds alternate the order of the two trees. Each row is printed on stderr as it is measured, then one JSON
object with every row and the medians per tree.
"""

from __future__ import annotations

import argparse
import json
import os
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
TIMEOUT_S = 900.0
COMMANDS = {
    "four_bar": ["simulate", "--preset", "four-bar", "--out", os.devnull],
    "jansen": ["mechanism", "--preset", "jansen-leg", "--t-end", "10"],
}


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _timed(arguments: list[str], cache: Path, tree: Path) -> tuple[float, float]:
    """Wall and CPU seconds of ``python -m physics <arguments>`` in ``tree`` with ``cache`` as the cache folder."""
    env = dict(os.environ, LINKAGE_LAB_CACHE=str(cache), PYTHONPATH=str(tree))
    env.pop("NUMBA_CACHE_DIR", None)
    cpu = _children_cpu()
    start = time.perf_counter()
    result = subprocess.run([sys.executable, "-m", "physics", *arguments], cwd=tree, env=env, capture_output=True,
                            text=True, timeout=TIMEOUT_S)
    elapsed = time.perf_counter() - start
    if result.returncode != 0:
        raise RuntimeError(f"{' '.join(arguments)} failed in {tree}: {result.stderr.strip()[-500:]}")
    return elapsed, _children_cpu() - cpu


def _alternating(run_ir, run_kernel, repeats: int) -> dict:
    """Medians of ``repeats`` calls of each (one warm-up call first), alternating which goes first."""
    results = {"ir": run_ir(), "numba": run_kernel()}
    seconds: dict = {"ir": [], "numba": []}
    for repeat in range(repeats):
        for which in (("ir", "numba") if repeat % 2 == 0 else ("numba", "ir")):
            start = time.perf_counter()
            (run_ir if which == "ir" else run_kernel)()
            seconds[which].append(time.perf_counter() - start)
    return {"ir_median_ms": 1e3 * statistics.median(seconds["ir"]),
            "numba_median_ms": 1e3 * statistics.median(seconds["numba"]), "results": results}


def _integrations(compiled, layout, integrator: str, y0, t_end: float, samples: int, params, rtol: float,
                  atol: float, alpha: float, beta: float, project: bool, repeats: int) -> dict:
    from physics.codegen import native_integrators  # noqa: PLC0415
    from physics.kernels import explicit_rk  # noqa: PLC0415

    kernel = explicit_rk.integrate_rk45 if integrator == "RK45" else explicit_rk.integrate_dop853
    t_eval = np.linspace(0.0, t_end, samples)
    outputs = {"ir": np.empty((samples, y0.size)), "numba": np.empty((samples, y0.size))}

    def arguments(which: str) -> tuple:
        return (layout, y0, 0.0, t_end, t_eval, params, rtol, atol, alpha, beta, project, 10**7, outputs[which],
                np.empty(0))

    timing = _alternating(
        lambda: native_integrators.integrate(integrator, compiled.assemble_function, *arguments("ir")),
        lambda: tuple(kernel(compiled.assemble_function, *arguments("numba"))), repeats)
    results = timing.pop("results")
    identical = (results["ir"] is not None and tuple(results["ir"]) == tuple(results["numba"])
                 and np.array_equal(outputs["ir"], outputs["numba"]))
    return {**timing, "steps": int(results["numba"][1]), "identical": bool(identical)}


def per_call(repeats: int) -> dict:
    import physics  # noqa: PLC0415
    from physics.codegen import load_compiled  # noqa: PLC0415
    from physics.mechanism import engine  # noqa: PLC0415
    from physics.mechanism.prepared import prepared  # noqa: PLC0415
    from physics.mechanism.presets import MECHANISM_PRESETS  # noqa: PLC0415
    from physics.mechanism.simulate import simulate_mechanism  # noqa: PLC0415

    chosen = physics.get_preset("four-bar")
    compiled = load_compiled("dae", chosen.chain.n, chosen.chain.pinned)
    y0 = np.concatenate([chosen.theta0, chosen.omega0]).astype(float)
    params = chosen.chain.params()
    rows = {}
    for integrator in ("RK45", "DOP853"):
        rows[f"four_bar_projection_{integrator}"] = _integrations(
            compiled, compiled.integration_layout, integrator, y0, 10.0, 301, params, 1e-10, 1e-10, 0.0, 0.0, True,
            repeats)
    rows["four_bar_baumgarte_DOP853"] = _integrations(compiled, compiled.integration_layout, "DOP853", y0, 10.0,
                                                      301, params, 1e-10, 1e-10, 5.0, 5.0, False, repeats)
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    start = simulate_mechanism(mechanism, 0.01, 2)
    mechanism_compiled = engine.compiled_system(mechanism, "dae")
    weights = prepared(mechanism).projection_weights  # the run's own: positions by size, velocities by mass
    mechanism_params, layout = engine.run_parameters(mechanism, mechanism_compiled, 0.0, weights)
    state = np.ascontiguousarray(np.concatenate([start.q[0], start.qdot[0]]), dtype=float)
    rows["slider_crank_projection_DOP853"] = _integrations(mechanism_compiled, layout, "DOP853", state, 2.0, 41,
                                                           mechanism_params, 1e-10, 1e-10, 0.0, 0.0, True, repeats)
    rows["slider_crank_none_DOP853"] = _integrations(mechanism_compiled, layout, "DOP853", state, 2.0, 41,
                                                     mechanism_params, 1e-10, 1e-10, 0.0, 0.0, False, repeats)
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.stabilised_ir", description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", type=Path, help="an older checkout to time the same way (whole processes)")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--repeats", type=int, default=21)
    parser.add_argument("--per-call-only", action="store_true")
    args = parser.parse_args(argv)
    report: dict = {"command": "python -m benchmarks.stabilised_ir " + " ".join(sys.argv[1:]),
                    "cpus": os.cpu_count(), "load_average_start": os.getloadavg()[0]}
    if not args.per_call_only:
        if args.before is None:
            parser.error("--before is needed for the whole-process figures (or pass --per-call-only)")
        trees = {"after": REPO_ROOT, "before": args.before.resolve()}
        rows: list[dict] = []
        for round_index in range(args.rounds):
            for name in (["after", "before"] if round_index % 2 == 0 else ["before", "after"]):
                row: dict = {"tree": name, "round": round_index, "load_average": os.getloadavg()[0]}
                for what, arguments in COMMANDS.items():
                    scratch = Path(tempfile.mkdtemp(prefix="linkage-lab-stabilised-"))
                    try:
                        wall, cpu = _timed(arguments, scratch, trees[name])
                        row.update({f"{what}_s": wall, f"{what}_cpu_s": cpu})
                    finally:
                        shutil.rmtree(scratch, ignore_errors=True)
                rows.append(row)
                print(json.dumps(row), file=sys.stderr, flush=True)
        report["rows"] = rows
        report["medians"] = {name: {key: statistics.median(row[key] for row in rows if row["tree"] == name)
                                    for key in rows[0] if key.endswith("_s")} for name in trees}
    report["per_call"] = per_call(args.repeats)
    report["load_average_end"] = os.getloadavg()[0]
    print(json.dumps(report, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
