"""Figures for BENCHMARKS.md, issue 25, "A first run in seconds ... warm path": whole processes with a warm
cache, and the cold Jansen leg, side by side with another tree (``--before``, a ``git worktree`` of the commit
before the work), rounds alternated in one run. Each process runs under ``/usr/bin/time``, which gives its wall
time and its CPU time (user + system): on a shared machine the wall time is mostly waiting for a core, so read
the CPU column first.

    git worktree add ../before a17353d
    python -m benchmarks.warm_path --before ../before [--repeat 3] [--warm-only]

Each tree gets a private cache folder (``LINKAGE_LAB_CACHE``) filled once by a warm-up run of every command
(the integrators compiled, the generated systems written, their machine code kept where the tree keeps it).
Figures:

* ``warm triple-a, dae``: ``python -m physics simulate --preset triple-a --method dae``;
* ``warm triple-a, default``: ``python -m physics simulate --preset triple-a`` (Lagrange);
* ``cold Jansen leg``: ``python -m physics mechanism --preset jansen-leg --t-end 10`` with the generated files
  removed before each run (every ``.py`` of the cache folder's top level, as ``benchmarks.cold_structure`` does:
  the leg is derived, generated and compiled anew; the integrators' machine code stays).

Prints a Markdown table (the median and the least of ``--repeat`` rounds, then every round's figure) and the
load average at the start and end.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TIME = "/usr/bin/time"
COMMANDS = {
    "warm triple-a, dae": (["-m", "physics", "simulate", "--preset", "triple-a", "--method", "dae"], False),
    "warm triple-a, default": (["-m", "physics", "simulate", "--preset", "triple-a"], False),
    "cold Jansen leg, 10 s": (["-m", "physics", "mechanism", "--preset", "jansen-leg", "--t-end", "10"], True),
}


def _environment(cache: Path) -> dict[str, str]:
    env = dict(os.environ, LINKAGE_LAB_CACHE=str(cache))
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # as an installation runs: the modules' bytecode is cached
    env.pop("NUMBA_CACHE_DIR", None)
    env.pop("PYTHONPATH", None)  # the tree's own code: ``python -m`` in its folder imports it first
    return env


def _whole(tree: Path, cache: Path, argv: list[str], scratch: Path) -> tuple[float, float]:
    """Wall and CPU seconds (user + system) of one whole process started in ``tree``'s folder with ``cache``
    as its cache folder, as ``/usr/bin/time`` reports them."""
    report = scratch / "time.txt"
    done = subprocess.run([TIME, "-o", str(report), "-f", "%e %U %S", sys.executable, *argv], cwd=tree,
                          env=_environment(cache), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{tree}: {' '.join(argv)} failed: {done.stderr.strip()[-500:]}")
    wall, user, system = (float(value) for value in report.read_text().split()[-3:])
    return wall, user + system


def _forget_generated(cache: Path) -> None:
    for generated in cache.glob("*.py"):
        generated.unlink()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.warm_path")
    parser.add_argument("--before", type=Path, required=True, help="a worktree of the commit before the work")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--warm-only", action="store_true",
                        help="only the two warm triple-a figures (the cold leg takes minutes a round)")
    args = parser.parse_args(argv)
    if not Path(TIME).exists():
        raise SystemExit(f"{TIME} is needed (GNU time)")
    trees = {"before": args.before.resolve(), "after": ROOT}
    scratch = Path(tempfile.mkdtemp(prefix="linkage-lab-warm-path-"))
    try:
        commands = {name: spec for name, spec in COMMANDS.items() if not (args.warm_only and spec[1])}
        return _measure(trees, scratch, args.repeat, commands)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def _cell(values: list[float]) -> str:
    return f"{statistics.median(values):.2f}, {min(values):.2f} ({', '.join(f'{v:.2f}' for v in values)})"


def _measure(trees: dict[str, Path], scratch: Path, repeat: int,
             commands: dict[str, tuple[list[str], bool]]) -> int:
    caches = {label: scratch / label for label in trees}
    print(f"load average at start: {' '.join(f'{v:.1f}' for v in os.getloadavg())}", flush=True)
    for label, tree in trees.items():  # compile the integrators once per tree, and the modules' bytecode
        for command, _ in commands.values():
            _whole(tree, caches[label], command, scratch)
            _whole(tree, caches[label], command, scratch)  # what a first run leaves for the next one
    figures: dict[tuple[str, str], list[tuple[float, float]]] = {}
    for _ in range(repeat):
        for name, (command, cold) in commands.items():
            for label, tree in trees.items():  # alternated: both trees see the same machine
                if cold:
                    _forget_generated(caches[label])
                figures.setdefault((name, label), []).append(_whole(tree, caches[label], command, scratch))
    print("| figure | before, CPU s: median, least (rounds) | after, CPU s | before / after (CPU medians) | "
          "before, wall s | after, wall s |")
    print("|---|---|---|---|---|---|")
    for name in commands:
        before, after = figures[(name, "before")], figures[(name, "after")]
        cpu = [[value[1] for value in values] for values in (before, after)]
        wall = [[value[0] for value in values] for values in (before, after)]
        ratio = statistics.median(cpu[0]) / statistics.median(cpu[1])
        print(f"| {name} | {_cell(cpu[0])} | {_cell(cpu[1])} | {ratio:.2f}x | {_cell(wall[0])} | {_cell(wall[1])} |")
    print(f"load average at end: {' '.join(f'{v:.1f}' for v in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
