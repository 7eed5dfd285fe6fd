"""Figures for BENCHMARKS.md, "Mechanism engine per-call work" (issue 24): one warm call of
``simulate_mechanism``, in this tree and in another (``--before``, a ``git worktree`` of the commit before the
work), alternated in one run.

    git worktree add ../percall-before da5222d
    python -m benchmarks.mechanism_per_call --before ../percall-before [--rounds 5] [--calls 31] [--cases triple-c]
    python -m benchmarks.mechanism_per_call [--rounds 5] [--calls 31]      # this tree alone
    python -m benchmarks.mechanism_per_call --only "DOP853 1e-10" --rounds 21   # the seed's case, three ways

One worker process per tree (``python -c ...`` in the tree's folder, so it imports that tree's code) runs every
case once to warm up (compiled code, caches); then, ``--rounds`` times, each case is timed by both workers one
after the other (which goes first alternates), ``--calls`` calls each, so the two trees meet the machine's load
together. A figure is the median CPU time of the calling thread (``time.thread_time``: the compiled integrators
run in it, and on a shared machine the wall time is partly waiting for a core) over a round's calls, and the
table gives the median over the rounds. The cases:

* ``triple-c``: the triple pendulum preset as a mechanism (``chain_mechanism``, its start velocities from
  ``chain_state``), RK45 at rtol = atol = 1e-6, 20 s, 200 samples, each formulation with projection; beside it
  the chain's own engine (``physics.simulate``) on the same preset and settings; and the mechanism's call with
  its ``condition`` and ``reaction_rows`` read (what the app and the ``mechanism`` command read of every run:
  a field computed on request, physics/simulate/trajectory.py ``OnRequest``, is computed by the read);
* ``slider-crank``, ``crank-rocker``, ``geared-five-bar``: RK45 at 1e-6, 2 s, 200 samples, integrated;
* ``jansen-leg``: its motor fixes every body, so each sample is position analysis (2 s, 200 samples);
* ``triple-c tree coordinates`` (method ``dae`` only, in a tree that has it): the triple pendulum as a mechanism
  run by the DAE in tree coordinates (``coordinates="tree"``: the state the chain engine's DAE integrates, joint
  angles and rates, with the mechanism's maximal DAE solved at each state), RK45 at 1e-6 as above; and, as
  ``DOP853 1e-10``, the seed's case (DOP853 at rtol = atol = 1e-10, 20 s, 200 samples) run three ways: this mode,
  the chain engine's DAE and the mechanism's maximal ``dae``.

A case a tree does not have (the tree-coordinates cases in a tree before them) is left blank in its column.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
from pathlib import Path

from .workers import TIMED_CASES_LOOP

ROOT = Path(__file__).resolve().parent.parent
METHODS = ("dae", "lagrange", "newton_euler")

WORKER = r"""
import inspect, json, statistics, sys, time
import physics
from physics.model import Settings
from physics.chain_presets import get_preset
from physics.mechanism.chains import chain_mechanism, chain_state
from physics.mechanism.presets import MECHANISM_PRESETS
from physics.mechanism.simulate import simulate_mechanism

def _read(run):  # what the app and the mechanism command read of every run (a field on request is computed)
    return run.condition, run.reaction_rows

calls = {}
preset = get_preset("triple-c")
triple = chain_mechanism(preset.chain, preset.theta0)
_, qdot0 = chain_state(preset.chain, preset.theta0, preset.theta0, preset.omega0)
for method in sys.argv[1].split(","):
    options = dict(t_end=20.0, samples=200, method=method, integrator="RK45", rtol=1e-6, atol=1e-6)
    calls[f"triple-c|{method}"] = (lambda o: lambda: simulate_mechanism(triple, qdot0=qdot0, **o))(options)
    calls[f"triple-c, condition and reactions read|{method}"] = (lambda o: lambda: _read(
        simulate_mechanism(triple, qdot0=qdot0, **o)))(options)
    calls[f"triple-c chain engine|{method}"] = (lambda s: lambda: physics.simulate(
        preset.chain, preset.theta0, preset.omega0, s))(Settings(**options))
    if method == "dae" and "coordinates" in inspect.signature(simulate_mechanism).parameters:
        calls["triple-c tree coordinates|dae"] = (lambda o: lambda: simulate_mechanism(
            triple, qdot0=qdot0, coordinates="tree", **o))(options)
        seed = dict(t_end=20.0, samples=200, method="dae", integrator="DOP853", rtol=1e-10, atol=1e-10)
        calls["triple-c tree coordinates|dae DOP853 1e-10"] = (lambda o: lambda: simulate_mechanism(
            triple, qdot0=qdot0, coordinates="tree", **o))(seed)
        calls["triple-c chain engine|dae DOP853 1e-10"] = (lambda s: lambda: physics.simulate(
            preset.chain, preset.theta0, preset.omega0, s))(Settings(**seed))
        calls["triple-c|dae DOP853 1e-10"] = (lambda o: lambda: simulate_mechanism(triple, qdot0=qdot0, **o))(seed)
        # the integrator alone (no assembly, samples, reactions or conditions): the compiled DOP853 on each system
        import numpy as np
        from physics.codegen import load_compiled
        from physics.mechanism.parameters import parameter_vector
        from physics.mechanism.tree_coordinates import tree_state
        from physics.mechanism.tree_dae import compiled_tree_dae
        from physics.simulate.chain_prepared import chain_arrays

        t_eval = np.linspace(0.0, 20.0, 200)
        q0, _ = chain_state(preset.chain, preset.theta0, preset.theta0, preset.omega0)
        alone = {"tree coordinates": (compiled_tree_dae(triple), np.concatenate(tree_state(triple, q0, qdot0)),
                                      parameter_vector(triple)),
                 "chain engine": (load_compiled("dae", 3, False),
                                  np.concatenate([preset.theta0, preset.omega0]).astype(float),
                                  chain_arrays(preset.chain).params_with(0.0))}
        for label, (system, y0, params) in alone.items():
            calls[f"triple-c {label}, integrator alone|dae DOP853 1e-10"] = (
                lambda c, y, p: lambda: c.integrate_dop853(y, 0.0, 20.0, t_eval, p.copy(), 1e-10, 1e-10, 0.0, 0.0,
                                                           True, 10**6, np.empty((200, y.size)), np.empty(0)))(
                system, y0, params)
    for name in ("slider-crank", "crank-rocker", "geared-five-bar", "jansen-leg"):
        options = dict(t_end=2.0, samples=200, method=method, integrator="RK45", rtol=1e-6, atol=1e-6)
        calls[f"{name}|{method}"] = (lambda m, o: lambda: simulate_mechanism(m, **o))(MECHANISM_PRESETS[name](),
                                                                                     options)
