"""The RK45 and DOP853 drivers generated as LLVM IR against the numba kernel ("Integrators as generated IR" in
BENCHMARKS.md).

    python -m benchmarks.integrator_ir [--repeats 21] [--compiles 5]

* ``compile``: seconds to build the drivers' IR and compile it with llvmlite, each in a fresh process (the
  drivers are compiled once per process; numba's compilation of the kernel they stand in for is about 20 s);
* ``specialised_median_ms``: the same driver specialised for the system (:mod:`physics.codegen.specialised_ir`);
* ``case_c``: seed case C (triple-c, RK45, rtol = atol = 1e-6, 20 s, 200 samples), DAE formulation (the IR
  drivers answer a system with a generated fused ``rhs``: the DAE's);
* ``triple_a_dop853``: triple-a, DOP853, rtol 1e-10, atol 1e-12, 10 s, 200 samples, DAE;
* ``case_c_lagrange``, ``case_c_newton_euler``, ``triple_a_dop853_lagrange``: the same runs for the formulations
  without a fused ``rhs``, whose every evaluation takes the general solve (``physics/codegen/linear_ir.py``);
* ``samples_*``: the per-sample solve of seed case C's 200 samples, the IR function
  (``physics/codegen/native_samples.py``) against the numba kernel (the positions, energies and joint reactions
  these rows also timed went with the chain's own run route);
* ``simulate_case_c``: ``physics.simulate`` of seed case C end to end (default method, Lagrange), the whole
  per-call figure (this tree only: run the same ``--simulate-only`` in another tree to compare).

Each run is timed warm (machine code loaded, one call before), the IR and the numba kernel alternating call by
call; medians in milliseconds, with whether both gave the same bits. One JSON object on stdout.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time

import numpy as np

_COMPILE_SNIPPET = (  # the one driver a run compiles (each method is a module of its own)
    "from physics.codegen import native_integrators as n; n._driver('DOP853'); print(n.compile_seconds())"
)


def _compile_seconds(count: int) -> list[float]:
    return [float(subprocess.run([sys.executable, "-c", _COMPILE_SNIPPET], check=True, capture_output=True,
                                 text=True).stdout.strip()) for _ in range(count)]


def _case(preset: str, integrator: str, rtol: float, atol: float, t_end: float, repeats: int,
          method: str = "dae") -> dict:
    import physics  # noqa: PLC0415
    from physics.codegen import load_compiled, native_integrators  # noqa: PLC0415
    from physics.kernels import explicit_rk  # noqa: PLC0415

    chosen = physics.get_preset(preset)
    compiled = load_compiled(method, chosen.chain.n, chosen.chain.pinned)
    layout = compiled.integration_layout
    y0 = np.concatenate([chosen.theta0, chosen.omega0]).astype(float)
    t_eval = np.linspace(0.0, t_end, 200)
    params = chosen.chain.params()
    kernel = explicit_rk.integrate_rk45 if integrator == "RK45" else explicit_rk.integrate_dop853
    max_steps = physics.Settings().max_steps
    outputs = {"ir": np.empty((200, y0.size)), "specialised": np.empty((200, y0.size)),
               "numba": np.empty((200, y0.size))}
    from physics.codegen import cache  # noqa: PLC0415

    cache.SPECIALISE_IN_BACKGROUND = False  # made in the call that asks: its 2nd
    specialised = compiled.specialised_driver(integrator) or compiled.specialised_driver(integrator)

    def run(which: str):
        arguments = (layout, y0, 0.0, t_end, t_eval, params, rtol, atol, 0.0, 0.0, False, max_steps, outputs[which],
                     np.empty(0))
        if which != "numba":
            return native_integrators.integrate(integrator, compiled.assemble_function, *arguments,
                                                driver=specialised if which == "specialised" else None)
        return kernel(compiled.assemble_function, *arguments)

    results = {which: run(which) for which in outputs}  # warm-up: machine code compiled or loaded
    seconds: dict = {which: [] for which in outputs}
    names = list(outputs)
    for repeat in range(repeats):
        shift = repeat % len(names)
        for which in names[shift:] + names[:shift]:
            start = time.perf_counter()
            run(which)
            seconds[which].append(time.perf_counter() - start)
    identical = all(results[which] is not None and tuple(results[which]) == tuple(results["numba"])
                    and np.array_equal(outputs[which], outputs["numba"]) for which in ("ir", "specialised"))
    return {"ir_median_ms": 1e3 * statistics.median(seconds["ir"]),
            "specialised_median_ms": 1e3 * statistics.median(seconds["specialised"]),
            "numba_median_ms": 1e3 * statistics.median(seconds["numba"]),
            "steps": int(results["numba"][1]), "identical": bool(identical)}


def _samples(method: str, repeats: int) -> dict:
    """Seed case C's per-sample solve, IR against numba."""
    import physics  # noqa: PLC0415
    from physics.codegen import load_compiled, native_samples  # noqa: PLC0415
    from physics.kernels import system  # noqa: PLC0415

    chosen = physics.get_preset("triple-c")
    settings = physics.Settings(method=method, integrator="RK45", rtol=1e-6, atol=1e-6, t_end=20.0, samples=200)
    run = physics.simulate(chosen.chain, chosen.theta0, chosen.omega0, settings)
    compiled = load_compiled(method, chosen.chain.n, chosen.chain.pinned)
    theta, omega = np.ascontiguousarray(run.theta), np.ascontiguousarray(run.omega)
    params, rows = chosen.chain.params(), theta.shape[0]
    kernels = {"ir": native_samples.solve_states, "numba": system.solve_states}
    outputs: dict = {}

    def run_pass(which: str):
        x, cond = np.empty((rows, compiled.n_unknowns)), np.empty(rows)
        kernels[which](compiled.assemble_function, compiled.layout, theta, omega, params, 0.0, 0.0, x, cond)
        outputs[which] = (x, cond)

    for which in kernels:
        run_pass(which)
    seconds: dict = {which: [] for which in kernels}
    for repeat in range(repeats):
        for which in (("ir", "numba") if repeat % 2 == 0 else ("numba", "ir")):
            start = time.perf_counter()
            run_pass(which)
            seconds[which].append(time.perf_counter() - start)
    identical = all(np.array_equal(a, b) for a, b in zip(outputs["ir"], outputs["numba"], strict=True))
    return {"ir_median_ms": 1e3 * statistics.median(seconds["ir"]),
            "numba_median_ms": 1e3 * statistics.median(seconds["numba"]), "identical": bool(identical)}


