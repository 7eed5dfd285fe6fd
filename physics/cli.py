"""``python -m physics``: arguments -> models -> run -> CSV/JSON. Any error -> one line on stderr, non-zero exit.

Subcommands: ``simulate``, ``accelerations``, ``presets``, ``warm`` (fill the derivation cache), the
benchmark and chaos-map commands (``bench``, ``chaos-map``) where installed, and the seed-report companions
(``fbd``, ``equilibrium``, ``seed-report``: physics.report_commands).
"""

from __future__ import annotations

import argparse
import csv
import importlib
import io
import json
import math
import sys
import time

import numpy as np

from .arguments import Parser, parse_floats, parse_integers, parse_set
from .chain_presets import get_preset, mechanism_summaries, preset_names
from .errors import LinkageError
from .evaluate import accelerations
from .kernels import numba_start
from .kernels.constants import RK4_WORK_ROWS
from .kinematics import joint_positions
from .long_run import simulate_in_segments
from .loop_closure import assemble, grashof, project_velocity
from .model import Settings, TracePoint, apply_overrides, make_chain, validated
from .notices import install_stderr_lines
from .outputs import EXIT_RUN_STOPPED, check_output_path, check_partial_path, partial_note, write_ensemble, write_output
from .program import program_name, version_text
from .registry import (
    BACKENDS,
    COMPILED_INTEGRATORS,
    FORMULATION_NAMES,
    INTEGRATOR_NAMES,
    METHOD_NAMES,
    integrators_for,
)
from .simulate import simulate
from .simulate.chain_system import chain_system
from .simulate.run import check_assembled

EXIT_BAD_INPUT = 2


def _build_setup(args):
    """Preset + overrides + pin -> (chain, theta0, omega0, preset). Closed chains stay assembled."""
    preset = get_preset(args.preset, args.links)
    overrides = parse_set(getattr(args, "set", None))
    chain, theta, omega = apply_overrides(preset.chain, preset.theta0, preset.omega0, overrides)
    if chain.pinned:
        chain, theta, omega = _close_loop(chain, theta, omega, args, overrides)
    elif getattr(args, "pin", None):
        raise LinkageError(f"--pin {args.pin}: preset {args.preset} is an open chain (its tip is free); "
                           "--pin applies to closed loops such as four-bar and change-point")
    return chain, theta, omega, preset


def _close_loop(chain, theta, omega, args, overrides):
    """The pin is where the tip starts, unless ``--pin`` puts it elsewhere; then the last two angles are
    assembled from the driving ones. Start velocities are projected onto the loop's velocity constraint."""
    n = chain.n
    if getattr(args, "pin", None):
        pin = tuple(parse_floats(args.pin, "--pin", 2))
        chain = chain.with_pin(pin)
        theta = assemble(chain.array("L"), np.array(pin), theta[: n - 2], theta_prev=theta)
    else:
        tip = joint_positions(chain.array("L"), theta)[-1]
        chain = chain.with_pin((float(tip[0]), float(tip[1])))
    omega = project_velocity(chain.array("L"), theta, omega)
    return chain, np.asarray(theta, float), np.asarray(omega, float)


def _settings(args, chain):
    trace = None
    if args.trace is not None:
        values = parse_floats(args.trace, "--trace")
        if len(values) not in (2, 3) or values[0] != int(values[0]):
            raise LinkageError(f"--trace {args.trace!r}: expected BAR,ALONG[,ACROSS], e.g. --trace 2,0.5,0.1")
        trace = validated(TracePoint, bar=int(values[0]), along=values[1], across=values[2] if len(values) > 2 else 0.0)
        if trace.bar > chain.n:
            raise LinkageError(f"--trace bar = {trace.bar}: allowed range 1 <= bar <= {chain.n}")
    fields = dict(
        method=args.method,
        integrator=args.integrator,
        backend=args.backend,
        rtol=args.rtol,
        atol=args.atol,
        t_end=args.t_end,
        samples=args.samples,
        stabilization=args.stabilization,
        damping=args.damping,
        trace=trace,
    )
    if args.step is not None:
        fields["step"] = args.step
    if getattr(args, "max_steps", None) is not None:
        fields["max_steps"] = args.max_steps
    return validated(Settings, **fields)


