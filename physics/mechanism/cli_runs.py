"""The chain commands of ``python -m physics`` for a mechanism preset or file: ``simulate``, ``accelerations``,
``fbd``, ``equilibrium``, ``ensemble`` and ``warm`` with ``--preset NAME`` (a mechanism preset) or ``--mechanism FILE``.

    python -m physics simulate --preset jansen-leg --t-end 2 --out leg.csv
    python -m physics simulate --mechanism my.toml --method lagrange --set crank.mass=0.2 --format json
    python -m physics accelerations --preset slider-crank --method dae,lagrange,newton_euler
    python -m physics fbd --preset slider-crank --body rod --time 0.1 --json
    python -m physics equilibrium --preset slider-crank
    python -m physics warm --preset jansen-leg
    python -m physics ensemble --preset slider-crank --count 10 --t-end 1 --out fan.png

Why apart from :mod:`physics.cli`: the chain commands read angles ``theta1..thetan`` and bar numbers, a
mechanism has named bodies and joints; :mod:`physics.cli` sends a command here when its ``--preset`` names a
mechanism or it has ``--mechanism``. A run's table is the ``mechanism`` command's (:func:`.command.run_table`:
``t``, the traced point, the energies, ``constraint_residual``, ``lambda[JOINT: row]``), its ``--json`` summary
that command's keys. An option that means something for a chain only is refused in one line naming it.
"""

from __future__ import annotations

import json
import math
import time

import numpy as np

from ..arguments import Parser, parse_floats, parse_set
from ..errors import LinkageError
from ..outputs import check_output_path, write_ensemble, write_output
from ..registry import METHODS
from .command import RunRequest, integrator_options, integrator_request, run_and_report
from .description import Mechanism
from .files import load_mechanism, mechanism_from_document
from .presets import MECHANISM_PRESETS
from .simulate import RUN_METHODS
from .statics import STATE_METHODS, check_state, evaluate, free_body, rest_poses, start_state

DEFAULT_T_END = 2.0  # seconds, as the mechanism command's runs
MAX_FBD_TIME = 1000.0  # the chain fbd's bound (physics.fbd.MAX_FBD_TIME)

# Chain options and why they do not apply to a mechanism: refused in one line naming the option.
CHAIN_ONLY = {
    "--links": "the number of bars of preset chain",
    "--pin": "where a closed chain's tip is pinned; a mechanism's joints are in its file",
    "--trace": "a chain's BAR,ALONG point; a mechanism traces the point its file names (trace = \"body.point\")",
    "--damping": "a chain's joint damping; give a mechanism joint's with --set JOINT.damping=C",
    "--input": "a file of chain cases (links, params, theta)",
    "--bar": "a chain's bar number; a mechanism's bodies are named: --body NAME",
}


def _source_options(parser: Parser) -> None:
    parser.add_argument("--preset", default=None, help=f"a mechanism preset: {', '.join(MECHANISM_PRESETS)}")
    parser.add_argument("--mechanism", default=None, metavar="FILE", help="a mechanism file, .toml or .json")
    parser.add_argument("--set", action="append", metavar="NAME=VALUE",
                        help="g, BODY.mass, BODY.inertia, JOINT.damping, JOINT.speed or JOINT.torque (a motor's)")


def _parse(parser: Parser, argv: list[str], applies: str):
    """Arguments; an option of the chain commands that does not apply here is named in one line."""
    args, rest = parser.parse_known_args(argv)
    for item in rest:
        option = item.split("=", 1)[0]
        if option in CHAIN_ONLY:
            raise LinkageError(f"{option}: does not apply to a mechanism ({CHAIN_ONLY[option]}); {applies}")
    if rest:
        parser.error(f"unrecognized arguments: {' '.join(rest)}")
    return args


def load(args) -> Mechanism:
    """The mechanism of ``--preset NAME`` or ``--mechanism FILE``, with ``--set`` applied."""
    if (args.preset is None) == (args.mechanism is None):
        raise LinkageError("give one of --preset NAME (a mechanism preset) or --mechanism FILE"
                           + (", not both" if args.preset is not None else ""))
    if args.mechanism is not None:
        if not args.mechanism.strip():
            raise LinkageError("--mechanism: give a mechanism file (.toml or .json)")
        mechanism = load_mechanism(args.mechanism)
    elif args.preset in MECHANISM_PRESETS:
        mechanism = MECHANISM_PRESETS[args.preset]()
    else:
        raise LinkageError(f"--preset {args.preset!r}: not a mechanism preset ({', '.join(MECHANISM_PRESETS)})")
    return with_settings(mechanism, parse_set(args.set))


