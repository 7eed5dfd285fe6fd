"""``python -m physics bench``: work-precision diagrams (error against wall time) for every formulation x
integrator x tolerance, on the seed cases and the four-bar, with the seed-style baseline beside them.

Why a benchmark command and not timed tests: wall time on a shared machine is noisy, so it is measured
here (median of repeats, stated with the machine's load) and recorded in BENCHMARKS.md, while the tests
only check that the command runs and that its numbers are sane.

A general mechanism (``--preset slider-crank``, any mechanism preset, or ``--mechanism FILE``) gets the same
report: every method (dae, lagrange, newton_euler; reduced where the mobility is 1) x stabilisation (none,
baumgarte, projection) swept over the tolerance (physics.studies.mechanism_work_precision).

Suites: ``work-precision`` (default; physics.studies.work_precision), ``ensemble`` (pendulum-steps per second,
physics.studies.ensemble_bench), ``chaos`` (chaos-map pixels per second, 1 and 2 workers,
physics.studies.chaos_map), ``models`` (the cheapest model for each question, physics.studies.models),
``design`` (Design mode's drag latency: re-assembly + coupler curve, physics.studies.design_bench).
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
from . import chaos_map, design_bench, ensemble_bench, models
from .mechanism_cases import FORMULATIONS as MECHANISM_FORMULATIONS
from .mechanism_cases import MECHANISM_INTEGRATORS, STABILIZATIONS, load_case, mechanism_names
from .mechanism_work_precision import MECHANISM_FULL, MECHANISM_QUICK, mechanism_document
from .work_precision import ALL_CASES, FORMULATIONS, FULL, QUICK, work_precision
from .work_precision_report import markdown_summary, write_outputs

# The suites other than work-precision: each writes its report into the output folder and lists the files.
SUITES: dict[str, Callable[..., list[Path]]] = {
    "ensemble": ensemble_bench.benchmark,
    "chaos": chaos_map.benchmark,
    "models": models.benchmark,
    "design": design_bench.benchmark,
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


def _mechanism_cases(names, file: str | None) -> dict:
    """The mechanisms among ``--preset``'s names, and ``--mechanism FILE``'s, each checked to run."""
    mechanisms = {name: load_case(preset=name) for name in names if name in mechanism_names()}
    if file is not None:
        mechanism = load_case(file=file)
        mechanisms[mechanism.name if mechanism.name not in mechanisms else f"{mechanism.name} ({file})"] = mechanism
    return mechanisms


def _with_mechanisms(options: dict, mechanisms: dict, args, run_chains: bool, progress: bool) -> dict:
    """The document for the mechanisms' cases (and the chains' when named too): one report, one shape."""
    mechanism_options = dict(MECHANISM_QUICK if args.quick else MECHANISM_FULL)
    # every method unless narrowed (the chains' --quick drops newton_euler; a mechanism's report keeps it)
    mechanism_options["formulations"] = options["formulations"] if args.formulations else MECHANISM_FORMULATIONS
    mechanism_options["stabilizations"] = parse_names(args.stabilizations, STABILIZATIONS,
                                                      "--stabilizations") or STABILIZATIONS
    integrators = [name for name in options["integrators"] if name in MECHANISM_INTEGRATORS]
    if not integrators:
        raise LinkageError(f"--integrators = {args.integrators!r}: a mechanism runs "
                           f"{', '.join(MECHANISM_INTEGRATORS)}; include one of them")
    mechanism_options["integrators"] = tuple(integrators)
    if args.tolerances:
        mechanism_options["tolerances"] = options["tolerances"]
    if args.repeats:
        mechanism_options["repeats"] = args.repeats
    document = mechanism_document(mechanisms, mechanism_options, progress)
    if run_chains:
        chains = work_precision(options, progress)
        chains["cases"].update(document["cases"])
        chains["elapsed_seconds"] += document["elapsed_seconds"]
        return chains
    return document


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="python -m physics bench", description=__doc__.split("\n\n")[0])
    parser.add_argument("--suite", default="work-precision",
                        choices=("work-precision", "ensemble", "chaos", "models", "design", "all"))
    parser.add_argument("--preset", default=None, metavar="NAME[,NAME]",
                        help=f"cases for work-precision (default: {', '.join(ALL_CASES)}; --quick: triple-c), or "
                             f"mechanism presets ({', '.join(mechanism_names())})")
    parser.add_argument("--mechanism", default=None, metavar="FILE",
                        help="a mechanism file (.toml or .json): its work-precision case")
    parser.add_argument("--stabilizations", default=None, metavar="S[,S]",
                        help=f"for a mechanism: {', '.join(STABILIZATIONS)} (default: all)")
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
    suites = ("work-precision", "ensemble", "chaos", "models", "design") if args.suite == "all" else (args.suite,)
    mechanism_asked = args.mechanism is not None or any(name.strip() in mechanism_names()
                                                        for name in (args.preset or "").split(","))
    if mechanism_asked and args.suite != "work-precision":  # refused before minutes of other suites' work
        raise LinkageError(f"--suite {args.suite}: the ensemble, chaos, models and design suites measure the chains' batched "
                           "engine; a mechanism's study is --suite work-precision")
    if args.repeats is not None and not 1 <= args.repeats <= 100:
        raise LinkageError(f"--repeats = {args.repeats}: allowed range 1 <= repeats <= 100")
    for suite in suites:
        if suite == "work-precision":
            options = dict(QUICK if args.quick else FULL)
            cases = parse_names(args.preset, ALL_CASES + mechanism_names(), "--preset")
            mechanisms = _mechanism_cases(cases or (), args.mechanism)
            cases = tuple(name for name in cases or () if name not in mechanisms)
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
            if mechanisms:
                document = _with_mechanisms(options, mechanisms, args, run_chains=bool(cases), progress=progress)
            else:
                document = work_precision(options, progress)
            document["command"] = " ".join(["python -m physics bench", *(sys.argv[2:] if argv is None else argv)])
            written = write_outputs(document, out)
            print(markdown_summary(document))
        else:
            written = SUITES[suite](out, quick=args.quick, progress=progress)
        for path in written:
            print(f"wrote {path}", file=sys.stderr)
    return 0
