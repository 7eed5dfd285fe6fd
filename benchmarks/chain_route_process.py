"""Figures for BENCHMARKS.md, issue 24, "A chain preset's whole process on the mechanism engine": ``python -m
physics simulate --preset P`` run on the chain's own kernels and on the general mechanism engine
(:data:`physics.simulate.on_mechanism.ENABLED`), whole processes alternated in one run.

    python -m benchmarks.chain_route_process [--rounds 5] [--presets triple-a four-bar] [--methods dae]
                                             [--lengths short long] [--cold] [--cold-rounds 3]

Warm: for every chain preset (``python -m physics presets``), method (``newton_euler``, ``lagrange``, ``dae``)
and length (``short``: the preset's own ``t_end`` and the default samples; ``long``: ``--t-end 2000 --samples
2001``), one process per route first (the cache folder, the user's, then holds everything both routes load),
then ``--rounds`` rounds of one process per route, which route goes first alternating. The switch is set by a
``python -c`` wrapper that imports :mod:`physics.simulate.on_mechanism`, sets ``ENABLED`` and ends as ``python -m
physics`` does (:func:`physics.cli.main`, then :func:`physics.process_exit.exit_without_teardown`), for both
routes alike. A figure is the median over the rounds of each process's wall
time and of its CPU time (user + system of the child: on a shared machine the wall time is partly waiting for a
core).

``--cold``: a new structure's first process, as ``benchmarks.cold_structure`` measures it: a private cache folder
per route filled once by every command (so the integrators are compiled), every generated system (its top-level
``.py`` files) removed before each measured process; ``simulate --preset chain --links 10 --t-end 10 --method M``
for each formulation M, ``--cold-rounds`` alternated rounds (CPU seconds, median and least); and, in one process
each, the sympy derivation each route makes for the 10-link chain's Lagrange run: the chain's own
(:func:`physics.derive.FORMULATIONS`) and the tree Lagrange derivation of the chain written as a mechanism in
absolute rotations (what the route compiles: :func:`physics.mechanism.chains.chain_mechanism`), sympy imported
beforehand. Prints Markdown tables and the load average at the start and end.
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
import time
from pathlib import Path

from physics.presets import get_preset, preset_names

ROOT = Path(__file__).resolve().parent.parent
METHODS = ("newton_euler", "lagrange", "dae")
LENGTHS = {"short": [], "long": ["--t-end", "2000", "--samples", "2001"]}
ROUTES = ("kernels", "mechanism")

# ``python -m physics`` (physics/__main__.py: the command, then the exit without the interpreter's teardown) with
# the route chosen first (the switch is a module flag, not an option). A wrapper ending in sys.exit would add the
# teardown of every module loaded, which ``python -m physics`` skips, and so charge the route's extra modules twice.
WRAPPER = ("import importlib, sys; importlib.import_module('physics.simulate.on_mechanism').ENABLED = "
           "sys.argv[1] == 'mechanism'; from physics.cli import main; "
           "from physics.process_exit import exit_without_teardown; exit_without_teardown(int(main(sys.argv[2:]) or 0))")

DERIVATION_SCRIPT = r"""
import sys, time
import sympy  # noqa: F401  (imported first: the figure is the derivation's own time)
from physics.model import make_chain
n = 10
chain = make_chain([1.0] * n, [0.5] * n, [1.0] * n, [1.0 / 12.0] * n, g=9.81)
if sys.argv[1] == "mechanism":
    from physics.mechanism.chains import chain_mechanism
    from physics.mechanism.parameters import structure
    from physics.mechanism.symbolic import derive_structure
    shape = structure(chain_mechanism(chain, [0.0] * n))
    started = time.process_time()
    derive_structure(shape, "lagrange", "absolute")
else:
    from physics.derive import FORMULATIONS
    started = time.process_time()
    FORMULATIONS["lagrange"]().derive(n, False)
