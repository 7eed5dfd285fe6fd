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
* ``generated file and machine code removed``: the leg's own machine code removed as well (the files of
  ``native/`` that the leg's warm-up runs added), so its generated IR (and its specialised drivers) is compiled by
  LLVM too, as for a structure this installation has never run. What every structure shares stays: the
  integrators' and the projection module's machine code, made by a run of the crank-rocker before the leg's warm-up
  (an earlier version emptied all of ``native/``, which made a new structure pay for those too).

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
# run first in each cache: the machine code every structure shares (integrators, projection) is made by it
SHARED_CODE = ["-m", "physics", "mechanism", "--preset", "crank-rocker", "--t-end", "1"]
FIGURES = {"generated file removed": False, "generated file and machine code removed": True}


def _machine_code(cache: Path) -> set[Path]:
    return set((cache / "native").glob("*"))


def _forget(cache: Path, own_machine_code: set[Path] | None) -> None:
    """Remove the generated modules, and ``own_machine_code`` (the leg's) when given."""
    for generated in cache.glob("*.py"):
        generated.unlink()
    for compiled in own_machine_code or ():
        compiled.unlink(missing_ok=True)


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
        own_code: dict[str, set[Path]] = {}
        for label, tree in trees.items():
            _whole(tree, caches[label], SHARED_CODE, scratch)
            shared = _machine_code(caches[label])
            for _ in range(2):
                _whole(tree, caches[label], COMMAND, scratch)
            own_code[label] = _machine_code(caches[label]) - shared
            if not own_code[label]:
                raise SystemExit(f"{label}: the leg's runs added no machine code to native/: nothing to remove")
        figures: dict[tuple[str, str], list[tuple[float, float]]] = {}
        for number in range(args.repeat):
            for name, machine_code in FIGURES.items():
                order = list(trees) if number % 2 == 0 else list(reversed(trees))
                for label in order:  # alternated: both trees see the same machine
                    _forget(caches[label], own_code[label] if machine_code else None)
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
