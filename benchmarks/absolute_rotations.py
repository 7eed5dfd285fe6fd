"""Figures for BENCHMARKS.md, "Absolute rotations for the tree formulations": the sympy time of a 10-body chain's
tree derivations written as a mechanism, with a pin's coordinate relative to its parent (the default) and absolute
(the child's own rotation, ``rotations="absolute"``), alternated in one run.

    python -m benchmarks.absolute_rotations [--repeat 5] [--links 10]

Each figure is one fresh process (the derivations are kept in memory per structure, so a second one in the same
process would cost nothing): sympy imported first, then the CPU seconds (``time.process_time``) of
:func:`physics.mechanism.symbolic.derive_structure` alone for the tree Lagrange and Newton–Euler formulations,
and of :func:`physics.mechanism.symbolic_tree_dae.derive_tree_dae` from the DAE (the DAE's own derivation, the
same for both, not counted). Prints a Markdown table (the median and the least of ``--repeat`` rounds: on a
loaded machine other processes only ever add to a figure) and the load average at the start and end.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
METHODS = ("lagrange", "newton_euler", "tree_dae")
ROTATIONS = ("relative", "absolute")

SCRIPT = r"""
import sys, time
import sympy  # noqa: F401  (imported first: the figure is the derivation's own time)
from physics.model import make_chain
from physics.mechanism.chains import chain_mechanism
from physics.mechanism.parameters import structure
from physics.mechanism.symbolic_parameters import parameter_symbols
from physics.mechanism.symbolic import derive_structure
from physics.mechanism.symbolic_tree_dae import derive_tree_dae
method, rotations, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
chain = make_chain([1.0] * n, [0.5] * n, [1.0] * n, [1.0 / 12.0] * n, g=9.81)
shape = structure(chain_mechanism(chain, [0.0] * n))
if method == "tree_dae":
    dae = derive_structure(shape, "dae", "relative")
    started = time.process_time()
    derive_tree_dae(shape, parameter_symbols(shape), dae, rotations)
else:
    started = time.process_time()
    derive_structure(shape, method, rotations)
print(time.process_time() - started)
"""


def _figure(method: str, rotations: str, links: int) -> float:
    done = subprocess.run([sys.executable, "-c", SCRIPT, method, rotations, str(links)], cwd=ROOT,
                          capture_output=True, text=True, check=True)
    return float(done.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--links", type=int, default=10)
    args = parser.parse_args(argv)
    load_start = os.getloadavg()
    figures: dict[tuple[str, str], list[float]] = {(m, r): [] for m in METHODS for r in ROTATIONS}
    for _ in range(args.repeat):
        for method in METHODS:
            for rotations in ROTATIONS:  # alternated: relative then absolute, round after round
                figures[method, rotations].append(_figure(method, rotations, args.links))
    print(f"{args.links}-body chain as a mechanism, sympy CPU s, median (least) of {args.repeat} alternated rounds")
    print()
    print("| derivation | relative | absolute | absolute / relative |")
    print("|---|---|---|---|")
    for method in METHODS:
        relative, absolute = (figures[method, r] for r in ROTATIONS)
        ratio = statistics.median(absolute) / statistics.median(relative)
        print(f"| {method} | {statistics.median(relative):.3f} ({min(relative):.3f}) | "
              f"{statistics.median(absolute):.3f} ({min(absolute):.3f}) | {ratio:.2f} |")
    print()
    print(f"load average: start {load_start[0]:.2f}, end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
