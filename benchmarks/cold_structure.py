"""Figures for BENCHMARKS.md, issue 24, "Cold start of a new structure": a new mechanism's first whole process,
side by side with another tree (``--before``, a ``git worktree`` of the commit before the work), alternated in one
run, in CPU seconds (user + system of the child: on a shared machine the wall time is mostly waiting for a core).

    git worktree add ../before ce76585
    python -m benchmarks.cold_structure --before ../before [--repeat 3]

Each tree gets a private cache folder (``LINKAGE_LAB_CACHE``) filled once by a warm-up run of every figure's
command, so the integrators are compiled; before every measured run the generated files of the mechanisms are
removed from it (``*mechanism*.py``, ``*chain*.py``...: every ``.py`` in the folder's top level, where only
generated systems live), so each run derives, generates and compiles its structure anew. Figures:

* ``cold Jansen leg``: ``python -m physics mechanism --preset jansen-leg --t-end 10``;
* ``cold chain, 10 links, M``: ``python -m physics simulate --preset chain --links 10 --t-end 10 --method M``
  for each formulation M;
* ``tree Lagrange derivation, 10-body chain``: in one process, ``derive_structure`` of a 10-bar chain written as
  a mechanism (:func:`physics.mechanism.chains.chain_mechanism`), method ``lagrange``: CPU seconds of the
  derivation alone (sympy imported beforehand), the figure the issue bounds by 1 s.

Prints a Markdown table (the median and the least of ``--repeat`` rounds, then every round's figure: on a loaded
machine other processes only ever add to a figure, so the least is the nearest to the work itself) and the load
average at the start and end.
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FORMULATIONS = ("newton_euler", "lagrange", "dae")

DERIVATION_SCRIPT = r"""
import time
import sympy  # noqa: F401  (imported first: the figure is the derivation's own time)
from physics.model import make_chain
from physics.mechanism.chains import chain_mechanism
from physics.mechanism.parameters import structure
from physics.mechanism.symbolic import derive_structure
n = 10
chain = make_chain([1.0] * n, [0.5] * n, [1.0] * n, [1.0 / 12.0] * n, g=9.81)
shape = structure(chain_mechanism(chain, [0.3] * n))
started = time.process_time()
derive_structure(shape, "lagrange")
print(time.process_time() - started)
"""


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _environment(cache: Path) -> dict[str, str]:
    env = dict(os.environ, LINKAGE_LAB_CACHE=str(cache))
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # as an installation runs: the modules' bytecode is cached
    env.pop("NUMBA_CACHE_DIR", None)
    return env


def _whole(tree: Path, cache: Path, argv: list[str]) -> float:
    """CPU seconds (user + system) of one whole process started in ``tree``'s folder (so it imports that
    tree's code) with ``cache`` as its cache folder."""
    started = _children_cpu()
    done = subprocess.run([sys.executable, *argv], cwd=tree, env=_environment(cache), stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{tree}: {' '.join(argv)} failed: {done.stderr.strip()[-500:]}")
    return _children_cpu() - started


def _forget_generated(cache: Path) -> None:
    """Remove every generated system from ``cache`` (its top-level ``.py`` files); the compiled integrators
    (``numba/``) stay."""
    for generated in cache.glob("*.py"):
        generated.unlink()


def _derivation(tree: Path, cache: Path) -> float:
    done = subprocess.run([sys.executable, "-c", DERIVATION_SCRIPT], cwd=tree, env=_environment(cache), check=True,
                          capture_output=True, text=True)
    return float(done.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.cold_structure")
    parser.add_argument("--before", type=Path, required=True, help="a worktree of the commit before the work")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args(argv)
    trees = {"before": args.before.resolve(), "after": ROOT}
    scratch = Path(tempfile.mkdtemp(prefix="linkage-lab-cold-structure-"))
    try:
        return _measure(trees, scratch, args.repeat)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def _measure(trees: dict[str, Path], scratch: Path, repeat: int) -> int:
    caches = {label: scratch / label for label in trees}
    commands = {"cold Jansen leg, 10 s": ["-m", "physics", "mechanism", "--preset", "jansen-leg", "--t-end", "10"]}
    for method in FORMULATIONS:
        commands[f"cold chain, 10 links, {method}"] = [
            "-m", "physics", "simulate", "--preset", "chain", "--links", "10", "--t-end", "10", "--method", method,
            "--out", os.devnull]
    print(f"load average at start: {' '.join(f'{v:.1f}' for v in os.getloadavg())}", flush=True)
    for label, tree in trees.items():  # compile the integrators once per tree, and the modules' bytecode
        for command in commands.values():
            _whole(tree, caches[label], command)
    figures: dict[tuple[str, str], list[float]] = {}
    for _ in range(repeat):
        for name, command in commands.items():
            for label, tree in trees.items():  # alternated: both trees see the same machine
                _forget_generated(caches[label])
                figures.setdefault((name, label), []).append(_whole(tree, caches[label], command))
        for label, tree in trees.items():
            figures.setdefault(("tree Lagrange derivation, 10-body chain (in-process)", label), []).append(
                _derivation(tree, caches[label]))
    print("| figure (CPU seconds) | before: median, least (rounds) | after: median, least (rounds) | before / after "
          "(medians) |")
    print("|---|---|---|---|")
    for name in dict.fromkeys(key[0] for key in figures):
        cells = []
        for label in trees:
            values = figures[(name, label)]
            cells.append(f"{statistics.median(values):.3f}, {min(values):.3f} ({', '.join(f'{v:.3f}' for v in values)})")
        ratio = statistics.median(figures[(name, "before")]) / statistics.median(figures[(name, "after")])
        print(f"| {name} | {cells[0]} | {cells[1]} | {ratio:.2f}x |")
    print(f"load average at end: {' '.join(f'{v:.1f}' for v in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