# Ensembles: copies x steps a run may take (about half an hour at a million copy-steps a second).
MAX_ENSEMBLE_COPY_STEPS = 2_000_000_000


def _write_table(columns: dict, fmt: str, out: str | None) -> None:
    if fmt == "json":
        text = json.dumps({k: [float(v) for v in arr] for k, arr in columns.items()})
    else:
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow(columns.keys())
        for row in zip(*columns.values()):
            writer.writerow([repr(float(v)) for v in row])
        text = buffer.getvalue()
    text = text if text.endswith("\n") else text + "\n"
    if out:
        write_output(out, text.encode("utf-8"))
    else:
        sys.stdout.write(text)


def cmd_simulate(args) -> int:
    chain, theta, omega, preset = _build_setup(args)
    if args.t_end is None:
        args.t_end = preset.t_end
    settings = _settings(args, chain)
    if args.out is not None:
        check_output_path(args.out)
        check_partial_path(args.out)
    # estimated up front, progress on stderr for a long run, Ctrl+C keeps what was computed (physics.long_run)
    trajectory = simulate_in_segments(chain, theta, omega, settings)
    fmt = args.format or ("json" if args.out and args.out.endswith(".json") else "csv")
    if trajectory.success:
        _write_table(trajectory.columns(), fmt, args.out)
        return 0
    # What was computed is kept, under a name that cannot be mistaken for a complete run.
    partial = f"{args.out}.partial" if args.out else None
    _write_table(trajectory.columns(), fmt, partial)
    print(f"error: {trajectory.message}{partial_note(trajectory.t, partial)}", file=sys.stderr)
    return EXIT_RUN_STOPPED


def _case_chain(case, pinned_default: bool, index: int):
    """A validated case (physics.case_file.Case) -> (chain, theta, omega)."""
    n = case.links
    L, d, m, I = ([case.params[f"{f}{i}"] for i in range(1, n + 1)] for f in "LdmI")
    omega = case.omega if case.omega is not None else [0.0] * n
    pin = case.pin
    if pin is None and pinned_default:
        tip = joint_positions(np.asarray(L, float), np.asarray(case.theta, float))[-1]
        pin = (float(tip[0]), float(tip[1]))
    try:
        chain = make_chain(L, d, m, I, g=case.params.get("g", 1.0), pin=pin)
    except LinkageError as error:
        raise LinkageError(f"case {index}: {error}") from None
    return chain, case.theta, omega


def _check_on_loop(chain, theta, field: str) -> None:
    """A closed chain's state must close its loop (as a run's start must, physics.simulate.run): the
    accelerations of a state 2 m off the loop are numbers for a mechanism that does not exist."""
    try:
        check_assembled(chain, np.asarray(theta, float))
    except LinkageError as error:
        raise LinkageError(f"{field}: {error}") from None


def _with_grashof(result: dict, chain) -> dict:
    if chain.pinned and chain.n == 3:
        info = grashof(chain.array("L"), np.asarray(chain.pin))
        result["grashof"] = info.as_dict()
    return result


def cmd_accelerations(args) -> int:
    if args.input:
        from .case_file import read_cases  # noqa: PLC0415  (its pydantic model: only for --input)

        cases = read_cases(args.input)
        pinned_default = get_preset(args.preset, args.links).chain.pinned if args.preset else False
        results = []
        for index, case in enumerate(cases):
            chain, theta, omega = _case_chain(case, pinned_default, index)
            _check_on_loop(chain, theta, f"case {index}")
            try:
                result = accelerations(chain, theta, omega, args.method)
            except LinkageError as error:
                raise LinkageError(f"case {index}: {error}") from None
            results.append(_with_grashof(result, chain))
        print(json.dumps(results))
        return 0
    chain, theta, omega, _ = _build_setup(args)
    if args.state is not None:
        values = parse_floats(args.state, "--state", 2 * chain.n)
        theta, omega = np.array(values[: chain.n]), np.array(values[chain.n :])
        _check_on_loop(chain, theta, "--state")
    print(json.dumps(_with_grashof(accelerations(chain, theta, omega, args.method), chain)))
    return 0


ENSEMBLE_SUFFIXES = (".json", ".csv", ".png")  # what `ensemble --out` writes, chosen by the file's suffix