print(time.process_time() - started)
"""


def chain_presets() -> list[str]:
    """Every preset of the chain table (the mechanism presets run on the engine whatever the switch)."""
    return list(preset_names())


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _environment(cache: Path | None) -> dict[str, str]:
    env = dict(os.environ)
    if cache is not None:
        env["LINKAGE_LAB_CACHE"] = str(cache)
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # as an installation runs: the modules' bytecode is cached
    env.pop("NUMBA_CACHE_DIR", None)
    return env


def whole_process(route: str, argv: list[str], cache: Path | None = None) -> tuple[float, float]:
    """Wall and CPU seconds (user + system) of ``python -m physics ARGV`` on ``route``, started in this tree."""
    started_cpu, started = _children_cpu(), time.perf_counter()
    done = subprocess.run([sys.executable, "-c", WRAPPER, route, *argv], cwd=ROOT, env=_environment(cache),
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - started
    if done.returncode != 0:
        raise SystemExit(f"{route}: {' '.join(argv)} failed: {done.stderr.strip()[-500:]}")
    return wall, _children_cpu() - started_cpu


def _load() -> str:
    return " ".join(f"{value:.1f}" for value in os.getloadavg())


def warm(options: argparse.Namespace) -> None:
    print("| preset, method, run | kernels: wall s | mechanism: wall s | wall ratio | kernels: CPU s | "
          "mechanism: CPU s | CPU ratio |")
    print("|---|---|---|---|---|---|---|")
    for preset in options.presets:
        default_t_end = get_preset(preset).t_end
        for method in options.methods:
            for length in options.lengths:
                argv = ["simulate", "--preset", preset, "--method", method, *LENGTHS[length], "--out", os.devnull]
                for route in ROUTES:  # everything either route loads is cached before the figures
                    whole_process(route, argv)
                walls: dict[str, list[float]] = {route: [] for route in ROUTES}
                cpus: dict[str, list[float]] = {route: [] for route in ROUTES}
                for round_ in range(options.rounds):
                    for route in (ROUTES if round_ % 2 == 0 else ROUTES[::-1]):
                        wall, cpu = whole_process(route, argv)
                        walls[route].append(wall)
                        cpus[route].append(cpu)
                wall_k, wall_m = (statistics.median(walls[route]) for route in ROUTES)
                cpu_k, cpu_m = (statistics.median(cpus[route]) for route in ROUTES)
                t_end = "2000 s, 2001 samples" if length == "long" else f"{default_t_end:g} s"
                print(f"| {preset}, {method}, {t_end} | {wall_k:.3f} | {wall_m:.3f} | {wall_m / wall_k:.2f}x | "
                      f"{cpu_k:.3f} | {cpu_m:.3f} | {cpu_m / cpu_k:.2f}x |", flush=True)


def cold(options: argparse.Namespace) -> None:
    scratch = Path(tempfile.mkdtemp(prefix="linkage-lab-chain-route-cold-"))
    try:
        caches = {route: scratch / route for route in ROUTES}
        commands = {method: ["simulate", "--preset", "chain", "--links", "10", "--t-end", "10", "--method", method,
                             "--out", os.devnull] for method in METHODS}
        for route in ROUTES:  # the integrators compiled once per cache folder
            for command in commands.values():
                whole_process(route, command, caches[route])
        figures: dict[tuple[str, str], list[float]] = {}
        for round_ in range(options.cold_rounds):
            for method, command in commands.items():
                for route in (ROUTES if round_ % 2 == 0 else ROUTES[::-1]):
                    for generated in caches[route].glob("*.py"):
                        generated.unlink()
                    figures.setdefault((method, route), []).append(whole_process(route, command, caches[route])[1])
        derivations: dict[str, list[float]] = {route: [] for route in ROUTES}
        for _ in range(options.cold_rounds):
            for route in ROUTES:
                done = subprocess.run([sys.executable, "-c", DERIVATION_SCRIPT, route], cwd=ROOT,
                                      env=_environment(caches[route]), check=True, capture_output=True, text=True)
                derivations[route].append(float(done.stdout.strip().splitlines()[-1]))
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    print("| cold, CPU seconds | kernels: median, least (rounds) | mechanism: median, least (rounds) |")
    print("|---|---|---|")

    def cell(values: list[float]) -> str:
        return f"{statistics.median(values):.3f}, {min(values):.3f} ({', '.join(f'{v:.3f}' for v in values)})"

    for method in METHODS:
        print(f"| `simulate --preset chain --links 10 --t-end 10 --method {method}` | "
              f"{cell(figures[(method, 'kernels')])} | {cell(figures[(method, 'mechanism')])} |")
    print(f"| Lagrange derivation of the 10-link chain (sympy, in-process) | {cell(derivations['kernels'])} | "
          f"{cell(derivations['mechanism'])} |")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.chain_route_process", description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--presets", nargs="+", default=chain_presets(), choices=chain_presets())
    parser.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS)
    parser.add_argument("--lengths", nargs="+", default=list(LENGTHS), choices=list(LENGTHS))
    parser.add_argument("--cold", action="store_true", help="the cold new-structure figures instead of the warm ones")
    parser.add_argument("--cold-rounds", type=int, default=3)
    options = parser.parse_args(argv)
    print(f"load average at start: {_load()}", flush=True)
    if options.cold:
        cold(options)
    else:
        warm(options)
    print(f"load average at end: {_load()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
