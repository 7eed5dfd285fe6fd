"""``python -m physics mechanism``: check, assemble and simulate any planar mechanism from a preset or a file.

    python -m physics mechanism --preset jansen-leg                 # topology, mobility and motors, loops
    python -m physics mechanism --file my.toml --json               # the same as JSON
    python -m physics mechanism --preset crank-rocker --t-end 2 --samples 201 --out run.csv
    python -m physics mechanism --preset slider-crank --t-end 2 --method lagrange --stabilization baumgarte

With ``--out`` (or ``--t-end``) the mechanism is simulated (``--method``: the maximal-coordinate DAE, the
default, or Lagrange or Newton–Euler on a spanning tree, or ``reduced``: one joint coordinate with
coordinate switching, for mobility 1; ``--stabilization``: projection, the default, Baumgarte or none;
``--integrator``, ``--step``, ``--max-steps``, ``--backend`` as for a chain, default DOP853) and a CSV of ``t``,
the traced point, the energies, the largest constraint residual and every joint reaction of that formulation is
written atomically. A run stopped midway writes what it computed to ``OUT.partial`` and exits 3, as a chain's. Bad input is one line and exit 2 (printed by :mod:`physics.cli`).
"""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass

import numpy as np

from ..arguments import Parser
from ..errors import LinkageError
from ..long_run import simulate_mechanism_in_segments
from ..outputs import EXIT_RUN_STOPPED, check_output_path, check_partial_path, partial_note, write_output
from ..registry import BACKENDS, INTEGRATOR_NAMES, STABILIZATIONS
from ..simulate.trajectory import Trajectory
from .assembly import assemble
from .description import Mechanism
from .files import load_mechanism
from .presets import MECHANISM_PRESETS
from .run_table import run_table  # noqa: F401 - the table's writer, where the app reads it too
from .simulate import RUN_METHODS, run_options
from .singularity import NEAR_SINGULAR_CONDITION
from .validation import check_runnable

MAX_SAMPLES = 100_000


def _mechanism(args) -> Mechanism:
    if (args.preset is None) == (args.file is None):
        raise LinkageError("give one of --preset NAME or --file FILE.toml|.json")
    if args.file is not None:
        return load_mechanism(args.file)
    return MECHANISM_PRESETS[args.preset]()


def summary(mechanism: Mechanism) -> dict:
    """Topology and degrees of freedom of an assembled mechanism (the ``--json`` output without a run)."""
    assembled = assemble(mechanism)
    return {
        "name": mechanism.name,
        "description": mechanism.description,
        "bodies": [body.name for body in mechanism.bodies],
        "joints": [joint.name for joint in mechanism.joints],
        "drivers": [driver.model_dump(exclude_none=True) for driver in mechanism.drivers],
        "loops": [list(loop.joints) for loop in assembled.topology.loops],
        # after the motors (what they leave free; scripts rely on these two) ...
        "grubler_mobility": assembled.grubler_mobility,
        "mobility": assembled.mobility,
        # ... and before them: the linkage's own mobility (the textbook's), and its motors
        "mechanism_mobility": assembled.mechanism_mobility,
        "grubler_mechanism_mobility": assembled.grubler_mechanism_mobility,
        "motors": len(mechanism.drivers),
        "speed_motors": assembled.speed_motors,
        "mobility_text": assembled.mobility_text(),
        "assembly_residual": assembled.residual,
        "newton_steps": assembled.newton_steps,
    }


def run_csv(run: Trajectory) -> bytes:
    return run_table(run, "csv")


def main(argv: list[str]) -> int:
    parser = Parser(prog="python -m physics mechanism",
                     description="check, assemble and simulate a planar mechanism (docs/mechanisms.md)")
    parser.add_argument("--preset", choices=sorted(MECHANISM_PRESETS), default=None)
    parser.add_argument("--file", default=None, help="a mechanism file, .toml or .json")
    parser.add_argument("--json", action="store_true", help="print the topology (and the run's summary) as JSON")
    parser.add_argument("--t-end", type=float, default=None, help="simulate this many seconds (0 < t_end <= 1e4)")
    parser.add_argument("--samples", type=int, default=201, help=f"samples of the run (2..{MAX_SAMPLES})")
    parser.add_argument("--out", default=None, help="write the run as CSV to this file")
    parser.add_argument("--method", default="dae", help=f"the formulation integrated: {', '.join(RUN_METHODS)}")
    parser.add_argument("--stabilization", default="projection",
                        help=f"how the loops are held: {', '.join(STABILIZATIONS)}")
    integrator_options(parser)
    args = parser.parse_args(argv)
    request = RunRequest(t_end=2.0 if args.t_end is None else args.t_end, samples=args.samples, method=args.method,
                         stabilization=args.stabilization, out=args.out, **integrator_request(args))
    request.check()
    mechanism = _mechanism(args)
    return run_and_report(mechanism, request, simulate=bool(args.out) or args.t_end is not None, as_json=args.json)