def cmd_ensemble(args) -> int:
    """N copies whose initial angles differ by ``spread``, advanced together (physics.ensemble): how fast the fan
    opens. JSON (default), CSV (a ``.csv`` file) or a PNG of the copies at the end (a ``.png`` file)."""
    from .ensemble import DEFAULT_STEP, Ensemble  # noqa: PLC0415  (off the path of simulate, as every command's own)

    chain, theta0, omega0, preset = _build_setup(args)
    t_end = preset.t_end if args.t_end is None else args.t_end
    if not (math.isfinite(t_end) and 0.0 < t_end <= 1e5):
        raise LinkageError(f"--t-end = {t_end}: allowed range 0 < t_end <= 1e5 s")
    if not 2 <= args.samples <= 100_000:
        raise LinkageError(f"--samples = {args.samples}: allowed range 2 <= samples <= 100000")
    step = DEFAULT_STEP if args.step is None else args.step
    if not (math.isfinite(step) and step > 0.0):
        raise LinkageError(f"--step = {step}: must be a positive number of seconds")
    steps = t_end / step  # a float: 1e5 / 1e-320 is infinite, not an integer
    copy_steps = args.count * (math.ceil(steps) if math.isfinite(steps) else steps)
    if not copy_steps <= MAX_ENSEMBLE_COPY_STEPS:
        raise LinkageError(
            f"--count {args.count} x (t_end / step = {steps:.3g}) = {copy_steps:.3g} copy-steps, more "
            f"than the {MAX_ENSEMBLE_COPY_STEPS:.0e} allowed (about {copy_steps / 1e6 / 60:.3g} min at 1e6 copy-steps/s); "
            "fewer copies, a shorter --t-end or a larger --step"
        )
    if args.out is not None:
        check_output_path(args.out, suffixes=ENSEMBLE_SUFFIXES)
    ensemble = Ensemble(chain, theta0, omega0, args.method, args.count, args.spread, step=step,
                        damping=args.damping)
    energy0 = ensemble.energy()
    scale = max(float(np.max(np.abs(energy0))), 1e-300)
    times, spread, alive, drift = [0.0], [ensemble.tip_spread()], [int(ensemble.alive.sum())], [0.0]
    for target in np.linspace(0.0, t_end, args.samples)[1:]:
        ensemble.run_steps(max(0, int(round(target / ensemble.step)) - ensemble.steps_taken))
        times.append(ensemble.time)
        spread.append(ensemble.tip_spread())
        alive.append(int(ensemble.alive.sum()))
        living = ensemble.alive
        drift.append(float(np.max(np.abs(ensemble.energy()[living] - energy0[living]))) / scale if living.any()
                     else float("nan"))
    columns: dict[str, list] = {"t": times, "tip_spread": spread, "alive": alive, "energy_drift": drift}
    document = {"preset": args.preset, "method": args.method, "count": ensemble.count, "spread": ensemble.spread,
                "step": ensemble.step, **columns, "message": ensemble.message,
                "final_tips": ensemble.joints()[:, -1, :].tolist()}
    from .studies.charts import fan_picture, png_bytes  # noqa: PLC0415  (PIL: only for an ensemble's picture)

    return write_ensemble(args.out, document, columns,
                          lambda: png_bytes(fan_picture(ensemble.joints(), ensemble.alive)),
                          bool(ensemble.alive.all()), ensemble.message)


def cmd_presets(args) -> int:
    """Every preset in one table: the chains (their keys unchanged), then the mechanisms (``kind: mechanism``)."""
    entries = [get_preset(name).summary() for name in preset_names()] + mechanism_summaries()
    print(json.dumps(entries, indent=2))
    return 0