def simulate_case_c(repeats: int) -> dict:
    """``physics.simulate`` of seed case C (RK45, rtol = atol = 1e-6, 20 s, 200 samples), warm, per call."""
    import physics  # noqa: PLC0415

    chosen = physics.get_preset("triple-c")
    settings = physics.Settings(integrator="RK45", rtol=1e-6, atol=1e-6, t_end=20.0, samples=200)
    physics.simulate(chosen.chain, chosen.theta0, chosen.omega0, settings)
    seconds = []
    for _ in range(repeats):
        start = time.perf_counter()
        physics.simulate(chosen.chain, chosen.theta0, chosen.omega0, settings)
        seconds.append(time.perf_counter() - start)
    return {"method": settings.method, "median_ms": 1e3 * statistics.median(seconds)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=21)
    parser.add_argument("--compiles", type=int, default=5)
    parser.add_argument("--simulate-only", action="store_true",
                        help="only simulate_case_c (what another tree can run too, by the same snippet)")
    arguments = parser.parse_args()
    if arguments.simulate_only:
        print(json.dumps({"simulate_case_c": simulate_case_c(arguments.repeats)}, indent=2))
        return
    compiles = _compile_seconds(arguments.compiles)
    repeats = arguments.repeats
    report = {
        "compile": {"median_s": statistics.median(compiles), "samples_s": compiles},
        "case_c": _case("triple-c", "RK45", 1e-6, 1e-6, 20.0, repeats),
        "triple_a_dop853": _case("triple-a", "DOP853", 1e-10, 1e-12, 10.0, repeats),
        "case_c_lagrange": _case("triple-c", "RK45", 1e-6, 1e-6, 20.0, repeats, "lagrange"),
        "case_c_newton_euler": _case("triple-c", "RK45", 1e-6, 1e-6, 20.0, repeats, "newton_euler"),
        "triple_a_dop853_lagrange": _case("triple-a", "DOP853", 1e-10, 1e-12, 10.0, repeats, "lagrange"),
        "samples_lagrange": _samples("lagrange", repeats),
        "samples_dae": _samples("dae", repeats),
        "simulate_case_c": simulate_case_c(repeats),
    }
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
