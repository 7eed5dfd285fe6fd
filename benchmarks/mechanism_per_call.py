"""Figures for BENCHMARKS.md, "Mechanism engine per-call work" (issue 24): one warm call of
``simulate_mechanism``, in this tree and in another (``--before``, a ``git worktree`` of the commit before the
work), alternated in one run.

    git worktree add /tmp/percall-before da5222d
    python -m benchmarks.mechanism_per_call --before /tmp/percall-before [--rounds 3] [--calls 31]

Each round starts one process per tree (``python -c ...`` in the tree's folder, so it imports that tree's code;
the order of the two alternates from round to round). In it every case runs once to warm up (compiled code,
caches), then ``--calls`` times; a case's figure is the median CPU time of the calling thread
(``time.thread_time``: the compiled integrators run in it, and on a shared machine the wall time is partly
waiting for a core), and the table gives the median over the rounds. The cases:

* ``triple-c``: the triple pendulum preset as a mechanism (``chain_mechanism``, its start velocities from
  ``chain_state``), RK45 at rtol = atol = 1e-6, 20 s, 200 samples, each formulation with projection; beside it
  the chain's own engine (``physics.simulate``) on the same preset and settings;
* ``slider-crank``, ``crank-rocker``, ``geared-five-bar``: RK45 at 1e-6, 2 s, 200 samples, integrated;
* ``jansen-leg``: its motor fixes every body, so each sample is position analysis (2 s, 200 samples).
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
METHODS = ("dae", "lagrange", "newton_euler")

MEASURE = r"""
import json, statistics, sys, time
import physics
from physics.model import Settings
from physics.presets import get_preset
from physics.mechanism.chains import chain_mechanism, chain_state
from physics.mechanism.presets import MECHANISM_PRESETS
from physics.mechanism.simulate import simulate_mechanism

calls = int(sys.argv[1])
methods = sys.argv[2].split(",")


def median_ms(call):
    call()
    spent = []
    for _ in range(calls):
        started = time.thread_time()
        call()
        spent.append(time.thread_time() - started)
    return 1e3 * statistics.median(spent)


figures = {}
preset = get_preset("triple-c")
triple = chain_mechanism(preset.chain, preset.theta0)
_, qdot0 = chain_state(preset.chain, preset.theta0, preset.theta0, preset.omega0)
for method in methods:
    options = dict(t_end=20.0, samples=200, method=method, integrator="RK45", rtol=1e-6, atol=1e-6)
    figures[f"triple-c|{method}"] = median_ms(lambda: simulate_mechanism(triple, qdot0=qdot0, **options))
    settings = Settings(**options)
    figures[f"triple-c chain engine|{method}"] = median_ms(
        lambda: physics.simulate(preset.chain, preset.theta0, preset.omega0, settings))
for name in ("slider-crank", "crank-rocker", "geared-five-bar", "jansen-leg"):
    mechanism = MECHANISM_PRESETS[name]()
    for method in methods:
        options = dict(t_end=2.0, samples=200, method=method, integrator="RK45", rtol=1e-6, atol=1e-6)
        figures[f"{name}|{method}"] = median_ms(lambda: simulate_mechanism(mechanism, **options))
print(json.dumps(figures))
"""


def measure(tree: Path, calls: int, methods: tuple[str, ...]) -> dict[str, float]:
    """One process in ``tree``: every case's median thread CPU time per call, ms."""
    done = subprocess.run([sys.executable, "-c", MEASURE, str(calls), ",".join(methods)], cwd=tree,
                          capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{tree}: the measurement failed: {done.stderr.strip()[-800:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", metavar="DIR", required=True, help="a checkout of the commit before the work")
    parser.add_argument("--rounds", type=int, default=3, help="processes per tree, alternated (default 3)")
    parser.add_argument("--calls", type=int, default=31, help="timed calls per case and process (default 31)")
    args = parser.parse_args(argv)
    trees = {"before": Path(args.before).resolve(), "after": ROOT}
    rounds: dict[str, list[dict[str, float]]] = {"before": [], "after": []}
    for number in range(args.rounds):
        order = ("before", "after") if number % 2 == 0 else ("after", "before")
        for label in order:
            rounds[label].append(measure(trees[label], args.calls, METHODS))
    cases = list(rounds["after"][0])
    print(f"median thread CPU time per call, ms (median over {args.rounds} alternated rounds of {args.calls} "
          "warm calls)\n")
    print("| case | method | before | after | after / before |")
    print("|---|---|---|---|---|")
    for case in cases:
        name, method = case.split("|")
        before = statistics.median(figures[case] for figures in rounds["before"])
        after = statistics.median(figures[case] for figures in rounds["after"])
        print(f"| {name} | {method} | {before:.2f} | {after:.2f} | {after / before:.2f} |")


if __name__ == "__main__":
    main()