def cmd_warm(args) -> int:
    """Derive and compile ahead of time, so the app and the CLI start warm: every integrator kernel once, then
    every mechanism the presets use (or the chains of ``--links``) for the three methods."""
    if args.preset is not None:
        raise LinkageError(f"--preset {args.preset}: warm takes a mechanism preset (python -m physics presets); a "
                           "chain's formulations are warmed by --links N,N or by warm alone")
    if args.links is None:
        targets = sorted({(get_preset(name).chain.n, get_preset(name).chain.pinned) for name in preset_names()})
    else:
        targets = [(int(n), False) for n in parse_integers(args.links, "--links", 1, 12)]
    warm_step = 0.01  # the fixed step of the warm-up runs (fixed-step integrators)
    for n, pinned in targets:
        preset = get_preset("four-bar") if pinned and n == 3 else get_preset("chain", links=n)
        if pinned and n != 3:
            continue
        for method in FORMULATION_NAMES:
            start = time.perf_counter()
            # the system a run of this chain takes (the chain written as a mechanism): the one the ensemble's
            # batch steps too
            system = chain_system(preset.chain, method)
            compiled = system.compiled
            # Every kernel this formulation can run (the variational one needs a Lagrangian).
            for integrator in integrators_for(method, COMPILED_INTEGRATORS):
                # step: the fixed-step kernels' step; the adaptive ones do not read it
                simulate(preset.chain, preset.theta0, preset.omega0,
                         Settings(method=method, integrator=integrator, t_end=0.05, samples=3, step=warm_step))
            compiled.rk4_batch_step(system.coordinates(preset.theta0[None]), system.coordinates(preset.omega0[None]),
                                    system.params, 1e-3, 0.0, 0.0, np.empty((RK4_WORK_ROWS, n)), np.empty(1))
            print(f"{method} n={n} {'pinned' if pinned else 'open'}: {time.perf_counter() - start:.2f} s "
                  f"({'cached' if compiled.from_cache else 'derived'})", flush=True)
    return 0


def cmd_cache(args) -> int:
    """Where the cache is, what it holds and its size (``--info``, the default), or empty it (``--clear``)."""
    from .codegen.inventory import cache_info, clear_cache, describe  # noqa: PLC0415  (only for this command)

    if args.clear:
        removed = clear_cache()
        print(f"removed {removed['removed_mechanisms']} mechanisms and {removed['removed_bytes'] / 1024 / 1024:.2f} "
              f"MiB from {removed['folder']}")
        return 0
    info = cache_info()
    print(json.dumps(info, indent=2) if args.json else describe(info))
    return 0


MECHANISM_HELP = ("a chain preset, or a mechanism preset (python -m physics presets lists both; a mechanism's own "
                  "options: docs/cli.md)")


def _common(parser, method_required=False, mechanisms=False):
    parser.add_argument("--preset", default="triple-a", choices=preset_names(),
                        help=MECHANISM_HELP if mechanisms else "a chain preset")
    parser.add_argument("--links", type=int, default=None, help="number of bars for --preset chain (1..12)")
    parser.add_argument("--method", default="lagrange", choices=METHOD_NAMES)
    parser.add_argument("--set", action="append", metavar="NAME=VALUE",
                        help="override a parameter or start value: L1..Ln d1..dn m1..mn I1..In g theta1.. omega1..")
    parser.add_argument("--pin", default=None, metavar="X,Y", help="pin the tip of a closed chain at this point")


CONSOLE_SCRIPT = "linkage-physics"  # [project.scripts] in pyproject.toml
MODULE_PROG = "python -m physics"


