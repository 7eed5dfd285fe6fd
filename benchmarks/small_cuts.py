"""Figures for BENCHMARKS.md, issue 24, "Small cuts of every process": what a warm process pays for the run
path's dataclasses (``eq``/``repr`` generated for classes that hold arrays), the derivation's symbol classes, the
tree formulations' closed-form reactions in a DAE run and the generated code's digest (the versions it reads),
and what a pin's rows at one pose cost (a run's assembly), for this tree and another (a worktree of main,
``../before``), alternated.

    python -m benchmarks.small_cuts [--rounds 9] [--other ../before] [--parts-only]

Module bytecode is cached (``PYTHONDONTWRITEBYTECODE`` removed, as an installation runs); the user's cache folder,
warm (one unmeasured process per tree and case first). Two kinds of figures, medians over ``--rounds`` rounds in
which the trees alternate which goes first:

* *parts*, measured inside a process with ``time.process_time``: the time spent in ``dataclasses`` making the
  package's classes while :mod:`physics`, its command line and the mechanism run's modules are imported; importing
  the mechanism run's modules (:mod:`physics` and its command line imported first, untimed: the shared base); the
  first :func:`physics.codegen.cache.generator_digest` (the sources it reads are the same files in both trees);
  :meth:`physics.mechanism.pin_rows.PinRows.rows_at` at one pose (microseconds a call, the best of 7 repeats of
  2000 calls), for triple-c and the four-bar written as mechanisms; and ``python -X importtime``'s own time of
  :mod:`physics.mechanism.parameters` (without the derivation's symbol classes after this work);
* *whole processes*: the CPU time (user + system) of ``python -m physics`` warm commands, from ``getrusage`` of
  the children: a mechanism preset's DAE run (the closed form of the tree reactions no longer imported), its
  Lagrange run, the driven Jansen leg and a chain preset's default run.

Prints Markdown tables (milliseconds) and the load average at the start and end.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

PARTS = r"""
import sys, time
if sys.argv[1] == "dataclasses":  # the time spent making the package's dataclasses, while importing the run's modules
    import dataclasses
    made, spent = dataclasses._process_class, []
    def timed(cls, *arguments, **keywords):
        start = time.process_time()
        try:
            return made(cls, *arguments, **keywords)
        finally:
            spent.append((cls.__module__, time.process_time() - start))
    dataclasses._process_class = timed
    import physics, physics.cli  # noqa: F401
    from physics.mechanism import assembly, engine, prepared, reduced_engine, reduced_partition, tree_reactions  # noqa
    from physics.codegen import mechanism_observables  # noqa: F401
    print(sum(seconds for module, seconds in spent if module.startswith("physics")) * 1e3)
    sys.exit()
import physics, physics.cli  # noqa: F401  (the shared base, untimed)
if sys.argv[1] == "imports":
    start = time.process_time()
    from physics.mechanism import assembly, engine, prepared, reduced_engine, reduced_partition  # noqa: F401
    from physics.codegen import mechanism_observables  # noqa: F401
    print((time.process_time() - start) * 1e3)
elif sys.argv[1] == "pin-rows":
    import timeit
    from physics.mechanism.chains import chain_mechanism
    from physics.mechanism.prepared import prepared
    from physics.chain_presets import get_preset
    loaded = get_preset(sys.argv[2])
    pieces = prepared(chain_mechanism(loaded.chain, loaded.theta0))
    q = pieces.constraints.sketch_pose() + 0.1
    rows = pieces.pin_rows
    rows.rows_at(q)
    print(min(timeit.repeat(lambda: rows.rows_at(q), number=2000, repeat=7, timer=time.process_time)) / 2000 * 1e6)
else:
    from physics.codegen import cache
    start = time.process_time()
    cache.generator_digest()
    print((time.process_time() - start) * 1e3)
