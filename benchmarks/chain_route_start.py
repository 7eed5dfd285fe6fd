"""Figures for BENCHMARKS.md, issue 24, "A warm route without the mechanism package": what a warm process pays to
set up a chain's route on the mechanism engine, measured inside the process, for this tree and another (a
worktree of main, ``../before``), alternated.

    python -m benchmarks.chain_route_start [--rounds 3] [--other ../before] [--presets triple-a four-bar]
                                           [--methods lagrange dae]

Each process (the user's cache folder, warm: one unmeasured process per tree and case first) imports
:mod:`physics`, sets the switch, then measures its own CPU time (``time.process_time``) over importing
:mod:`physics.simulate.mechanism_route` and the first ``chain_route`` of the preset (the route's set-up, what the
whole process pays beyond the chain's kernels), then over one default ``simulate`` of it, and counts the
``physics.mechanism`` modules it loaded. Module bytecode is cached (PYTHONDONTWRITEBYTECODE removed) as an
installation runs. Prints a Markdown table of medians (milliseconds) and the load average.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CHILD = r"""
import importlib, sys, time
importlib.import_module("physics.simulate.on_mechanism").ENABLED = True
from physics import Settings, get_preset, simulate
loaded = get_preset(sys.argv[1])
start = time.process_time()
from physics.simulate import mechanism_route
mechanism_route.chain_route(loaded.chain, sys.argv[2], 0.0)
routed = time.process_time()
simulate(loaded.chain, loaded.theta0, loaded.omega0, Settings(method=sys.argv[2]))
done = time.process_time()
print((routed - start) * 1e3, (done - routed) * 1e3, sum(name.startswith("physics.mechanism") for name in sys.modules))
"""


def _measure(tree: Path, preset: str, method: str) -> tuple[float, float, int]:
    env = dict(os.environ, PYTHONPATH=str(tree))
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    done = subprocess.run([sys.executable, "-c", CHILD, preset, method], cwd=tree, env=env, check=True,
                          capture_output=True, text=True)
    route, run, modules = done.stdout.split()
    return float(route), float(run), int(modules)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.chain_route_start", description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--other", type=Path, default=None, help="another tree (a worktree of main) to alternate with")
    parser.add_argument("--presets", nargs="+", default=["triple-a", "four-bar"])
    parser.add_argument("--methods", nargs="+", default=["lagrange", "dae"])
    options = parser.parse_args(argv)
    trees = [("this tree", ROOT)] + ([("other", options.other.resolve())] if options.other else [])
    print(f"load average at start: {' '.join(f'{v:.1f}' for v in os.getloadavg())}", flush=True)
    print("| preset, method | tree | route set-up: CPU ms | simulate: CPU ms | physics.mechanism modules |")
    print("|---|---|---|---|---|")
    for preset in options.presets:
        for method in options.methods:
            figures: dict[str, list[tuple[float, float, int]]] = {name: [] for name, _ in trees}
            for _, tree in trees:
                _measure(tree, preset, method)  # warm
            for round_ in range(options.rounds):
                for name, tree in trees[:: 1 if round_ % 2 == 0 else -1]:
                    figures[name].append(_measure(tree, preset, method))
            for name, _ in trees:
                rows = figures[name]
                print(f"| {preset}, {method} | {name} | {statistics.median(r[0] for r in rows):.1f} | "
                      f"{statistics.median(r[1] for r in rows):.1f} | {rows[-1][2]} |")
    print(f"load average at end: {' '.join(f'{v:.1f}' for v in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