def build_parser(prog: str | None = None) -> argparse.ArgumentParser:
    parser = Parser(prog=prog or program_name(CONSOLE_SCRIPT, MODULE_PROG),
                    description="Linkage Lab physics: derive, simulate, compare.")
    parser.add_argument("--version", action="version", version=version_text())
    sub = parser.add_subparsers(dest="command", parser_class=Parser, metavar="COMMAND")

    sim = sub.add_parser("simulate", help="integrate a preset and print or write the trajectory")
    _common(sim, mechanisms=True)
    sim.add_argument("--integrator", default="DOP853", choices=INTEGRATOR_NAMES)
    sim.add_argument("--backend", default="compiled", choices=BACKENDS)
    sim.add_argument("--rtol", type=float, default=1e-10)
    sim.add_argument("--atol", type=float, default=1e-10)
    sim.add_argument("--step", type=float, default=None, help="fixed step for --integrator midpoint or variational")
    sim.add_argument("--max-steps", type=int, default=None,
                     help="integration steps allowed (default 1e7, at most 1e9); a fixed-step run beyond it is refused")
    sim.add_argument("--t-end", type=float, default=None, help="seconds to simulate (default: the preset's)")
    sim.add_argument("--samples", type=int, default=201)
    sim.add_argument("--stabilization", default="projection", choices=("none", "baumgarte", "projection"))
    sim.add_argument("--damping", type=float, default=0.0, help="viscous joint damping (torque per rad/s)")
    sim.add_argument("--trace", default=None, metavar="BAR,ALONG[,ACROSS]", help="point to trace")
    sim.add_argument("--out", default=None, help="write to this file (CSV, or JSON if it ends in .json)")
    sim.add_argument("--format", default=None, choices=("csv", "json"))
    sim.add_argument("--mechanism", default=None, metavar="FILE",
                     help="a mechanism file (.toml or .json, docs/mechanisms.md), run as the mechanism command runs "
                     "it, with the options that apply to it (docs/cli.md)")
    sim.set_defaults(func=cmd_simulate)

    acc = sub.add_parser("accelerations", help="print the accelerations (and reactions) at one state as JSON")
    _common(acc, mechanisms=True)
    acc.add_argument("--mechanism", default=None, metavar="FILE", help="a mechanism file (docs/cli.md)")
    acc.add_argument("--state", default=None, metavar="TH1,..,THN,W1,..,WN")
    acc.add_argument("--input", default=None, metavar="cases.json", help="evaluate a JSON list of cases")
    acc.set_defaults(func=cmd_accelerations)

    pre = sub.add_parser("presets", help="list the presets with their parameters (JSON)")
    pre.set_defaults(func=cmd_presets)

    ens = sub.add_parser("ensemble", help="N copies 1e-9 rad apart, advanced together: how fast the fan opens")
    _common(ens, mechanisms=True)
    ens.add_argument("--mechanism", default=None, metavar="FILE", help="a mechanism file (docs/cli.md)")
    ens.add_argument("--count", type=int, default=100, help="number of copies (1..1000000)")
    ens.add_argument("--spread", type=float, default=1e-9, help="radians between neighbouring copies' angles")
    ens.add_argument("--step", type=float, default=None, help="fixed RK4 step (default 1/240 s)")
    ens.add_argument("--t-end", type=float, default=None, help="seconds to simulate (default: the preset's)")
    ens.add_argument("--samples", type=int, default=101, help="rows of the time series")
    ens.add_argument("--damping", type=float, default=0.0, help="viscous joint damping (torque per rad/s)")
    ens.add_argument("--out", default=None, help="file: .json, .csv (time series) or .png (the fan at the end)")
    ens.set_defaults(func=cmd_ensemble)

    warm = sub.add_parser("warm", help="derive and compile ahead of time: every preset's mechanisms, or --links")
    warm.add_argument("--links", default=None, metavar="N,N,...", help="open chains of these lengths instead")
    warm.add_argument("--preset", default=None, metavar="MECHANISM", help="a mechanism preset's formulations instead")
    warm.add_argument("--mechanism", default=None, metavar="FILE", help="a mechanism file's formulations instead")
    warm.set_defaults(func=cmd_warm)

    cache = sub.add_parser("cache", help="show the code cache (where, what, how big) or empty it")
    action = cache.add_mutually_exclusive_group()
    action.add_argument("--info", action="store_true", help="where it is, what it holds and its size (default)")
    action.add_argument("--clear", action="store_true", help="remove everything in it")
    cache.add_argument("--json", action="store_true", help="--info as JSON")
    cache.set_defaults(func=cmd_cache)

    for name, description in EXTERNAL_HELP.items():  # listed for --help; main() dispatches them before parsing
        external = sub.add_parser(name, help=description, add_help=False, prefix_chars="\0")  # all its own
        external.add_argument("arguments", nargs=argparse.REMAINDER)
        external.set_defaults(func=lambda args, name=name: run_external(name, args.arguments))
    return parser


# Subcommands implemented apart, loaded by name only when asked for: a study may import sympy (the seed-style
# baseline) or dask, which ``simulate`` must not load (tests/physics/test_lean_start.py).
_EXTERNAL = {
    "bench": ("physics.studies.bench", "main"),
    "chaos-map": ("physics.studies.chaos_map", "main"),
    "fbd": ("physics.report_commands", "fbd_main"),
    "equilibrium": ("physics.report_commands", "equilibrium_main"),
    "seed-report": ("physics.report_commands", "seed_report_main"),
    "mechanism": ("physics.mechanism.command", "main"),
    "export": ("physics.export_command", "main"),  # other tools' formats (docs/mechanisms.md)
}

