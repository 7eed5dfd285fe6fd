"""Figures for BENCHMARKS.md, issue 24, "Cold (integrators cached, new structure) whole process: the Jansen leg
<= 2 s": ``python -m physics mechanism --preset jansen-leg --t-end 10`` as a whole process, in this tree and in
another (``--before``, a ``git worktree`` of the commit before the work), rounds alternated in one run, each
process under ``/usr/bin/time`` (wall, and CPU = user + system: on a shared machine the wall time is partly
waiting for a core, so read the CPU column first).

    git worktree add ../before f92973a
    python -m benchmarks.cold_jansen --before ../before [--repeat 7]

Each tree gets a private cache folder filled by two warm-up runs (the compiled kernels, the modules' bytecode).
Two figures, the structure new to the cache in each round:

* ``generated file removed``: every ``.py`` of the cache folder's top level removed before each run (what
  ``benchmarks.warm_path`` and ``benchmarks.cold_structure`` do): the leg is derived, its code generated,
  but the machine code of that code (``native/*.o``, named by a digest of its IR) is found and loaded;
* ``generated file and machine code removed``: ``native/`` emptied as well, so the generated IR is compiled by
  LLVM too, as for a structure this installation has never run (the leg is fully driven: it uses no
  integrator's machine code, so nothing else of ``native/`` is lost; numba's kernels stay).

Prints a Markdown table (median and least of ``--repeat`` rounds, then every round) and the load average at the
start and end.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import sys
import tempfile
from pathlib import Path

from .warm_path import TIME, _whole

ROOT = Path(__file__).resolve().parent.parent
COMMAND = ["-m", "physics", "mechanism", "--preset", "jansen-leg", "--t-end", "10"]
FIGURES = {"generated file removed": False, "generated file and machine code removed": True}


def _forget(cache: Path, machine_code: bool) -> None:
    for generated in cache.glob("*.py"):
        generated.unlink()
    if machine_code:
        for compiled in (cache / "native").glob("*"):
            compiled.unlink()


def _cell(values: list[float]) -> str:
    return f"{statistics.median(values):.2f}, {min(values):.2f} ({', '.join(f'{v:.2f}' for v in values)})"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.cold_jansen")
    parser.add_argument("--before", type=Path, required=True, help="a worktree of the commit before the work")
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args(argv)
    if not Path(TIME).exists():
        raise SystemExit(f"{TIME} is needed (GNU time)")
    trees = {"before": args.before.resolve(), "after": ROOT}
    scratch = Path(tempfile.mkdtemp(prefix="linkage-lab-cold-jansen-"))
    try:
        caches = {label: scratch / label for label in trees}
        print(f"load average at start: {' '.join(f'{v:.1f}' for v in os.getloadavg())}", flush=True)
        for label, tree in trees.items():
            for _ in range(2):
                _whole(tree, caches[label], COMMAND, scratch)
        figures: dict[tuple[str, str], list[tuple[float, float]]] = {}
        for number in range(args.repeat):
            for name, machine_code in FIGURES.items():
                order = list(trees) if number % 2 == 0 else list(reversed(trees))
                for label in order:  # alternated: both trees see the same machine
                    _forget(caches[label], machine_code)
                    figures.setdefault((name, label), []).append(_whole(trees[label], caches[label], COMMAND,
                                                                        scratch))
        print("| cold Jansen leg, 10 s | before, CPU s: median, least (rounds) | after, CPU s | before / after "
              "(CPU medians) | before, wall s | after, wall s |")
        print("|---|---|---|---|---|---|")
        for name in FIGURES:
            before, after = figures[(name, "before")], figures[(name, "after")]
            cpu = [[value[1] for value in values] for values in (before, after)]
            wall = [[value[0] for value in values] for values in (before, after)]
            ratio = statistics.median(cpu[0]) / statistics.median(cpu[1])
            print(f"| {name} | {_cell(cpu[0])} | {_cell(cpu[1])} | {ratio:.2f}x | {_cell(wall[0])} | "
                  f"{_cell(wall[1])} |")
        print(f"load average at end: {' '.join(f'{v:.1f}' for v in os.getloadavg())}")
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
