"""The RK45 and DOP853 drivers generated as LLVM IR against the numba kernel ("Integrators as generated IR" in
BENCHMARKS.md).

    python -m benchmarks.integrator_ir [--repeats 21] [--compiles 5]

* ``compile``: seconds to build the drivers' IR and compile it with llvmlite, each in a fresh process (the
  drivers are compiled once per process; numba's compilation of the kernel they stand in for is about 20 s);
* ``case_c``: seed case C (triple-c, RK45, rtol = atol = 1e-6, 20 s, 200 samples), DAE formulation (the IR
  drivers answer a system with a generated fused ``rhs``: the DAE's);
* ``triple_a_dop853``: triple-a, DOP853, rtol 1e-10, atol 1e-12, 10 s, 200 samples, DAE.

Each run is timed warm (machine code loaded, one call before), the IR driver and the kernel alternating call by
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


def _case(preset: str, integrator: str, rtol: float, atol: float, t_end: float, repeats: int) -> dict:
    import physics  # noqa: PLC0415
    from physics.codegen import load_compiled, native_integrators  # noqa: PLC0415
    from physics.kernels import explicit_rk  # noqa: PLC0415

    chosen = physics.get_preset(preset)
    compiled = load_compiled("dae", chosen.chain.n, chosen.chain.pinned)
    layout = compiled.integration_layout
    y0 = np.concatenate([chosen.theta0, chosen.omega0]).astype(float)
    t_eval = np.linspace(0.0, t_end, 200)
    params = chosen.chain.params()
    kernel = explicit_rk.integrate_rk45 if integrator == "RK45" else explicit_rk.integrate_dop853
    max_steps = physics.Settings().max_steps
    outputs = {"ir": np.empty((200, y0.size)), "numba": np.empty((200, y0.size))}

    def run(which: str):
        arguments = (layout, y0, 0.0, t_end, t_eval, params, rtol, atol, 0.0, 0.0, False, max_steps, outputs[which],
                     np.empty(0))
        if which == "ir":
            return native_integrators.integrate(integrator, compiled.assemble_function, *arguments)
        return kernel(compiled.assemble_function, *arguments)

    results = {which: run(which) for which in outputs}  # warm-up: machine code compiled or loaded
    seconds: dict = {which: [] for which in outputs}
    for repeat in range(repeats):
        for which in (("ir", "numba") if repeat % 2 == 0 else ("numba", "ir")):
            start = time.perf_counter()
            run(which)
            seconds[which].append(time.perf_counter() - start)
    identical = (results["ir"] is not None and tuple(results["ir"]) == tuple(results["numba"])
                 and np.array_equal(outputs["ir"], outputs["numba"]))
    return {"ir_median_ms": 1e3 * statistics.median(seconds["ir"]),
            "numba_median_ms": 1e3 * statistics.median(seconds["numba"]),
            "steps": int(results["numba"][1]), "identical": bool(identical)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=21)
    parser.add_argument("--compiles", type=int, default=5)
    arguments = parser.parse_args()
    compiles = _compile_seconds(arguments.compiles)
    report = {
        "compile": {"median_s": statistics.median(compiles), "samples_s": compiles},
        "case_c": _case("triple-c", "RK45", 1e-6, 1e-6, 20.0, arguments.repeats),
        "triple_a_dop853": _case("triple-a", "DOP853", 1e-10, 1e-12, 10.0, arguments.repeats),
    }
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