SETTABLE = ("mass", "inertia", "damping", "speed", "torque")


def with_settings(mechanism: Mechanism, overrides: dict[str, str]) -> Mechanism:
    """``--set`` on a mechanism: ``g``, ``BODY.mass``, ``BODY.inertia``, ``JOINT.damping`` (pins and sliders),
    ``JOINT.speed`` / ``JOINT.torque`` (the motor on that joint, added or turned into that kind). Checked by the
    mechanism's own model, so a value out of range is refused as a file's would be."""
    if not overrides:
        return mechanism
    document = mechanism.model_dump(mode="json", exclude_none=True)
    bodies = {body["name"]: body for body in document["bodies"]}
    joints = {joint["name"]: joint for joint in document["joints"]}
    for name, text in overrides.items():
        value = _number(name, text)
        if name == "g":
            document["g"] = value
            continue
        owner, _, what = name.rpartition(".")
        if what in ("mass", "inertia") and owner in bodies:
            bodies[owner][what] = value
        elif what in ("damping", "ratio", "offset") and what in joints.get(owner, {}):  # a gear's ratio, offset
            joints[owner][what] = value
        elif what in ("speed", "torque") and owner in joints:
            drivers = [driver for driver in document.get("drivers", []) if driver["joint"] != owner]
            document["drivers"] = [*drivers, {"joint": owner, what: value}]
        else:
            raise LinkageError(
                f"--set {name}={text}: names g, BODY.{{mass,inertia}}, JOINT.{{damping,speed,torque}} or GEAR.{{ratio,offset}} (bodies: "
                f"{', '.join(bodies)}; joints: {', '.join(joints)})")
    return mechanism_from_document(document, source="--set")


