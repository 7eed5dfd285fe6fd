"""Figures for BENCHMARKS.md, issue 24, "The reduced model on the compiled engine": the reduced model in one joint
coordinate (physics/mechanism/reduced.py) on the seed four-bar through the chain's ``simulate`` and through the
mechanism directly, side by side in one process, and every mobility-1 preset's reduced run. (Before issue 24's
"one pipeline" the chain's row ran the four-bar's own model, physics/reduced.py, now deleted: with ``--before``
on such a tree the two four-bar rows compare the old model with the general one.)

    python -m benchmarks.reduced [--t-end 20] [--samples 201] [--repeat 3] [--before TREE]

Figures are CPU seconds of the run alone (``time.process_time``; the machine is shared), the median of
``--repeat`` rounds, each case run once per round in the order below after a short warm-up run (generated code
loaded, kernels compiled):

* ``four-bar (chain)``: ``physics.simulate`` of the seed four-bar preset with ``method="reduced"``: the chain
  drawn as a mechanism, the general model (switching at share 0.4), the samples mapped back to the chain's angles
  and its Trajectory built;
* ``four-bar (mechanism)``: the same four-bar written as a mechanism (``chain_mechanism``), ``simulate_reduced``
  (switching at the general share 0.1), its maximal-coordinate run;
* ``slider-crank``, ``watt-six-bar``, ``stephenson-six-bar``: ``simulate_reduced`` of each preset from rest.

With ``--before TREE`` every round also runs the same cases in a child process on the tree ``TREE`` (a copy of
the package before a change: ``git archive <commit> physics | tar -x -C TREE``), alternating with this one, and
prints both columns. This file imports nothing from ``benchmarks`` so that it runs as a plain script there.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

CASES = ("four-bar (chain)", "four-bar (mechanism)", "slider-crank", "watt-six-bar", "stephenson-six-bar")


def _runners(t_end: float, samples: int):
    """One callable per case, each running it for ``t_end`` s (and returning its run's evaluation count)."""
    import physics  # noqa: PLC0415  (the tree on the path: this one, or the one --before names)
    from physics.chain_presets import get_preset  # noqa: PLC0415
    from physics.mechanism import MECHANISM_PRESETS  # noqa: PLC0415
    from physics.mechanism.chains import chain_mechanism  # noqa: PLC0415
    from physics.mechanism.reduced import simulate_reduced  # noqa: PLC0415

    preset = get_preset("four-bar")

    def chain(t: float):
        settings = physics.model.Settings(method="reduced", t_end=t, samples=samples)
        return physics.simulate(preset.chain, preset.theta0, preset.omega0, settings=settings).n_rhs

    def mechanism_run(mechanism):
        def run(t: float) -> int:
            result = simulate_reduced(mechanism, t, samples)
            # a tree before the counts moved to the run (n_rhs: scipy's evaluations) counted states solved
            return getattr(result, "rhs_evaluations", None) or result.run.n_rhs

        return run

    runners = {"four-bar (chain)": chain,
               "four-bar (mechanism)": mechanism_run(chain_mechanism(preset.chain, preset.theta0))}
    for name in CASES[2:]:
        runners[name] = mechanism_run(MECHANISM_PRESETS[name]())
    return runners


def measure(t_end: float, samples: int, rounds: int) -> dict[str, dict[str, list[float]]]:
    """CPU seconds of each case in each round, and its evaluation count."""
    runners = _runners(t_end, samples)
    for run in runners.values():
        run(0.05)  # load the generated code, compile the kernels
    seconds: dict[str, list[float]] = {name: [] for name in CASES}
    evaluations: dict[str, list[float]] = {name: [] for name in CASES}
    for _ in range(rounds):
        for name in CASES:
            started = time.process_time()
            count = runners[name](t_end)
            seconds[name].append(time.process_time() - started)
            evaluations[name].append(float(count))
    return {"seconds": seconds, "evaluations": evaluations}


def _before(tree: str, t_end: float, samples: int) -> dict[str, dict[str, list[float]]]:
    """One round in a child process on ``tree``'s package."""
    environment = {**os.environ, "PYTHONPATH": os.path.abspath(tree)}
    output = subprocess.run(
        [sys.executable, os.path.abspath(__file__), "--json", "--t-end", str(t_end), "--samples", str(samples),
         "--repeat", "1"], env=environment, cwd=os.path.abspath(tree), capture_output=True, text=True, check=True)
    return json.loads(output.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.reduced")
    parser.add_argument("--t-end", type=float, default=20.0)
    parser.add_argument("--samples", type=int, default=201)
    parser.add_argument("--repeat", type=int, default=3, help="rounds; the median is reported")
    parser.add_argument("--before", help="a copy of the package before the change, measured alternately")
    parser.add_argument("--json", action="store_true", help=argparse.SUPPRESS)  # the child's output
    args = parser.parse_args(argv)
    if args.json:
        print(json.dumps(measure(args.t_end, args.samples, args.repeat)))
        return 0
    print(f"load average at start: {os.getloadavg()[0]:.1f}", flush=True)
    now: dict[str, list[float]] = {name: [] for name in CASES}
    before: dict[str, list[float]] = {name: [] for name in CASES}
    counts: dict[str, float] = {}
    counts_before: dict[str, float] = {}
    for _ in range(max(args.repeat, 1)):
        if args.before:
            child = _before(args.before, args.t_end, args.samples)
            for name in CASES:
                before[name] += child["seconds"][name]
                counts_before[name] = child["evaluations"][name][-1]
        figures = measure(args.t_end, args.samples, 1)
        for name in CASES:
            now[name] += figures["seconds"][name]
            counts[name] = figures["evaluations"][name][-1]
    chain_now = statistics.median(now[CASES[0]])
    print(f"{args.t_end:g} s, {args.samples} samples, CPU seconds, median of {args.repeat} (rounds: all figures)")
    print("| case | " + ("before (CPU s) | " if args.before else "") + "now (CPU s) | now / chain now | "
          + ("before / now | " if args.before else "") + "evaluations |")
    print("|---|" + ("---|" if args.before else "") + "---|---|" + ("---|" if args.before else "") + "---|")
    for name in CASES:
        median_now = statistics.median(now[name])
        cells = [f"`{name}`"]
        if args.before:
            median_before = statistics.median(before[name])
            cells.append(f"{median_before:.3f} ({', '.join(f'{x:.3f}' for x in before[name])})")
        cells.append(f"{median_now:.3f} ({', '.join(f'{x:.3f}' for x in now[name])})")
        cells.append(f"{median_now / chain_now:.2f}x")
        if args.before:
            cells.append(f"{median_before / median_now:.1f}x")
        evaluations = f"{counts[name]:.0f}"
        if args.before and counts_before[name] != counts[name]:
            evaluations = f"{counts_before[name]:.0f} -> {counts[name]:.0f}"
        cells.append(evaluations)
        print("| " + " | ".join(cells) + " |")
    print(f"load average at end: {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