for call in calls.values():  # warm: compiled code, caches
    call()
"""
WORKER += TIMED_CASES_LOOP


class Worker:
    """A process in ``tree`` (its folder, so it imports that tree's code) that times a case when asked."""

    def __init__(self, tree: Path, methods: tuple[str, ...]) -> None:
        self.process = subprocess.Popen([sys.executable, "-c", WORKER, ",".join(methods)], cwd=tree, text=True,
                                        stdin=subprocess.PIPE, stdout=subprocess.PIPE)
        self.cases = json.loads(self._line(tree))
        self.tree = tree

    def _line(self, tree: Path) -> str:
        assert self.process.stdout is not None
        line = self.process.stdout.readline()
        if not line:
            raise SystemExit(f"{tree}: the worker stopped (its error is above)")
        return line

    def time(self, case: str, calls: int) -> float:
        """The median CPU time of ``calls`` calls of ``case``; NaN for a case this tree does not have."""
        if case not in self.cases:
            return float("nan")
        assert self.process.stdin is not None
        self.process.stdin.write(f"{case} {calls}\n")
        self.process.stdin.flush()
        return float(self._line(self.tree))

    def close(self) -> None:
        assert self.process.stdin is not None
        self.process.stdin.close()
        self.process.wait()


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", metavar="DIR", help="a checkout of the commit before the work (without it: "
                                                         "this tree alone)")
    parser.add_argument("--rounds", type=int, default=5, help="alternations per case (default 5)")
    parser.add_argument("--calls", type=int, default=31, help="timed calls per case and round (default 31)")
    parser.add_argument("--only", metavar="TEXT", default="",
                        help="time only the cases whose name and method contain TEXT (default: every case)")
    parser.add_argument("--cases", default="", help="comma-separated beginnings of the case names to time "
                                                    "(default: every case)")
    args = parser.parse_args(argv)
    wanted = tuple(part.strip() for part in args.cases.split(",") if part.strip())
    workers = {"after": Worker(ROOT, METHODS)}
    workers["after"].cases = [case for case in workers["after"].cases if args.only in case]
    if args.before:
        workers["before"] = Worker(Path(args.before).resolve(), METHODS)
    figures: dict[str, dict[str, list[float]]] = {label: {} for label in workers}
    try:
        cases = [case for case in workers["after"].cases if not wanted or case.startswith(wanted)]
        for number in range(args.rounds):
            for case in cases:
                order = [label for label in (("before", "after") if number % 2 == 0 else ("after", "before"))
                         if label in workers]
                for label in order:
                    figures[label].setdefault(case, []).append(workers[label].time(case, args.calls))
    finally:
        for worker in workers.values():
            worker.close()
    together = "the two trees alternated case by case" if args.before else "this tree alone"
    print(f"median thread CPU time per call, ms: the median over {args.rounds} rounds ({together}) of the median "
          f"of {args.calls} warm calls\n")
    if not args.before:
        print("| case | method | ms |")
        print("|---|---|---|")
        for case in cases:
            name, method = case.split("|")
            print(f"| {name} | {method} | {statistics.median(figures['after'][case]):.2f} |")
        return
    print("| case | method | before | after | after / before |")
    print("|---|---|---|---|---|")
    for case in cases:
        name, method = case.split("|")
        before, after = (statistics.median(figures[label][case]) for label in ("before", "after"))
        if before != before:  # NaN: the tree before has no such case
            print(f"| {name} | {method} | | {after:.2f} | |")
            continue
        print(f"| {name} | {method} | {before:.2f} | {after:.2f} | {after / before:.2f} |")


if __name__ == "__main__":
    main()
