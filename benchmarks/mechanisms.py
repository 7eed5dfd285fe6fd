"""Figures for BENCHMARKS.md, issue "Any planar linkage": each mechanism preset run for 60 s by each chosen
formulation (projection, physics/mechanism/simulate.py), its mobility, wall time, largest constraint residual
and, undriven, its largest energy drift relative to its energy scale.

    python -m benchmarks.mechanisms [--t-end 60] [--samples 601] [--presets slider-crank,jansen-leg]
                                    [--method dae,lagrange,newton_euler] [--repeat 1] [--cpu]

The time (three decimals) is of the run alone: each formulation is derived and compiled by a short run first (the cold
cost of a whole process is measured separately, with an empty cache folder); with ``--repeat N`` the fastest of
N runs, for a machine shared with other work.

Driven mechanisms gain and lose the motor's work, so no energy drift is quoted for them; the motor's torque is
checked against the power balance in tests/physics/test_mechanism_dynamics.py instead.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from physics.mechanism import MECHANISM_PRESETS, assemble
from physics.mechanism.simulate import simulate_mechanism


def energy_scale(run) -> float:
    """The swing of the energies over the run (kinetic and potential), the scale a drift is measured against."""
    return float(max(np.ptp(run.kinetic), np.ptp(run.potential), np.max(np.abs(run.energy)), 1e-12))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.mechanisms")
    parser.add_argument("--t-end", type=float, default=60.0)
    parser.add_argument("--samples", type=int, default=601)
    parser.add_argument("--presets", default=",".join(sorted(MECHANISM_PRESETS)))
    parser.add_argument("--method", default="dae", help="comma-separated: dae, lagrange, newton_euler")
    parser.add_argument("--repeat", type=int, default=1, help="report the fastest of this many runs")
    parser.add_argument("--cpu", action="store_true", help="CPU seconds of the process instead of wall seconds "
                        "(a shared, loaded machine)")
    args = parser.parse_args(argv)
    print(f"load average at start: {os.getloadavg()[0]:.1f}")
    clock = "CPU (s)" if args.cpu else "wall (s)"
    print(f"| preset | method | mobility | motors | simulated (s) | {clock} | real-time factor "
          "| max constraint residual | max relative energy drift |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name in args.presets.split(","):
        mechanism = MECHANISM_PRESETS[name]()
        assembled = assemble(mechanism)
        for method in args.method.split(","):
            simulate_mechanism(mechanism, t_end=0.05, samples=2, method=method)  # derive and compile first
            walls = []
            for _ in range(max(args.repeat, 1)):
                started = time.process_time() if args.cpu else time.perf_counter()
                run = simulate_mechanism(mechanism, t_end=args.t_end, samples=args.samples, method=method)
                walls.append((time.process_time() if args.cpu else time.perf_counter()) - started)
            wall = min(walls)
            driven = bool(mechanism.drivers)
            drift = "(driven)" if driven else f"{np.max(np.abs(run.energy - run.energy[0])) / energy_scale(run):.1e}"
            print(f"| `{name}` | {method} | {assembled.mobility} | {len(mechanism.drivers)} | {run.t[-1]:g} "
                  f"| {wall:.3f} | {run.t[-1] / wall:.1f} | {np.max(run.residual):.1e} | {drift} |", flush=True)
    print(f"load average at end: {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
