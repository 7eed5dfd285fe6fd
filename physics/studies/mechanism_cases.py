"""What every study of a general mechanism shares: which mechanism (a preset or a file), its mobility, the
point whose path a study measures, and one run whose failure comes back as a status instead of an exception.

Why here and not in the core: the studies run a mechanism only through
:func:`physics.mechanism.simulate.simulate_mechanism` and read only its :class:`physics.Trajectory`, so they keep working
whichever engine is under that function. The point a study follows is the ensemble's
(:func:`physics.ensemble.probe_reference`: the traced point, else the last body's last point). A run that stops midway raises ``LinkageError`` today; a study records
it as a failed cell with its message (the chain studies' ``Status``), as a sweep must go on past a failure.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..ensemble import point_path, probe_reference
from ..errors import LinkageError
from ..mechanism.assembly import assemble
from ..mechanism.description import Mechanism
from ..mechanism.files import load_mechanism
from ..mechanism.presets import MECHANISM_PRESETS
from ..mechanism.simulate import simulate_mechanism
from ..mechanism.validation import check_runnable
from ..registry import STABILIZATIONS as STABILIZATIONS  # the one list, re-exported for the studies
from ..simulate.trajectory import Trajectory
from ..status import Status

# The methods of a mechanism's run: the three formulations, and the reduced model where the mobility is 1.
FORMULATIONS = ("newton_euler", "lagrange", "dae")
REDUCED = "reduced"
# The integrators a work-precision sweep of a mechanism runs: the adaptive compiled pairs, as a chain's bench
# (every integrator of the registry runs a mechanism; these are the ones a tolerance sweep compares).
MECHANISM_INTEGRATORS = ("RK45", "DOP853")


def mechanism_names() -> tuple[str, ...]:
    """The mechanism presets, in the table's order."""
    return tuple(MECHANISM_PRESETS)


def load_case(preset: str | None = None, file: str | None = None) -> Mechanism:
    """The mechanism of ``--preset NAME`` or ``--mechanism FILE`` (exactly one), checked to run
    (:func:`physics.mechanism.validation.check_runnable`: the same check as every other door)."""
    if (preset is None) == (file is None):
        raise LinkageError("give one of --preset NAME (a mechanism preset) or --mechanism FILE.toml|.json")
    if file is not None:
        mechanism = load_mechanism(file)
    else:
        if preset not in MECHANISM_PRESETS:
            raise LinkageError(f"--preset {preset!r}: not a mechanism preset; allowed {', '.join(MECHANISM_PRESETS)}")
        mechanism = MECHANISM_PRESETS[preset]()
    check_runnable(mechanism)
    return mechanism


def mobility(mechanism: Mechanism) -> int:
    """Degrees of freedom the motors leave free (rank count at the assembled sketch)."""
    return assemble(mechanism).mobility


def methods_for(mechanism: Mechanism, formulations=FORMULATIONS) -> tuple[str, ...]:
    """``formulations``, with the reduced model where the mechanism has exactly one free coordinate."""
    return tuple(formulations) + ((REDUCED,) if mobility(mechanism) == 1 else ())


@dataclass
class Outcome:
    """One run of a study: the run (None when it stopped), its status and message (the engine's sentence),
    wall time, and the probe's path. ``success``, ``status``, ``message``, ``n_rhs``, ``tip_xy`` are what the
    work-precision points read from a chain's Trajectory."""

    run: Trajectory | None
    status: Status
    message: str
    seconds: float
    tip_xy: np.ndarray

    @property
    def success(self) -> bool:
        return self.status == Status.OK

    @property
    def n_rhs(self) -> int | None:
        return None if self.run is None else int(self.run.n_rhs)


def failure_status(message: str) -> Status:
    """The chain studies' status for a mechanism run's failure sentence."""
    return Status.SINGULAR if "singular" in message else Status.INTEGRATOR_FAILED


def run_case(mechanism: Mechanism, t_end: float, samples: int, *, probe: str | None = None, **options) -> Outcome:
    """:func:`simulate_mechanism` with ``options`` (method, stabilization, rtol, atol, q0, qdot0, integrator),
    timed; a run stopped midway (its status) or refused at its start (LinkageError) is a failed Outcome."""
    probe = probe or probe_reference(mechanism)
    start = time.perf_counter()
    try:
        run = simulate_mechanism(mechanism, t_end, samples, **options)
    except LinkageError as error:
        return Outcome(None, failure_status(str(error)), str(error), time.perf_counter() - start, np.zeros((0, 2)))
    except np.linalg.LinAlgError as error:  # an engine's linear algebra giving up (a pose gone non-finite) is a
        # failed cell of the sweep, named as what it is, not the end of the study
        message = f"the engine's linear algebra failed ({type(error).__name__}: {error}), not a LinkageError"
        return Outcome(None, Status.SINGULAR, message, time.perf_counter() - start, np.zeros((0, 2)))
    seconds = time.perf_counter() - start
    status = int(getattr(run, "status", Status.OK))  # an engine that keeps a stopped run's samples says so here
    if status != Status.OK:
        message = str(getattr(run, "message", "")) or Status.describe(status, float(run.t[-1]) if run.t.size else 0.0)
        return Outcome(None, failure_status(message), message, seconds, point_path(mechanism, run.q, probe))
    return Outcome(run, Status.OK, "ok", seconds, point_path(mechanism, run.q, probe))
