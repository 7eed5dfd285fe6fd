"""Seed case C's ``physics.simulate`` with the observables' function specialised for the plan's structure
(:func:`physics.codegen.mechanism_observables.specialised_observables`) against the same process's generic one,
alternated call by call (issue 25): the difference of two whole calls in one process, where two processes'
figures differ by more than it on a shared machine.

    python -m benchmarks.specialised_observables [--calls N]

Thread CPU time per call, medians, for each derived method; the same bits both ways
(``tests/physics/test_specialised_observables.py``).
"""

from __future__ import annotations

import argparse
import statistics
import threading
import time

import numpy as np


def compare(method: str, calls: int) -> tuple[float, float]:
    """``(generic, specialised)``: median thread CPU microseconds of a call of seed case C with each."""
    import physics  # noqa: PLC0415
    from physics.simulate import mechanism_route  # noqa: PLC0415

    from .closed_form import CASE_C_ATOL, CASE_C_PRESET, CASE_C_RTOL, CASE_C_SAMPLES, CASE_C_T_END  # noqa: PLC0415

    preset = physics.get_preset(CASE_C_PRESET)
    chain = preset.chain
    theta0, omega0 = np.array(preset.theta0, dtype=float), np.array(preset.omega0, dtype=float)
    settings = physics.Settings(method=method, integrator="RK45", rtol=CASE_C_RTOL, atol=CASE_C_ATOL,
                                t_end=CASE_C_T_END, samples=CASE_C_SAMPLES)
    for _ in range(3):  # the specialised driver, solve and observables asked for twice: built
        physics.simulate(chain, theta0, omega0, settings)
    for thread in threading.enumerate():
        if thread.name.startswith("specialise"):
            thread.join()
    for _ in range(3):
        physics.simulate(chain, theta0, omega0, settings)
    run = [call for call in mechanism_route._calls.values() if call.route.chain is chain][-1].shape
    specialised = run.observables_specialised
    if specialised is None:
        raise RuntimeError("the specialised observables are not in place")
    generic = (run.observables_call, None)
    times: dict[bool, list[int]] = {False: [], True: []}
    for index in range(2 * calls):
        use = bool(index % 2)
        run.observables_specialised = specialised if use else generic
        start = time.thread_time_ns()
        physics.simulate(chain, theta0, omega0, settings)
        times[use].append(time.thread_time_ns() - start)
    run.observables_specialised = specialised
    return statistics.median(times[False]) / 1e3, statistics.median(times[True]) / 1e3


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--calls", type=int, default=2000)
    options = parser.parse_args(argv)
    print("| method | generic observables, us | specialised, us | saved |")
    print("|---|---|---|---|")
    for method in ("lagrange", "newton_euler", "dae"):
        generic, specialised = compare(method, options.calls)
        print(f"| {method} | {generic:.0f} | {specialised:.0f} | {generic - specialised:.0f} us "
              f"({100 * (1 - specialised / generic):.1f} %) |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