def integrator_options(parser: Parser) -> None:
    """``--integrator``, ``--step``, ``--max-steps`` and ``--backend`` of a mechanism's run (the chain's names)."""
    parser.add_argument("--integrator", default="DOP853",
                        help=f"{', '.join(INTEGRATOR_NAMES)} (default DOP853; variational needs --method lagrange; "
                             "a mechanism its motors fully drive is not integrated and ignores it)")
    parser.add_argument("--step", type=float, default=None, help="fixed step of midpoint and variational, s "
                                                                  "(default 1e-3)")
    parser.add_argument("--max-steps", type=int, default=None, help="integration steps before the run is stopped")
    parser.add_argument("--backend", default="compiled", help=f"{', '.join(BACKENDS)} (Radau and LSODA: scipy)")


def integrator_request(args) -> dict:
    """The run keywords of :func:`integrator_options`, for :class:`RunRequest`."""
    return {"integrator": args.integrator, "step": args.step, "max_steps": args.max_steps, "backend": args.backend}


@dataclass(frozen=True)
class RunRequest:
    """What a command asks of a run: span, samples, formulation, stabilisation, tolerances, integrator (and its
    fixed step, step budget and back end), and where the table goes (``out``, in ``fmt``: csv or json). Shared by
    ``mechanism`` and ``simulate``."""

    t_end: float = 2.0
    samples: int = 201
    method: str = "dae"
    stabilization: str = "projection"
    rtol: float = 1e-10
    atol: float = 1e-10
    out: str | None = None
    fmt: str = "csv"
    integrator: str = "DOP853"
    step: float | None = None
    max_steps: int | None = None
    backend: str = "compiled"

    def check(self) -> None:
        """Every option in range before any work (one line naming the first bad one)."""
        run_options(t_end=self.t_end, samples=max(self.samples, 2), t_start=0.0, method=self.method,
                    stabilization=self.stabilization, rtol=self.rtol, atol=self.atol, **self.integrator_options())
        if not 2 <= self.samples <= MAX_SAMPLES:
            raise LinkageError(f"--samples {self.samples}: allowed range 2..{MAX_SAMPLES}")

    def integrator_options(self) -> dict:
        return {"integrator": self.integrator, "step": self.step, "max_steps": self.max_steps,
                "backend": self.backend}


def run_and_report(mechanism: Mechanism, request: RunRequest, *, simulate: bool, as_json: bool,
                   table_to_stdout: bool = False) -> int:
    """Check that ``mechanism`` can run, run it when ``simulate``, write its table to ``request.out`` (or to
    stdout when ``table_to_stdout``) and print the summary: JSON (``as_json``) or a few lines of text. Exit code
    0, or 3 when a long run was stopped (what was computed is in ``OUT.partial``)."""
    check_runnable(mechanism)  # assembles through its motion, masses and motors in range (mechanism.validation)
    if request.out is not None:
        check_output_path(request.out)
        check_partial_path(request.out)
    report = summary(mechanism)
    run = None
    if simulate:
        # estimated up front, progress on stderr for a long run, Ctrl+C keeps what was computed (physics.long_run)
        run, interrupted = simulate_mechanism_in_segments(mechanism, request.t_end, request.samples, request.method,
                                                          request.stabilization, rtol=request.rtol,
                                                          atol=request.atol, **request.integrator_options())
        if interrupted:
            partial = f"{request.out}.partial" if request.out else None
            if partial:
                write_output(partial, run_table(run, request.fmt))
            print(f"error: {interrupted}{partial_note(run.t, partial)}", file=sys.stderr)
            return EXIT_RUN_STOPPED
        report["run"] = {
            "t_end": float(run.t[-1]), "samples": len(run.t), "method": run.method,
            "stabilization": run.stabilization,
            "max_constraint_residual": float(np.max(run.residual)),
            "energy_change": float(run.energy[-1] - run.energy[0]),
            # how near the run came to a singular pose (physics/mechanism/singularity.py); null: reduced model
            "max_jacobian_condition": float(np.max(run.condition)) if run.condition.size else None,
            # what produced the samples: the integrator, or "position analysis" when the motors fix every body
            # (then --integrator is accepted and not used), and its accepted steps and right-hand sides
            "integrator": run.integrator, "steps": run.n_steps, "evaluations": run.n_rhs,
        }
        if request.out:
            write_output(request.out, run_table(run, request.fmt))
        elif table_to_stdout:
            sys.stdout.write(run_table(run, request.fmt).decode("utf-8"))
            return 0
    if as_json:
        print(json.dumps(report))
        return 0
    counts = f"{len(report['bodies'])} bodies, {len(report['joints'])} joints"
    print(f"{report['name']}: {counts}; {report['mobility_text']}")
    for loop in report["loops"]:
        print("  loop " + " - ".join(loop))
    if run is not None:
        print(f"  ran {run.t[-1]:g} s ({run.method}, {run.stabilization}, {run.integrator}): constraint residual at most {np.max(run.residual):.2g}, "
              f"energy change {run.energy[-1] - run.energy[0]:.3g} J" + (f"; wrote {request.out}" if request.out else ""))
        if run.condition.size and np.max(run.condition) > NEAR_SINGULAR_CONDITION:
            worst = int(np.argmax(run.condition))
            print(f"  passed near a singular pose at t = {run.t[worst]:.4g} s (Jacobian condition "
                  f"{run.condition[worst]:.2g}): a change point or a dead centre")
    return 0
