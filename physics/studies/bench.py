"""``python -m physics bench``: work-precision diagrams (error against wall time) for every formulation x
integrator x tolerance, on the seed cases and the four-bar, with the seed-style baseline beside them.

Why a benchmark command and not timed tests: wall time on a shared machine is noisy, so it is measured
here (median of repeats, stated with the machine's load) and recorded in BENCHMARKS.md, while the tests
only check that the command runs and that its numbers are sane.

Suites: ``work-precision`` (default; physics.studies.work_precision), ``ensemble`` (pendulum-steps per second,
physics.studies.ensemble_bench), ``chaos`` (chaos-map pixels per second, 1 and 2 workers,
physics.studies.chaos_map), ``models`` (the cheapest model for each question, physics.studies.models).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path

from ..arguments import Parser, parse_names
from ..errors import LinkageError
from ..outputs import check_output_folder
from ..registry import INTEGRATOR_NAMES
from . import chaos_map, ensemble_bench, models
from .work_precision import ALL_CASES, FORMULATIONS, FULL, QUICK, work_precision
from .work_precision_report import markdown_summary, write_outputs

# The suites other than work-precision: each writes its report into the output folder and lists the files.
SUITES: dict[str, Callable[..., list[Path]]] = {
    "ensemble": ensemble_bench.benchmark,
    "chaos": chaos_map.benchmark,
    "models": models.benchmark,
}


def _parse_tolerances(text: str | None):
    if text is None:
        return None
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise LinkageError(f"--tolerances = {text!r}: expected comma-separated numbers, e.g. 1e-3,1e-6") from None
    if not all(1e-14 <= v <= 0.1 for v in values):
        raise LinkageError(f"--tolerances = {text!r}: every tolerance must lie in 1e-14 <= tol <= 0.1")
    return values


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="python -m physics bench", description=__doc__.split("\n\n")[0])
    parser.add_argument("--suite", default="work-precision",
                        choices=("work-precision", "ensemble", "chaos", "models", "all"))
    parser.add_argument("--preset", default=None, metavar="NAME[,NAME]",
                        help=f"cases for work-precision (default: {', '.join(ALL_CASES)}; --quick: triple-c)")
    parser.add_argument("--quick", action="store_true", help="a small subset (about a minute), as CI runs it")
    parser.add_argument("--out", default="bench-results", help="folder for JSON, SVG, HTML and Markdown")
    parser.add_argument("--formulations", default=None, metavar="F[,F]")
    parser.add_argument("--integrators", default=None, metavar="I[,I]")
    parser.add_argument("--tolerances", default=None, metavar="TOL[,TOL]")
    parser.add_argument("--repeats", type=int, default=None)
    parser.add_argument("--no-baseline", action="store_true", help="skip the seed-style baseline")
    parser.add_argument("--no-progress", action="store_true")
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    check_output_folder(args.out)  # before any work: a benchmark is minutes of it
    out = Path(args.out)
    progress = not args.no_progress
    suites = ("work-precision", "ensemble", "chaos", "models") if args.suite == "all" else (args.suite,)
    if args.repeats is not None and not 1 <= args.repeats <= 100:
        raise LinkageError(f"--repeats = {args.repeats}: allowed range 1 <= repeats <= 100")
    for suite in suites:
        if suite == "work-precision":
            options = dict(QUICK if args.quick else FULL)
            cases = parse_names(args.preset, ALL_CASES, "--preset")
            if cases:
                options["cases"] = cases
            options["formulations"] = parse_names(args.formulations, FORMULATIONS, "--formulations") or options["formulations"]
            options["integrators"] = (parse_names(args.integrators, INTEGRATOR_NAMES, "--integrators")
                                      or options["integrators"])
            tolerances = _parse_tolerances(args.tolerances)
            if tolerances:
                options["tolerances"] = tolerances
                options["baseline_tolerances"] = tolerances
            if args.repeats:
                options["repeats"] = args.repeats
            if args.no_baseline:
                options["baseline_formulations"] = ()
            document = work_precision(options, progress)
            document["command"] = " ".join(["python -m physics bench", *(sys.argv[2:] if argv is None else argv)])
            written = write_outputs(document, out)
            print(markdown_summary(document))
        else:
            written = SUITES[suite](out, quick=args.quick, progress=progress)
        for path in written:
            print(f"wrote {path}", file=sys.stderr)
    return 0
