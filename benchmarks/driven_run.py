"""Figures for BENCHMARKS.md, issue 24: a fully driven mechanism's run (the motors fix every body, so every
sample is position analysis) per call, in this tree and in another (``--before``, a ``git worktree`` of the
commit before the work), rounds alternated in one run.

    git worktree add ../before <commit>
    python -m benchmarks.driven_run --before ../before [--rounds 5] [--calls 20] [--presets jansen-leg ...]

A call is ``simulate_mechanism(preset, t_end, samples)`` (DAE, the default) from the assembled start at rest,
for a 2 s chunk (121 samples, the app's longest chunk) and a 10 s run (601 samples); beside the whole call, the
part of it spent in ``physics.mechanism.engine._position_analysis`` (timed by wrapping it), which the one-call
sequence (:func:`physics.codegen.native_states.driven_sequence`) replaced.

Each round starts one process per tree (``python -c ...`` in the tree's folder, so it imports that tree's code;
which tree goes first alternates), which runs every case twice to warm up (compiled code, caches) and then
``--calls`` times; a figure is the median over a round's calls of the wall time (the calling thread's CPU time
beside it for the whole call), and the table gives the median over the rounds, with the load average at the
start and end.
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
SPANS = ((2.0, 121), (10.0, 601))

WORKER = r"""
import json, sys, time
from physics.mechanism import MECHANISM_PRESETS, engine
from physics.mechanism.simulate import simulate_mechanism

presets, spans, calls = json.loads(sys.argv[1]), json.loads(sys.argv[2]), int(sys.argv[3])
analysis = []
original = engine._position_analysis

def timed(*arguments, **keywords):
    started = time.perf_counter()
    try:
        return original(*arguments, **keywords)
    finally:
        analysis.append(time.perf_counter() - started)

engine._position_analysis = timed
out = {}
for preset in presets:
    mechanism = MECHANISM_PRESETS[preset]()
    for t_end, samples in spans:
        for _ in range(2):
            simulate_mechanism(mechanism, t_end, samples)
        analysis.clear()
        cpu, wall = [], []
        for _ in range(calls):
            started, started_wall = time.thread_time(), time.perf_counter()
            run = simulate_mechanism(mechanism, t_end, samples)
            cpu.append(time.thread_time() - started)
            wall.append(time.perf_counter() - started_wall)
        assert run.status == 0 and not run.integrated and run.t.size == samples, (preset, run.message)
        assert len(analysis) == calls
        middle = calls // 2
        out[f"{preset}, {t_end:g} s ({samples} samples)"] = [sorted(cpu)[middle], sorted(wall)[middle],
                                                             sorted(analysis)[middle]]
print(json.dumps(out))
"""


def _round(tree: Path, presets: list[str], calls: int) -> dict[str, list[float]]:
    return run_once(tree, WORKER, [json.dumps(presets), json.dumps(SPANS), str(calls)])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.driven_run")
    parser.add_argument("--before", type=Path, required=True, help="a worktree of the commit before the work")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--calls", type=int, default=20)
    parser.add_argument("--presets", nargs="+", default=["jansen-leg"], help="fully driven mechanism presets")
    args = parser.parse_args(argv)
    if args.rounds < 1 or args.calls < 1:
        parser.error("--rounds and --calls must be at least 1")
    trees = {"before": args.before.resolve(), "after": ROOT}
    print(f"load average at start: {' '.join(f'{v:.1f}' for v in os.getloadavg())}", flush=True)
    figures: dict[str, dict[str, list[list[float]]]] = {label: {} for label in trees}
    for number in range(args.rounds):
        order = list(trees) if number % 2 == 0 else list(reversed(trees))
        for label in order:
            for case, values in _round(trees[label], args.presets, args.calls).items():
                figures[label].setdefault(case, []).append(values)
    print("| run (ms per call, median of rounds) | before: wall | after: wall | before / after "
          "| before: position analysis | after: position analysis | before / after | before: CPU | after: CPU |")
    print("|---|---|---|---|---|---|---|---|---|")
    for case in figures["before"]:
        median = {label: [1000 * statistics.median(v[i] for v in figures[label][case]) for i in range(3)]
                  for label in trees}
        (cpu_b, wall_b, pa_b), (cpu_a, wall_a, pa_a) = median["before"], median["after"]
        print(f"| {case} | {wall_b:.2f} | {wall_a:.2f} | {wall_b / wall_a:.2f}x | {pa_b:.2f} | {pa_a:.2f} "
              f"| {pa_b / pa_a:.2f}x | {cpu_b:.2f} | {cpu_a:.2f} |")
    print(f"load average at end: {' '.join(f'{v:.1f}' for v in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