# Their one-line descriptions for ``--help``, written here so that listing them imports none of them
# (tests/physics/test_cli_conventions.py checks this table names exactly the commands of _EXTERNAL).
EXTERNAL_HELP = {
    "mechanism": "check, assemble and simulate a planar mechanism file (docs/mechanisms.md)",
    "export": "write a mechanism as MJCF (MuJoCo), pylinkage's JSON or TOML/JSON, or read pylinkage's JSON",
    "fbd": "forces on one bar (or a mechanism's --body) at one instant: gravity, joint reactions, motors",
    "equilibrium": "rest positions of a chain or a mechanism: angles, stability, potential energy",
    "seed-report": "the seed report's figures at its own settings, beside converged runs",
    "bench": "work-precision diagrams and speed suites (ensemble, chaos, models) for BENCHMARKS.md",
    "chaos-map": "time-to-first-flip map of initial angles (PNG and data)",
}


def run_external(name: str, argv: list[str]) -> int:
    """Import the module of a subcommand implemented apart and run it on its own arguments."""
    module_name, func = _EXTERNAL[name]
    return int(getattr(importlib.import_module(module_name), func)(argv) or 0)


MECHANISM_COMMANDS = ("simulate", "accelerations", "fbd", "equilibrium", "warm", "ensemble")  # take a mechanism too


def asks_for_mechanism(argv: list[str]) -> bool:
    """Whether a chain command's arguments ask for a general mechanism: ``--mechanism FILE``, or ``--preset``
    naming a mechanism preset (the mechanism presets are imported only then, so a chain's run stays lean)."""
    if any(item == "--mechanism" or item.startswith("--mechanism=") for item in argv):
        return True  # with a chain --preset too: the mechanism side refuses the pair in one line
    for position, item in enumerate(argv):
        name = item.split("=", 1)[1] if item.startswith("--preset=") else (
            argv[position + 1] if item == "--preset" and position + 1 < len(argv) else None)
        if name is not None:
            if name in preset_names():
                return False
            from .mechanism.presets import MECHANISM_PRESETS  # noqa: PLC0415

            return name in MECHANISM_PRESETS
    return False


def run_mechanism_command(command: str, argv: list[str]) -> int:
    """``simulate``, ``accelerations``, ``fbd``, ``equilibrium``, ``warm`` or ``ensemble`` of a mechanism preset or file
    (physics/mechanism/cli_runs.py)."""
    from .mechanism.cli_runs import main as mechanism_main  # noqa: PLC0415

    return mechanism_main(command, argv)


def refuse_empty_values(argv: list[str]) -> None:
    """``--trace=``, ``--state ''``, ``--out ''``: an option given an empty value is a mistake (a shell variable
    that was not set), not a request for the default; no option of any subcommand takes an empty value."""
    for position, item in enumerate(argv):
        if item.startswith("--") and "=" in item and not item.split("=", 1)[1].strip():
            raise LinkageError(f"{item.split('=', 1)[0]}: empty value; give one or leave the option out")
        if not item.strip():
            before = argv[position - 1] if position and argv[position - 1].startswith("--") else "an argument"
            raise LinkageError(f"{before}: empty value; give one or leave the option out")


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    install_stderr_lines()  # the library's notices (physics.notices) as the one-line stderr text they always were
    numba_start.start_without_blas()  # when numba loads: only a run that reaches a numba kernel
    try:
        refuse_empty_values(argv)
        if argv[:1] and argv[0] in MECHANISM_COMMANDS and asks_for_mechanism(argv[1:]):
            return run_mechanism_command(argv[0], argv[1:])
        if argv and argv[0] in _EXTERNAL:
            return run_external(argv[0], argv[1:])
        parser = build_parser()
        args = parser.parse_args(argv)
        if not getattr(args, "command", None):
            parser.print_help()
            return EXIT_BAD_INPUT
        return int(args.func(args) or 0)
    except LinkageError as error:
        print(f"error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("error: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0
