"""Figures for BENCHMARKS.md, "A chain's run on the mechanism engine, per call": one warm ``physics.simulate`` call
of a chain on its own kernels against the same call with ``physics.simulate.on_mechanism.ENABLED`` (the chain
written as a mechanism, run by the general engine and returned as the chain's Trajectory), alternated in one
process.

    python -m benchmarks.chain_route [--rounds 15] [--calls 5]

The cases: the ``triple-a`` and ``four-bar`` presets, Lagrange and the DAE, a 20 s run of 201 samples and a
0.1 s chunk of 11 (the app's size), DOP853 at 1e-10, projection. Each case is called a few times on both routes
to warm up (compiled code, the routes' caches); then ``--rounds`` times both routes are timed one after the other
(which goes first alternates), ``--calls`` calls each, and a figure is the median over the rounds of the
per-call CPU time (``time.thread_time``: on a shared machine the wall time is partly waiting for a core).
Prints a Markdown table and the load average at the start and end.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

from physics import Settings, get_preset, simulate
from physics.simulate import on_mechanism

CASES = [(preset, method, t_end, samples) for preset in ("triple-a", "four-bar") for method in ("lagrange", "dae")
         for t_end, samples in ((20.0, 201), (0.1, 11))]
WARM_UP = 3


def per_call(chain, theta0, omega0, settings: Settings, enabled: bool, calls: int) -> float:
    """CPU seconds per call of ``simulate`` on the route ``enabled`` chooses."""
    on_mechanism.ENABLED = enabled
    try:
        start = time.thread_time()
        for _ in range(calls):
            simulate(chain, theta0, omega0, settings)
        return (time.thread_time() - start) / calls
    finally:
        on_mechanism.ENABLED = False


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=15)
    parser.add_argument("--calls", type=int, default=5)
    options = parser.parse_args(argv)
    print(f"load at start: {os.getloadavg()[0]:.2f}")
    print("| case | chain kernels, ms | on the mechanism engine, ms | ratio |")
    print("|---|---|---|---|")
    for preset, method, t_end, samples in CASES:
        chosen = get_preset(preset)
        settings = Settings(method=method, t_end=t_end, samples=samples)
        arguments = (chosen.chain, chosen.theta0, chosen.omega0, settings)
        for enabled in (False, True):
            per_call(*arguments, enabled, WARM_UP)
        figures: dict[bool, list[float]] = {False: [], True: []}
        for round_ in range(options.rounds):
            for enabled in ((False, True) if round_ % 2 == 0 else (True, False)):
                figures[enabled].append(per_call(*arguments, enabled, options.calls))
        chain_ms, route_ms = (1e3 * statistics.median(figures[enabled]) for enabled in (False, True))
        print(f"| {preset} {method}, {t_end:g} s, {samples} samples | {chain_ms:.2f} | {route_ms:.2f} | "
              f"{route_ms / chain_ms:.1f}x |")
    print(f"load at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