"""

COMMANDS = {
    "mechanism slider-crank, dae": ["mechanism", "--preset", "slider-crank", "--method", "dae", "--t-end", "1"],
    "mechanism slider-crank, lagrange": ["mechanism", "--preset", "slider-crank", "--method", "lagrange",
                                         "--t-end", "1"],
    "mechanism jansen-leg (driven)": ["mechanism", "--preset", "jansen-leg", "--t-end", "1"],
    "simulate triple-a, dae": ["simulate", "--preset", "triple-a", "--method", "dae"],
}


def _environment(tree: Path) -> dict[str, str]:
    environment = dict(os.environ, PYTHONPATH=str(tree))
    environment.pop("PYTHONDONTWRITEBYTECODE", None)
    return environment


def _part(tree: Path, *which: str) -> float:
    done = subprocess.run([sys.executable, "-c", PARTS, *which], cwd=tree, env=_environment(tree), check=True,
                          capture_output=True, text=True)
    return float(done.stdout.split()[-1])


IMPORTED = "import physics.cli; from physics.mechanism import engine, prepared, assembly"


def _import_self_time(tree: Path, module: str) -> float:
    """``python -X importtime``'s own time (ms, not its imports') of ``module`` while the mechanism run's modules
    are imported."""
    done = subprocess.run([sys.executable, "-X", "importtime", "-c", IMPORTED], cwd=tree, env=_environment(tree),
                          check=True, capture_output=True, text=True)
    for line in done.stderr.splitlines():
        fields = line.split("|")
        if len(fields) == 3 and fields[2].strip() == module:
            return int(fields[0].split(":")[1]) / 1e3
    raise RuntimeError(f"{module} was not imported")


def _process_cpu(tree: Path, command: list[str]) -> float:
    """CPU milliseconds (user + system) of one ``python -m physics COMMAND`` process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([sys.executable, "-m", "physics", *command], cwd=tree, env=_environment(tree), check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime) * 1e3


def _alternated(trees: list[tuple[str, Path]], rounds: int, measure) -> dict[str, float]:
    for _, tree in trees:
        measure(tree)  # warm: the cache folder and the bytecode
    figures: dict[str, list[float]] = {name: [] for name, _ in trees}
    for round_ in range(rounds):
        for name, tree in trees[:: 1 if round_ % 2 == 0 else -1]:
            figures[name].append(measure(tree))
    return {name: statistics.median(values) for name, values in figures.items()}


def _row(case: str, medians: dict[str, float]) -> str:
    cells = " | ".join(f"{value:.1f}" for value in medians.values())
    if len(medians) == 2:
        this, other = medians.values()
        cells += f" | {this - other:+.1f}"
    return f"| {case} | {cells} |"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.small_cuts", description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=9)
    parser.add_argument("--other", type=Path, default=None, help="another tree (a worktree of main) to alternate with")
    parser.add_argument("--parts-only", action="store_true", help="skip the whole processes")
    options = parser.parse_args(argv)
    trees = [("this tree", ROOT)] + ([("other", options.other.resolve())] if options.other else [])
    header = " | ".join(f"{name}: CPU ms" for name, _ in trees) + (" | difference" if len(trees) == 2 else "")
    print(f"load average at start: {' '.join(f'{v:.1f}' for v in os.getloadavg())}", flush=True)
    print(f"| part or process (medians of {options.rounds}) | {header} |")
    print("|---|" + "---|" * (len(trees) + (len(trees) == 2)))
    for which, label in (("dataclasses", "making the package's dataclasses (import of the run's modules)"),
                         ("imports", "import the mechanism run's modules"),
                         ("digest", "first generator_digest()"),
                         ("pin-rows triple-c", "PinRows.rows_at, triple-c as a mechanism (us a call, best of 7)"),
                         ("pin-rows four-bar", "PinRows.rows_at, four-bar as a mechanism (us a call, best of 7)")):
        print(_row(label, _alternated(trees, options.rounds, lambda tree, which=which: _part(tree, *which.split()))),
              flush=True)
    for module in ("physics.mechanism.parameters",):
        print(_row(f"-X importtime, own time of {module}",
                   _alternated(trees, options.rounds, lambda tree, module=module: _import_self_time(tree, module))),
              flush=True)
    if not options.parts_only:
        for case, command in COMMANDS.items():
            print(_row(f"whole process: {case}",
                       _alternated(trees, options.rounds, lambda tree, command=command: _process_cpu(tree, command))),
                  flush=True)
    print(f"load average at end: {' '.join(f'{v:.1f}' for v in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
