"""Figures for BENCHMARKS.md, issue 24, "an edit ... to the first new frame <= 50 ms server side": the server's
work for one chunk of a general mechanism's run in the app, in this tree and in another (``--before``, a
``git worktree`` of the commit before the work), rounds alternated in one run.

    git worktree add ../before f92973a
    python -m benchmarks.app_mechanism_chunk --before ../before [--rounds 5] [--calls 15]

A chunk's work is what the player does with it before a frame can show it: ``MechanismSpec.simulate`` (the
run, in this interpreter as with ``LINKAGE_LAB_MECHANISM_WORKERS=0``; a worker process does the same work and
pickles the run), ``MechanismSpec.chunk`` (the samples the ring stores) and ``TrajectoryRing.append``, then the
status line's read of the condition at the chunk's last sample (``MechanismSpec.condition_at`` where the tree
has it, else the stored figure). Cases: every mechanism preset with the DAE (the app's default) and, for two of
them, a tree formulation (Lagrange), each for a chunk of 0.25 s (16 samples, the player's first chunks) and of
2 s (121 samples, its longest), from the assembled start at rest.

Each round starts one process per tree (``python -c ...`` in the tree's folder, so it imports that tree's
code; which tree goes first alternates), which runs every case twice to warm up (compiled code, caches) and then
``--calls`` times; a figure is the median over a round's calls of the calling thread's CPU time
(``time.thread_time``) and of the wall time, and the table gives the median over the rounds, with the load
average at the start and end.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
from pathlib import Path

from .workers import run_once

ROOT = Path(__file__).resolve().parent.parent
CASES = [(preset, "dae") for preset in ("slider-crank", "crank-rocker", "chebyshev-lambda", "watt-six-bar",
                                        "stephenson-six-bar", "jansen-leg", "geared-five-bar")]
CASES += [("crank-rocker", "lagrange"), ("watt-six-bar", "lagrange")]
SECONDS = (0.25, 2.0)

WORKER = r"""
import json, sys, time
import numpy as np
from physics.mechanism import MECHANISM_PRESETS
from app.mechanism_runs import MechanismSettings, MechanismSpec, start_state
from app.player import SAMPLE_DT

cases, seconds, calls = json.loads(sys.argv[1]), json.loads(sys.argv[2]), int(sys.argv[3])
out = {}
for preset, method in cases:
    mechanism = MECHANISM_PRESETS[preset]()
    q0, qdot0, _ = start_state(mechanism)
    for span in seconds:
        samples = int(round(span / SAMPLE_DT)) + 1
        settings = MechanismSettings(method=method, t_end=span, samples=samples)
        spec = MechanismSpec("main", mechanism, settings)
        ring = spec.new_ring(4 * samples, SAMPLE_DT)

        def one():
            chunk = spec.simulate(mechanism, q0, qdot0, settings)
            ring.clear()
            ring.append(spec.chunk(chunk))
            last = len(ring) - 1
            shown = spec.condition_at(ring, last) if hasattr(spec, "condition_at") else float(
                ring.get("condition", last))
            return shown

        for _ in range(2):
            one()
        cpu, wall = [], []
        for _ in range(calls):
            started, started_wall = time.thread_time(), time.perf_counter()
            one()
            cpu.append(time.thread_time() - started)
            wall.append(time.perf_counter() - started_wall)
        out[f"{preset}, {method}, {span:g} s"] = [sorted(cpu)[calls // 2], sorted(wall)[calls // 2]]
print(json.dumps(out))
"""


def _round(tree: Path, calls: int) -> dict[str, list[float]]:
    return run_once(tree, WORKER, [json.dumps(CASES), json.dumps(SECONDS), str(calls)],
                    LINKAGE_LAB_MECHANISM_WORKERS="0")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.app_mechanism_chunk")
    parser.add_argument("--before", type=Path, required=True, help="a worktree of the commit before the work")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--calls", type=int, default=15)
    args = parser.parse_args(argv)
    trees = {"before": args.before.resolve(), "after": ROOT}
    print(f"load average at start: {' '.join(f'{v:.1f}' for v in os.getloadavg())}", flush=True)
    figures: dict[str, dict[str, list[list[float]]]] = {label: {} for label in trees}
    for number in range(args.rounds):
        order = list(trees) if number % 2 == 0 else list(reversed(trees))
        for label in order:
            for case, values in _round(trees[label], args.calls).items():
                figures[label].setdefault(case, []).append(values)
    print("| chunk (ms per chunk, median of rounds) | before: CPU | after: CPU | before / after (CPU) "
          "| before: wall | after: wall |")
    print("|---|---|---|---|---|---|")
    for case in figures["before"]:
        cpu = {label: 1000 * statistics.median(v[0] for v in figures[label][case]) for label in trees}
        wall = {label: 1000 * statistics.median(v[1] for v in figures[label][case]) for label in trees}
        print(f"| {case} | {cpu['before']:.2f} | {cpu['after']:.2f} | {cpu['before'] / cpu['after']:.2f}x "
              f"| {wall['before']:.2f} | {wall['after']:.2f} |")
    print(f"load average at end: {' '.join(f'{v:.1f}' for v in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