def _number(name: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise LinkageError(f"--set {name}={text}: expected a number") from None
    if not math.isfinite(value):
        raise LinkageError(f"--set {name}={text}: expected a finite number")
    return value


# --- simulate ---------------------------------------------------------------------------------------------

SIMULATE_APPLIES = ("a mechanism's run takes --t-end, --samples, --method, --stabilization, --rtol, --atol, "
                    "--integrator, --step, --max-steps, --backend, --set, --out, --format, --json")


def simulate_main(argv: list[str]) -> int:
    """``simulate --preset MECHANISM | --mechanism FILE``: the run of the ``mechanism`` command, with the chain
    command's options that apply. The table goes to ``--out`` (then a summary is printed, text or ``--json``) or
    to stdout."""
    parser = Parser(prog="python -m physics simulate", description="simulate a mechanism preset or file")
    _source_options(parser)
    parser.add_argument("--t-end", type=float, default=DEFAULT_T_END, help="seconds to simulate (default 2)")
    parser.add_argument("--samples", type=int, default=201)
    parser.add_argument("--method", default="dae", help=f"the formulation integrated: {', '.join(RUN_METHODS)}")
    parser.add_argument("--stabilization", default="projection", help="none, baumgarte or projection")
    integrator_options(parser)
    parser.add_argument("--rtol", type=float, default=1e-10)
    parser.add_argument("--atol", type=float, default=1e-10)
    parser.add_argument("--out", default=None, help="write the table to this file (CSV, or JSON if it ends in .json)")
    parser.add_argument("--format", default=None, choices=("csv", "json"))
    parser.add_argument("--json", action="store_true", help="print the mechanism command's summary as JSON")
    args = _parse(parser, argv, SIMULATE_APPLIES)
    fmt = args.format or ("json" if args.out and args.out.endswith(".json") else "csv")
    request = RunRequest(t_end=args.t_end, samples=args.samples, method=args.method,
                         stabilization=args.stabilization, rtol=args.rtol, atol=args.atol, out=args.out, fmt=fmt,
                         **integrator_request(args))
    request.check()
    mechanism = load(args)
    return run_and_report(mechanism, request, simulate=True, as_json=args.json,
                          table_to_stdout=not args.out and not args.json)


# --- accelerations ----------------------------------------------------------------------------------------

def accelerations_main(argv: list[str]) -> int:
    """``accelerations --preset MECHANISM | --mechanism FILE [--state Q,QDOT] [--method M,...] [--time T]``:
    JSON of the accelerations in maximal coordinates and every reaction row of each method asked, at the given
    state (default: the start of a run), with their largest disagreement."""
    parser = Parser(prog="python -m physics accelerations",
                    description="accelerations and every reaction of a mechanism at one state (JSON)")
    _source_options(parser)
    parser.add_argument("--state", default=None, metavar="Q..,QDOT..",
                        help="x, y, phi of every body's centre of mass, then their rates (6 per body)")
    parser.add_argument("--method", default=",".join(STATE_METHODS),
                        help=f"comma-separated, of {', '.join(STATE_METHODS)} (default: all three)")
    parser.add_argument("--time", type=float, default=0.0, help="the instant of the state (a speed motor's angle)")
    args = _parse(parser, argv, "a mechanism's accelerations take --state, --method, --time, --set")
    methods = [item.strip() for item in args.method.split(",") if item.strip()]
    for method in methods or [""]:
        if method not in STATE_METHODS:
            raise LinkageError(f"--method {method!r}: allowed {', '.join(STATE_METHODS)}, comma-separated (the "
                               "reduced model's accelerations are its runs': simulate --method reduced)")
    if not (math.isfinite(args.time) and abs(args.time) <= 1e6):
        raise LinkageError(f"--time = {args.time}: allowed range -1e6 <= time <= 1e6 s")
    mechanism = load(args)
    size = 3 * len(mechanism.bodies)
    if args.state is None:
        q, qdot = start_state(mechanism, args.time)
    else:
        values = parse_floats(args.state, "--state", 2 * size)
        q, qdot = np.array(values[:size]), np.array(values[size:])
        check_state(mechanism, q, qdot, args.time, "--state")
    instants = {method: evaluate(mechanism, q, qdot, method, args.time) for method in dict.fromkeys(methods)}
    first = next(iter(instants.values()))
    document = {
        "mechanism": mechanism.name, "time": args.time, "bodies": [body.name for body in mechanism.bodies],
        "q": q.tolist(), "qdot": qdot.tolist(),
        "methods": {method: {"qddot": instant.qddot.tolist(),
                             "reactions": {f"lambda[{name}]": float(value)
                                           for name, value in zip(instant.row_names, instant.reactions)}}
                    for method, instant in instants.items()},
        # the largest difference from the first method asked, relative to 1 + its largest value
        "disagreement": {"qddot": max(_relative(i.qddot, first.qddot) for i in instants.values()),
                         "reactions": max(_relative(i.reactions, first.reactions) for i in instants.values())},
    }
    print(json.dumps(document))
    return 0


def _relative(mine: np.ndarray, theirs: np.ndarray) -> float:
    if not theirs.size:
        return 0.0
    return float(np.max(np.abs(mine - theirs)) / (1.0 + np.max(np.abs(theirs))))


def _state_at(mechanism: Mechanism, time_s: float, method: str) -> tuple[np.ndarray, np.ndarray]:
    """The state of a run from the start at ``time_s`` (the start itself at 0)."""
    if time_s == 0.0:
        return start_state(mechanism)
    from .simulate import simulate_mechanism  # noqa: PLC0415

    run = simulate_mechanism(mechanism, time_s, 2, method=method if METHODS[method].reduced else "dae")
    if not run.success:  # the run to --time stopped before it: nothing to draw there
        raise LinkageError(f"--time = {time_s:g}: {run.message}")
    return run.q[-1], run.qdot[-1]


# --- fbd --------------------------------------------------------------------------------------------------

def fbd_main(argv: list[str]) -> int:
    """``fbd --preset MECHANISM | --mechanism FILE --body NAME [--time T] [--method M] [--json] [--out F.svg]``:
    the loads on one body at one instant of a run, and the balance they must strike (text, JSON or a drawing)."""
    parser = Parser(prog="python -m physics fbd", description="forces on one body of a mechanism at one instant")
    _source_options(parser)
    parser.add_argument("--body", required=True, help="the body's name (as in the mechanism)")
    parser.add_argument("--time", type=float, default=0.0, help=f"instant of the run, 0..{MAX_FBD_TIME:g} s")
    parser.add_argument("--method", default="dae", help=f"whose reactions: {', '.join(STATE_METHODS)}")
    parser.add_argument("--json", action="store_true", help="print the loads and the balance as JSON")
    parser.add_argument("--out", default=None, help="draw the diagram into this SVG file")
    args = _parse(parser, argv, "a mechanism's fbd takes --body, --time, --method, --set, --json, --out")
    if args.out is not None:
        check_output_path(args.out, suffixes=(".svg",))
    if not (math.isfinite(args.time) and 0.0 <= args.time <= MAX_FBD_TIME):
        raise LinkageError(f"--time = {args.time}: allowed range 0 <= time <= {MAX_FBD_TIME:g} s")
    if args.method not in STATE_METHODS:
        raise LinkageError(f"--method {args.method!r}: allowed {', '.join(STATE_METHODS)}")
    mechanism = load(args)
    from .validation import check_runnable  # noqa: PLC0415

    check_runnable(mechanism)  # the run to --time is a run like simulate's: the same check first
    if args.body not in [body.name for body in mechanism.bodies]:
        names = ", ".join(body.name for body in mechanism.bodies)
        raise LinkageError(f"--body {args.body!r}: no body of that name (bodies: {names})")
    q, qdot = _state_at(mechanism, args.time, args.method)
    body = free_body(mechanism, evaluate(mechanism, q, qdot, args.method, args.time), args.body)
    document = body.as_dict()
    if args.out:
        from .fbd_drawing import fbd_svg  # noqa: PLC0415

        write_output(args.out, fbd_svg(mechanism, q, body).encode("utf-8"))
    if args.json:
        print(json.dumps({"mechanism": mechanism.name, **document}))
        return 0
    if args.out:
        return 0
    print(f"{mechanism.name}, body {body.body} at t = {body.time:g} s ({body.method}; angle "
          f"{math.degrees(body.angle):.3f} deg from the sketch):")
    for load_ in body.loads:
        where = f"at ({load_.at[0]: .6g}, {load_.at[1]: .6g})" if load_.at is not None else "couple"
        print(f"  {load_.name:<34} F = ({load_.force[0]: .6g}, {load_.force[1]: .6g})  M_G = {load_.moment: .6g}  "
              f"{where}")
    balance = document["balance"]
    print(f"  sum F = ({balance['net_force'][0]:.6g}, {balance['net_force'][1]:.6g}); m a_G = "
          f"({balance['m_a'][0]:.6g}, {balance['m_a'][1]:.6g})")
    print(f"  sum M about G = {balance['net_moment_about_com']:.6g}; I alpha = {balance['I_alpha']:.6g}")
    return 0


# --- equilibrium ------------------------------------------------------------------------------------------

def equilibrium_main(argv: list[str]) -> int:
    """``equilibrium --preset MECHANISM | --mechanism FILE [--json]``: the rest poses of a mechanism that has a
    free motion, stable or not, lowest potential first."""
    parser = Parser(prog="python -m physics equilibrium", description="rest poses of a mechanism, and their stability")
    _source_options(parser)
    parser.add_argument("--json", action="store_true", help="print as JSON")
    args = _parse(parser, argv, "a mechanism's equilibrium takes --set and --json")
    mechanism = load(args)
    poses = rest_poses(mechanism)
    if args.json:
        print(json.dumps({"mechanism": mechanism.name, "rest_poses": [pose.as_dict(mechanism) for pose in poses]}))
        return 0
    print(f"{mechanism.name}: {len(poses)} rest poses, lowest potential energy first (body angles from the sketch)")
    names = [body.name for body in mechanism.bodies]
    print("  " + "  ".join(f"{name[:12]:>12}" for name in names) + f"  {'stable':>6}  {'V':>12}")
    for pose in poses:
        angles = "  ".join(f"{math.degrees(v):12.4f}" for v in pose.q[2::3])
        stable = "yes" if pose.stable else "flat" if pose.neutral else "no"
        print(f"  {angles}  {stable:>6}  {pose.potential:12.6f}")
    return 0


# --- ensemble ---------------------------------------------------------------------------------------------

ENSEMBLE_SUFFIXES = (".json", ".csv", ".png")  # as the chain ensemble's --out
MAX_ENSEMBLE_SECONDS = 1800.0  # an ensemble estimated (from its first copy) longer than this is stopped


def ensemble_main(argv: list[str]) -> int:
    """``ensemble --preset MECHANISM | --mechanism FILE``: ``--count`` copies, copy k with every body turned
    ``k * spread`` rad further and closed again, each a run of the general engine
    (:class:`physics.ensemble.MechanismEnsemble`); the chain ensemble's JSON keys with the mechanism's, its
    time series as CSV, or a PNG of the copies at the end."""
    from ..ensemble import MechanismEnsemble  # noqa: PLC0415

    parser = Parser(prog="python -m physics ensemble", description="copies of a mechanism a little apart, run together")
    _source_options(parser)
    parser.add_argument("--count", type=int, default=20, help="number of copies (1..1000; each is a whole run)")
    parser.add_argument("--spread", type=float, default=1e-9, help="radians every body turns between copies")
    parser.add_argument("--t-end", type=float, default=DEFAULT_T_END, help="seconds to simulate (default 2)")
    parser.add_argument("--samples", type=int, default=101, help="rows of the time series")
    parser.add_argument("--method", default="dae", help=f"the formulation integrated: {', '.join(RUN_METHODS)}")
    parser.add_argument("--stabilization", default="projection", help="none, baumgarte or projection")
    parser.add_argument("--rtol", type=float, default=1e-10)
    parser.add_argument("--atol", type=float, default=1e-10)
    integrator_options(parser)
    parser.add_argument("--out", default=None, help="file: .json, .csv (time series) or .png (the copies at the end)")
    args = _parse(parser, argv, "a mechanism's ensemble takes --count, --spread, --t-end, --samples, --method, "
                  "--stabilization, --rtol, --atol, --integrator, --step, --max-steps, --backend, --set, --out")
    if not 2 <= args.samples <= 100_000:
        raise LinkageError(f"--samples = {args.samples}: allowed range 2 <= samples <= 100000")
    if args.out is not None:
        check_output_path(args.out, suffixes=ENSEMBLE_SUFFIXES)
    mechanism = load(args)
    from .validation import check_runnable  # noqa: PLC0415

    check_runnable(mechanism)
    ensemble = MechanismEnsemble(mechanism, count=args.count, spread=args.spread, t_end=args.t_end,
                                 samples=args.samples, method=args.method, stabilization=args.stabilization,
                                 rtol=args.rtol, atol=args.atol, **integrator_request(args))
    clock = time.perf_counter()

    def estimate(k: int) -> None:
        if k == 0 and (elapsed := time.perf_counter() - clock) * ensemble.count > MAX_ENSEMBLE_SECONDS:
            raise LinkageError(
                f"--count {ensemble.count}: the first copy took {elapsed:.3g} s, so the ensemble would take about "
                f"{elapsed * ensemble.count / 60:.3g} min, more than the {MAX_ENSEMBLE_SECONDS / 60:g} min allowed; "
                "fewer copies or a shorter --t-end")

    ensemble.run(progress=estimate)

    def picture() -> bytes:
        from ..studies.charts import fan_picture, png_bytes  # noqa: PLC0415

        return png_bytes(fan_picture(ensemble.outlines(), ensemble.alive))

    return write_ensemble(args.out, ensemble.document(), ensemble.columns(), picture, bool(ensemble.alive.all()),
                          ensemble.message)


# --- warm -------------------------------------------------------------------------------------------------

def warm_main(argv: list[str]) -> int:
    """``warm --preset MECHANISM | --mechanism FILE``: derive and compile the mechanism's three formulations
    (the DAE's augmented system, Lagrange and Newton–Euler on its spanning tree) by a short integrated run of
    each, printing how long each took and whether its code was already cached (the engine keeps it on disk per
    structure, so a warmed structure starts warm with any numbers)."""
    parser = Parser(prog="python -m physics warm", description="derive and compile a mechanism's formulations")
    _source_options(parser)
    args = _parse(parser, argv, "a mechanism's warm takes --preset or --mechanism, and --set")
    mechanism = load(args)
    from .engine import is_compiled  # noqa: PLC0415
    from .simulate import simulate_mechanism  # noqa: PLC0415
    from .validation import check_runnable  # noqa: PLC0415

    check_runnable(mechanism)
    for method in STATE_METHODS:
        start = time.perf_counter()
        cached = is_compiled(mechanism, method)
        simulate_mechanism(mechanism, 1e-3, 2, method=method, integrate=True)
        print(f"{method} {mechanism.name}: {time.perf_counter() - start:.2f} s ({'cached' if cached else 'derived'})",
              flush=True)
    # a mechanism its motors fully drive runs by position analysis, not by an integrator: one short run of that
    # kind compiles (or loads) the driven sequence's machine code too (physics.codegen.native_states), so the
    # first real run after a warm compiles nothing
    run = simulate_mechanism(mechanism, 1e-2, 3)
    if not run.integrated:
        print(f"position analysis {mechanism.name}: ready", flush=True)
    return 0


COMMANDS = {"simulate": simulate_main, "accelerations": accelerations_main, "fbd": fbd_main,
            "equilibrium": equilibrium_main, "warm": warm_main, "ensemble": ensemble_main}
"""The chain commands that take a mechanism, by name (physics.cli dispatches to them)."""


def main(command: str, argv: list[str]) -> int:
    return COMMANDS[command](argv)
