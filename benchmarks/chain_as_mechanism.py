"""Figures for BENCHMARKS.md, "A chain as a mechanism, per call" (issue 24, one pipeline): one warm call of the
chain engine (``physics.simulate``) against the same chain written as a mechanism (``chain_mechanism``, its start
velocities from ``chain_state``) run by the mechanism engine (``simulate_mechanism``), for Newton-Euler, Lagrange
and the DAE, in this tree and in another (``--before``, a ``git worktree`` of the commit before the work),
alternated in one run.

    git worktree add ../before main
    python -m benchmarks.chain_as_mechanism --before ../before [--rounds 5] [--calls 31]
    python -m benchmarks.chain_as_mechanism [--rounds 5] [--calls 31]      # this tree alone

The chains: seed case C (the ``triple-c`` preset, a triple pendulum) and the ``four-bar`` preset (a triple
pendulum with its tip pinned to the ground: one loop), each RK45 at rtol = atol = 1e-6, 20 s, 200 samples, from
the preset's start, projection where it applies. For each chain and method the cases are:

* ``chain engine``: ``physics.simulate`` (its reactions computed by the run);
* ``mechanism``: ``simulate_mechanism`` with its ``reaction_rows`` read (a tree formulation's reactions are
  computed on request: the read is part of the call; the DAE's are its multipliers); the DAE in the tree's joint
  coordinates (``coordinates="tree"``, the state the chain engine's DAE integrates);
* ``mechanism, condition read too``: as above, also reading ``condition`` (every sample's condition of
  ``Phi_q``, a batched SVD), as the app and the ``mechanism`` command do;
* ``mechanism, a new start each call``: as ``mechanism``, from ``chain_state`` at the preset's angles moved by
  a different 1e-9 rad each call (``q0`` and ``qdot0``): the start is assembled each time, not remembered, as
  for a chain engine that hands every run to the mechanism engine (the four-bar's moved tip takes Newton steps
  back onto its pin ``H``);
* ``mechanism (absolute)``, ``... condition read too``, ``... a new start each call``: the three cases above as
  the one pipeline runs a chain (issue 24): the chain sketched at ``theta = 0`` (``chain_mechanism(chain,
  0)``), started at the preset's state (``chain_state``) with ``rotations="absolute"``, so a pin's tree
  coordinate is the bar's own angle and the run integrates exactly the chain engine's state (seed case C: the
  same 192 steps and 1502 right-hand sides), and ``the solve's condition read``: ``condition="solve"``, the
  condition a chain's run reports (its own solve's estimate, which the run has already; a tree without
  ``condition="solve"`` leaves its cells empty); the open chain and the four-bar, and a tree without
  ``rotations`` leaves them empty too.

One worker process per tree (``python -c ...`` in the tree's folder, so it imports that tree's code) runs every
case a few times to warm up (compiled code, caches, the drivers specialised per system); then, ``--rounds``
times, each case is timed by both workers one after the other (which goes first alternates), ``--calls`` calls
each. A figure is the median CPU time of the calling thread (``time.thread_time``; on a shared machine the wall
time is partly waiting for a core) over a round's calls, and the table gives the median over the rounds. The
load (``os.getloadavg``) is printed before and after.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

from .workers import TIMED_CASES_LOOP

ROOT = Path(__file__).resolve().parent.parent
METHODS = ("newton_euler", "lagrange", "dae")
CHAINS = ("triple-c", "four-bar")

WORKER = r"""
import inspect, itertools, json, statistics, sys, time
import physics
from physics.model import Settings
from physics.chain_presets import get_preset
from physics.mechanism.chains import chain_mechanism, chain_state
from physics.mechanism.simulate import simulate_mechanism

counter = itertools.count(1)  # a start never seen before: assembled, not remembered (physics/mechanism/prepared.py)

def new_start(mechanism, preset, options, absolute=False):
    sketch = 0.0 * preset.theta0 if absolute else preset.theta0
    q0, qdot0 = chain_state(preset.chain, sketch, preset.theta0 + 1e-9 * next(counter), preset.omega0)
    return simulate_mechanism(mechanism, q0=q0, qdot0=qdot0, **options).reaction_rows

