"""``simulate``: one entry point from a validated chain, start state and settings to a Trajectory.

A chain runs on the engine that runs every mechanism (issue 24, "one pipeline"): the request is checked here
(a valid start that closes the loop, an output that fits), then the chain written as a mechanism is integrated
and sampled by :mod:`physics.simulate.mechanism_route` (its text says what maps to what). Failures midway come back as ``status``/``message`` with the samples computed so far; only bad input
raises.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import LinkageError
from ..kernels.constants import SINGULAR_PIVOT_RATIO
from ..kinematics import joint_positions
from ..model import MAX_ANGLE, MAX_ANGULAR_SPEED, Chain, Settings, check_state
from ..status import Status
from .trajectory import Trajectory

__all__ = ["SINGULAR_PIVOT_RATIO", "check_assembled", "simulate", "status_message"]
# The start of a closed chain must close the loop to this distance (a user typing angles by hand will not;
# presets and the app assemble them with physics.loop_closure).
ASSEMBLY_TOLERANCE = 1e-8

_routes: list = []  # the route's run function, once imported


def _route():
    """:func:`physics.simulate.mechanism_route.simulate_on_mechanism`, imported at the first run (the route's
    modules are not loaded by ``import physics``) and kept, so a run pays no import statement."""
    if not _routes:
        from .mechanism_route import simulate_on_mechanism  # noqa: PLC0415

        _routes.append(simulate_on_mechanism)
    return _routes[0]


def status_message(status: int, t: float, detail: str = "") -> str:
    """The sentence for a run's status at time ``t`` (physics.status.Status)."""
    return Status.describe(status, t, detail)




def _start_state(n: int, theta0, omega0) -> tuple[np.ndarray, np.ndarray]:
    """``(theta0, omega0)`` of a valid start, float arrays of shape ``(n,)`` (the run copies them into its own
    buffer before it starts). Arrays of the right shape and every entry within range (so finite) pass as they
    are, with one comparison each; anything else goes through :func:`physics.model.check_state`, which converts
    lists and names the first bad entry."""
    if (type(theta0) is np.ndarray and type(omega0) is np.ndarray and theta0.shape == (n,)
            and omega0.shape == (n,) and theta0.dtype == np.float64 and omega0.dtype == np.float64):
        if n <= FEW_LINKS:  # a few floats compare faster in Python than through numpy calls
            # plain loops, no generator: about 1 us less a run than all() over two generators (seed case C)
            for value in theta0.tolist():
                if not -MAX_ANGLE <= value <= MAX_ANGLE:  # True for NaN and infinities
                    break
            else:
                for value in omega0.tolist():
                    if not -MAX_ANGULAR_SPEED <= value <= MAX_ANGULAR_SPEED:
                        break
                else:
                    return theta0, omega0
        elif (np.abs(theta0) <= MAX_ANGLE).all() and (np.abs(omega0) <= MAX_ANGULAR_SPEED).all():
            return theta0, omega0  # (False for NaN and infinities too)
    return check_state(n, theta0, omega0)


FEW_LINKS = 8


def check_assembled(chain: Chain, theta: np.ndarray) -> None:
    """A closed chain must start on its loop; say by how much it misses."""
    if chain.pin is None:
        return
    tip = joint_positions(chain.array("L"), theta)[-1]
    gap = float(np.hypot(tip[0] - chain.pin[0], tip[1] - chain.pin[1]))
    if not gap <= ASSEMBLY_TOLERANCE:
        raise LinkageError(
            f"the start does not close the loop: the tip is {gap:.3g} from the pin {tuple(chain.pin)} "
            f"(allowed {ASSEMBLY_TOLERANCE:g}); assemble it with physics.loop_closure.assemble or set the pin to the tip"
        )


# A trajectory holds about 8n + 14 float64 columns per sample (angles, velocities, joints, energies, the
# DAE's reactions, every method's joint reactions, pin reaction and constraint residuals): past this many values (400 MB) a request does not fit a run of this tool, and is refused up front.
MAX_OUTPUT_VALUES = 50_000_000


def check_output_size(n: int, samples: int) -> None:
    """Refuse, before any allocation, a trajectory too large to hold: one line with the estimate and the limit."""
    values = samples * (8 * n + 14)
    if values > MAX_OUTPUT_VALUES:
        raise LinkageError(
            f"samples = {samples}: a {n}-bar trajectory of that many samples holds about {values * 8 / 1e9:.2g} GB "
            f"(limit {MAX_OUTPUT_VALUES * 8 / 1e9:.2g} GB); allowed samples <= {MAX_OUTPUT_VALUES // (8 * n + 14)}"
        )


def simulate(
    chain: Chain, theta0, omega0, settings: Settings | None = None, t_start: float = 0.0, *, continuing: bool = False
) -> Trajectory:
    """Integrate from ``(theta0, omega0)`` at ``t_start`` over ``settings.t_end`` seconds.

    Returns a :class:`Trajectory` sampled at ``settings.samples`` equally spaced times (both ends included).
    Raises :class:`LinkageError` only for invalid input; a failure midway is reported in ``status``.
    ``continuing=True``: the start is the last sample of an earlier run of the same chain (chunked
    integration, as the app does); its constraint drift belongs to that run and is not re-checked.
    """
    settings = settings or Settings()
    n = chain.n
    theta0, omega0 = _start_state(n, theta0, omega0)
    check_output_size(n, settings.samples)
    if not math.isfinite(t_start):
        raise LinkageError(f"t_start = {t_start}: must be a finite number")
    if not continuing:
        check_assembled(chain, theta0)
    return _route()(chain, theta0, omega0, settings, t_start)