tree_dae = "coordinates" in inspect.signature(simulate_mechanism).parameters
absolute = "rotations" in inspect.signature(simulate_mechanism).parameters
solve_condition = "condition" in inspect.signature(simulate_mechanism).parameters
calls = {}
for name in sys.argv[1].split(","):
    preset = get_preset(name)
    mechanism = chain_mechanism(preset.chain, preset.theta0)
    _, qdot0 = chain_state(preset.chain, preset.theta0, preset.theta0, preset.omega0)
    for method in sys.argv[2].split(","):
        options = dict(t_end=20.0, samples=200, method=method, integrator="RK45", rtol=1e-6, atol=1e-6)
        extra = dict(coordinates="tree") if method == "dae" and tree_dae else {}
        calls[f"{name}|chain engine|{method}"] = (lambda s, p: lambda: physics.simulate(
            p.chain, p.theta0, p.omega0, s))(Settings(**options), preset)
        calls[f"{name}|mechanism|{method}"] = (lambda m, v, o: lambda: simulate_mechanism(
            m, qdot0=v, **o).reaction_rows)(mechanism, qdot0, {**options, **extra})
        calls[f"{name}|mechanism, condition read too|{method}"] = (lambda m, v, o: lambda: (
            lambda run: (run.reaction_rows, run.condition))(simulate_mechanism(m, qdot0=v, **o)))(
            mechanism, qdot0, {**options, **extra})
        calls[f"{name}|mechanism, a new start each call|{method}"] = (lambda m, p, o: lambda: new_start(m, p, o))(
            mechanism, preset, {**options, **extra})
        if absolute:  # the route's run: sketched at theta = 0, the state from the preset's start, absolute rotations
            zero = 0.0 * preset.theta0
            sketched = chain_mechanism(preset.chain, zero)
            q0, v0 = chain_state(preset.chain, zero, preset.theta0, preset.omega0)
            opts = {**options, **extra, "rotations": "absolute"}
            calls[f"{name}|mechanism (absolute)|{method}"] = (lambda m, q, v, o: lambda: simulate_mechanism(
                m, q0=q, qdot0=v, **o).reaction_rows)(sketched, q0, v0, opts)
            calls[f"{name}|mechanism (absolute), condition read too|{method}"] = (lambda m, q, v, o: lambda: (
                lambda run: (run.reaction_rows, run.condition))(simulate_mechanism(m, q0=q, qdot0=v, **o)))(
                sketched, q0, v0, opts)
            if solve_condition:
                calls[f"{name}|mechanism (absolute), the solve's condition read|{method}"] = (
                    lambda m, q, v, o: lambda: (lambda run: (run.reaction_rows, run.condition))(
                        simulate_mechanism(m, q0=q, qdot0=v, condition="solve", **o)))(sketched, q0, v0, opts)
            calls[f"{name}|mechanism (absolute), a new start each call|{method}"] = (
                lambda m, p, o: lambda: new_start(m, p, o, absolute=True))(sketched, preset, opts)
for _ in range(3):  # warm: compiled code, caches, the specialised drivers (compiled in the background)
    for call in calls.values():
        call()
    time.sleep(1.0)
"""
WORKER += TIMED_CASES_LOOP


class Worker:
    """A process in ``tree`` (its folder, so it imports that tree's code) that times a case when asked."""

    def __init__(self, tree: Path) -> None:
        self.process = subprocess.Popen([sys.executable, "-c", WORKER, ",".join(CHAINS), ",".join(METHODS)],
                                        cwd=tree, text=True, stdin=subprocess.PIPE, stdout=subprocess.PIPE)
        self.tree = tree
        self.cases = json.loads(self._line())

    def _line(self) -> str:
        assert self.process.stdout is not None
        line = self.process.stdout.readline()
        if not line:
            raise SystemExit(f"{self.tree}: the worker stopped (its error is above)")
        return line

    def time(self, case: str, calls: int) -> float:
        """The median CPU time of ``calls`` calls of ``case``; NaN for a case this tree does not have."""
        if case not in self.cases:
            return float("nan")
        assert self.process.stdin is not None
        self.process.stdin.write(f"{case} {calls}\n")
        self.process.stdin.flush()
        return float(self._line())

    def close(self) -> None:
        assert self.process.stdin is not None
        self.process.stdin.close()
        self.process.wait()


def _load() -> str:
    return " ".join(f"{value:.2f}" for value in os.getloadavg())


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", metavar="DIR", help="a checkout of the commit before the work (without it: "
                                                         "this tree alone)")
    parser.add_argument("--rounds", type=int, default=5, help="alternations per case (default 5)")
    parser.add_argument("--calls", type=int, default=31, help="timed calls per case and round (default 31)")
    args = parser.parse_args(argv)
    print(f"load average at the start: {_load()}")
    workers = {"after": Worker(ROOT)}
    if args.before:
        workers["before"] = Worker(Path(args.before).resolve())
    figures: dict[str, dict[str, list[float]]] = {label: {} for label in workers}
    cases = workers["after"].cases
    try:
        for number in range(args.rounds):
            for case in cases:
                order = [label for label in (("before", "after") if number % 2 == 0 else ("after", "before"))
                         if label in workers]
                for label in order:
                    figures[label].setdefault(case, []).append(workers[label].time(case, args.calls))
    finally:
        for worker in workers.values():
            worker.close()
    print(f"load average at the end: {_load()}")
    together = "the two trees alternated case by case" if args.before else "this tree alone"
    print(f"median thread CPU time per call, ms: the median over {args.rounds} rounds ({together}) of the median "
          f"of {args.calls} warm calls; in brackets the ratio to the chain engine in the same tree\n")
    labels = [label for label in ("before", "after") if label in workers]
    print("| chain | case | " + " | ".join(f"{method} {label}" for method in METHODS for label in labels) + " |")
    print("|---|---|" + "---|" * (len(METHODS) * len(labels)))
    for chain in CHAINS:
        for kind in ("chain engine", "mechanism", "mechanism, condition read too", "mechanism, a new start each call",
                     "mechanism (absolute)", "mechanism (absolute), condition read too",
                     "mechanism (absolute), the solve's condition read",
                     "mechanism (absolute), a new start each call"):
            cells = []
            for method in METHODS:
                for label in labels:
                    values = figures[label].get(f"{chain}|{kind}|{method}", [])
                    base = figures[label].get(f"{chain}|chain engine|{method}", [])
                    if not values or values[0] != values[0]:
                        cells.append("")
                        continue
                    value = statistics.median(values)
                    ratio = "" if kind == "chain engine" else f" ({value / statistics.median(base):.1f}x)"
                    cells.append(f"{value:.2f}{ratio}")
            if any(cells):  # a case no tree has (the four-bar's absolute ones): no row
                print(f"| {chain} | {kind} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
