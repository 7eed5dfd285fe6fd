"""The reduced model of a one-degree-of-freedom mechanism: one joint coordinate integrated as one ODE, with
coordinate switching at its dead centres.

The maximal-coordinate DAE (:mod:`physics.mechanism.numeric_dae`) integrates ``3 B`` positions and velocities and
projects them back onto the constraints. A mechanism of mobility 1 needs only one coordinate ``s``: a pin's
relative angle or a slider's travel (:mod:`physics.mechanism.joint_coordinates`). Every other position comes
from position analysis, so the constraints hold to rounding by construction, and the equation of motion is the
scalar ``(B^T M B) sddot = B^T (Q - M a0)`` (:mod:`physics.mechanism.reduced_partition`), integrated by scipy's
DOP853 in ``(s, sdot)``.

**Which coordinate.** Along the motion every joint moves at a rate proportional to ``sdot``; counting an angle's
rate times the mechanism's size as a speed, the coordinate's *share* is its speed divided by the fastest
joint's. With the share ``kappa``, no dependent joint moves faster than ``1 / kappa`` times the coordinate
(the velocity transformation is that well conditioned), and ``kappa = 0`` is a dead centre: the coordinate
stands still while the mechanism moves, the bordered Jacobian is singular and the dependent positions are not
functions of it (two branches meet). The run starts in the fastest joint (share 1) unless told otherwise, and an
integrator event switches when the share falls below :data:`SWITCH_SHARE` (or a caller's ``switch_share``:
:func:`reduced_run`): the new coordinate is the fastest
joint at that instant, its value and rate are read off the exact state (nothing is integrated across the
switch), and the switch is recorded. With ``switching=False`` the coordinate is kept and the run is refused
when its share falls below :data:`DEAD_CENTRE_SHARE`, naming the joint and the time.

A mechanism its motors fully determine (0 free) has no free coordinate; it is refused, and
:func:`physics.mechanism.simulate.simulate_mechanism` moves it by kinematics alone. Mobility 2 or more needs
more than one coordinate and is refused as well. Where the constraints themselves become dependent (a change
point: every link of a four-bar in line) no joint is a valid coordinate: each segment's start is checked, and
the run stops there as the DAE's does (:mod:`physics.mechanism.singularity`).

A chain's methods ``"reduced"`` and ``"reduced_fixed"`` are this model too, on the chain written as a mechanism
(:mod:`physics.simulate.reduced_adapter`), through :func:`reduced_run`, which takes sample times its caller has
already checked.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import LinkageError
from ..simulate.trajectory import Trajectory
from ..status import Status
from .assembly import assemble, mobility_text_for, sketch_size
from .description import Mechanism
from .joint_coordinates import JointCoordinates
from .numeric_dae import MechanismDAE
from .reduced_engine import reduced_engine
from .reduced_partition import Partition, ReducedState
from .reduced_samples import Samples, collect_segment
from .run_settings import run_options
from .run_table import state_vector
from .singularity import NEAR_SINGULAR_CONDITION, jacobian_condition, singular_message

# Switch when the coordinate's speed share falls below this: the dependent joints then move up to 10 times
# faster than it. The new coordinate starts at share 1, so switches cannot chatter. A caller may ask for a
# higher share (``switch_share``): an error the integrator allows in the coordinate grows up to 1 / share times
# in the dependent joints, so a higher share buys accuracy at the same tolerance (the chains' four-bar asks for
# 0.4: physics/simulate/reduced_adapter.py).
SWITCH_SHARE = 0.1
# Without switching, a share below this counts as the dead centre itself (the run is refused there).
DEAD_CENTRE_SHARE = 1e-3
# A safety net against a run that switches without end (a mechanism passing a singular pose).
MAX_SWITCHES = 10_000

@dataclass(frozen=True)
class CoordinateSwitch:
    """At time ``t`` the integrated coordinate changed from joint ``from_joint`` (whose share had fallen to
    ``share``) to joint ``to_joint``."""

    t: float
    from_joint: str
    to_joint: str
    share: float


@dataclass(frozen=True)
class DeadCentre:
    """A coordinate kept without switching stood still: joint ``joint`` at time ``t``, its share ``share``."""

    joint: str
    t: float
    share: float


@dataclass(frozen=True)
class ReducedRun:
    """A reduced run: ``run`` has the fields of the DAE's run (its ``n_steps`` and ``n_rhs`` the accepted steps
    and right-hand sides of every segment); ``switches`` every coordinate switch in order; ``coordinate`` the
    joint integrated at each sample; ``dead_centre`` where a run without switching stopped (None otherwise), so a
    caller can word the stop in its own terms (a chain's theta1)."""

    run: Trajectory
    switches: tuple[CoordinateSwitch, ...]
    coordinate: tuple[str, ...]
    dead_centre: DeadCentre | None = None


class ReducedStop(LinkageError):
    """A reduced run stopped midway: its ``status`` (physics.status.Status) and, at a kept coordinate's dead
    centre, where (``dead_centre``). ``simulate_reduced`` raises it unless asked for the run as a status."""

    def __init__(self, message: str, status: Status, dead_centre: DeadCentre | None = None) -> None:
        super().__init__(message)
        self.status = int(status)
        self.dead_centre = dead_centre


@dataclass
class _Counts:
    """What the segments integrated so far took, as scipy reports each: accepted steps and right-hand sides."""

    steps: int = 0
    evaluations: int = 0

    def add(self, solution) -> None:
        self.steps += len(solution.t) - 1  # without t_eval, solution.t is the start and every accepted step
        self.evaluations += int(solution.nfev)


def simulate_reduced(
    mechanism: Mechanism,
    t_end: float,
    samples: int,
    *,
    q0: np.ndarray | None = None,
    qdot0: np.ndarray | None = None,
    t_start: float = 0.0,
    rtol: float = 1e-10,
    atol: float = 1e-10,
    coordinate: str | None = None,
    switching: bool = True,
    stop_as_status: bool = False,
) -> ReducedRun:
    """Integrate a mobility-1 mechanism for ``t_end`` s from ``t_start``, from the assembled sketch (or ``q0``)
    at rest (or the consistent velocity nearest ``qdot0`` in kinetic energy, as the DAE run projects it).
    ``coordinate``: the joint to start in (default: the fastest); ``switching=False`` keeps it throughout.
    Samples are ``samples`` equally spaced times from ``t_start`` to ``t_start + t_end``. A run that stops midway
    (a dead centre, too many switches, the integration or a position analysis failing) raises LinkageError;
    with ``stop_as_status`` it returns the samples recorded before the segment that stopped, the run's
    ``status`` and ``message`` saying why (:func:`physics.mechanism.simulate.simulate_mechanism` asks for this)."""
    settings = run_options(t_end=t_end, samples=samples, t_start=t_start, method="reduced", rtol=rtol, atol=atol)
    times = float(t_start) + np.linspace(0.0, settings.t_end, settings.samples)
    return reduced_run(mechanism, times, rtol=settings.rtol, atol=settings.atol, q0=q0, qdot0=qdot0,
                       coordinate=coordinate, switching=switching, stop_as_status=stop_as_status)


def reduced_run(mechanism: Mechanism, times: np.ndarray, *, rtol: float, atol: float, q0: np.ndarray | None = None,
                qdot0: np.ndarray | None = None, coordinate: str | None = None, switching: bool = True,
                stop_as_status: bool = False, switch_share: float | None = None) -> ReducedRun:
    """:func:`simulate_reduced` at the sample times ``times`` (increasing, the first the start time) and
    tolerances its caller has checked (a chain's ``Settings``, whose spans differ from a mechanism's), switching
    when the coordinate's share falls below ``switch_share`` (default :data:`SWITCH_SHARE`)."""
    switch_share = SWITCH_SHARE if switch_share is None else float(switch_share)
    if not DEAD_CENTRE_SHARE < switch_share < 1.0:
        raise LinkageError(f"switch_share = {switch_share}: allowed range {DEAD_CENTRE_SHARE:g} < switch_share < 1")
    dae = MechanismDAE(mechanism)
    size = dae.constraints.size
    q_start = state_vector(q0, "q0", size)
    qdot_start = state_vector(qdot0, "qdot0", size)
    times = np.asarray(times, dtype=float)
    assembled = assemble(mechanism, q_start, float(times[0]))
    if assembled.mobility != 1:
        raise LinkageError(_mobility_refusal(mechanism, assembled.mobility))
    coordinates = JointCoordinates(mechanism, dae.constraints)
    if coordinate is not None and coordinate not in coordinates.names:
        raise LinkageError(f"coordinate = {coordinate!r}: no joint of that name (joints: {', '.join(coordinates.names)})")
    length = sketch_size(mechanism)
    q = assembled.q
    t = float(times[0])
    if coordinate is None:
        which = _fastest_joint(coordinates, dae, q)
    else:
        which = coordinates.index(coordinate)
    engine = reduced_engine(dae)
    partition = Partition(dae, coordinates, which, q, t, length, engine)
    at_rest = partition.state(t, coordinates.value(q, which), 0.0)
    qdot = _nearest_velocity(dae, at_rest, qdot_start)
    t_final = float(times[-1])
    collected = Samples(times)
    switches: list[CoordinateSwitch] = []
    counts = _Counts()  # counted as the segments go (kept when one stops)
    try:
        _integrate(mechanism, rtol, atol, dae, coordinates, partition, q, qdot, t, t_final, collected, switches,
                   length, switch_share if switching else None, counts)
    except (LinkageError, np.linalg.LinAlgError) as error:
        if not stop_as_status or not collected.states:
            raise
        run = replace(collected.run(dae, engine), status=getattr(error, "status", int(Status.INTEGRATOR_FAILED)),
                      message=str(error) if isinstance(error, LinkageError)
                      else f"{mechanism.name}: position analysis failed after t = {collected.states[-1].t:.6g} s "
                           f"({error})", n_steps=counts.steps, n_rhs=counts.evaluations)
        return ReducedRun(run=run, switches=tuple(switches), coordinate=tuple(collected.coordinate),
                          dead_centre=getattr(error, "dead_centre", None))
    run = replace(collected.run(dae, engine), n_steps=counts.steps, n_rhs=counts.evaluations)
    return ReducedRun(run=run, switches=tuple(switches), coordinate=tuple(collected.coordinate))


def _integrate(mechanism, rtol, atol, dae, coordinates, partition, q, qdot, t, t_final, collected, switches, length,
               switch_share: float | None, counts: _Counts) -> None:
    """The reduced run's segments, from coordinate switch to switch, into ``collected`` and ``switches``; each
    segment's accepted steps and right-hand sides are added to ``counts`` as soon as it is integrated (a run
    that stops keeps them, the failed segment's included)."""
    switch_now = False  # the last segment ended at the switching event
    while True:
        s, sdot = partition.coordinate_of(q, qdot)
        start = partition.state(t, s, sdot)
        share = partition.share(start)
        condition = jacobian_condition(dae.constraints, q)
        if not condition <= NEAR_SINGULAR_CONDITION:  # no joint is a coordinate where the constraints are dependent
            raise ReducedStop(f"{mechanism.name}: {singular_message(dae.constraints, q, t)}; no joint is a valid "
                              "coordinate there", Status.SINGULAR)
        if switch_share is not None and (switch_now or share < switch_share):
            switch_now = False
            if len(switches) >= MAX_SWITCHES:
                raise ReducedStop(f"{mechanism.name}: more than {MAX_SWITCHES} coordinate switches by t = {t:.6g} s; "
                               "the mechanism is near a singular pose where no joint is a good coordinate",
                               Status.SINGULAR)
            new = Partition(dae, coordinates, int(np.argmax(start.shares)), q, t, length, partition.engine)
            switches.append(CoordinateSwitch(t=t, from_joint=partition.name, to_joint=new.name, share=share))
            partition = new
            continue
        if share < DEAD_CENTRE_SHARE:
            raise ReducedStop(_dead_centre_refusal(partition, t, share), Status.SINGULAR,
                              DeadCentre(partition.name, t, share))
        if t >= t_final:
            collected.add(start, partition.name)
            break
        event = _share_event(partition, DEAD_CENTRE_SHARE if switch_share is None else switch_share)
        # scipy boundary: the reduced model integrates with scipy, imported only when it runs.
        from scipy.integrate import solve_ivp  # noqa: PLC0415

        solution = solve_ivp(partition.rhs, (t, t_final), [s, sdot], method="DOP853", rtol=rtol, atol=atol,
                             events=[event], dense_output=True)
        counts.add(solution)
        if solution.status == -1:
            raise ReducedStop(f"{mechanism.name}: the reduced integration failed after t = {t:.6g} s "
                           f"({solution.message})", Status.INTEGRATOR_FAILED)
        end = collect_segment(collected, partition, solution, start)
        q, qdot, t = end.q, end.qdot, float(solution.t[-1])
        if solution.status == 0:
            collected.add(end, partition.name, last=True)
            break
        if switch_share is None:
            share = partition.share(end)
            raise ReducedStop(_dead_centre_refusal(partition, t, share), Status.SINGULAR,
                              DeadCentre(partition.name, t, share))
        switch_now = True


def fixed_coordinate(mechanism: Mechanism) -> str:
    """The joint whose coordinate ``method = "reduced_fixed"`` keeps throughout: the first joint of the
    description that carries a freedom and no speed motor (a chain's ``O``: its coordinate is theta1, as the
    chain's fixed-coordinate model has always kept). Why the first and not the fastest at the start: the choice
    is then the user's, by the order of the file, and the same from every start, so a run's failure at this
    joint's dead centre can be shown and repeated."""
    speed_driven = {driver.joint for driver in mechanism.drivers if driver.speed is not None}
    names = JointCoordinates(mechanism, MechanismDAE(mechanism).constraints).names
    free = [name for name in names if name not in speed_driven]
    if not free:
        raise LinkageError(f"{mechanism.name}: no joint carries a freedom that a speed motor leaves free; "
                           "the fixed-coordinate reduced model has no coordinate to keep")
    return free[0]


def _mobility_refusal(mechanism: Mechanism, mobility: int) -> str:
    """``mobility`` is what the motors leave free; the message states the mechanism's own mobility first."""
    stated = mobility_text_for(mechanism, mobility)
    if mobility == 0:
        return (f"{mechanism.name}: {stated}: its motors fix every body, so there is no free coordinate to "
                "integrate; the reduced model needs 1 free (simulate_mechanism moves it by kinematics)")
    return (f"{mechanism.name}: {stated}: the reduced model integrates one coordinate and needs 1 free; use the "
            "DAE (simulate_mechanism), or add motors")


def _dead_centre_refusal(partition: Partition, t: float, share: float) -> str:
    return (f"joint {partition.name!r} stopped being a valid coordinate at t = {t:.6g} s: a dead centre (its "
            f"speed share fell to {share:.2g}, limit {DEAD_CENTRE_SHARE:g}); the fixed-coordinate reduced model "
            "cannot continue past it: choose method 'reduced' (switching=True), which switches coordinates")


def _fastest_joint(coordinates: JointCoordinates, dae: MechanismDAE, q: np.ndarray) -> int:
    """The joint with speed share 1 along the null vector of the constraint Jacobian (at a switch, a partition's
    state has every joint's share along its own velocity map: ``ReducedState.shares``)."""
    direction = np.linalg.svd(dae.constraints.jacobian(q))[2][-1]
    return int(np.argmax(coordinates.speed_shares(q, direction)))


def _nearest_velocity(dae: MechanismDAE, at_rest: ReducedState, qdot0: np.ndarray | None) -> np.ndarray:
    """The consistent velocity ``B sdot + D`` nearest ``qdot0`` (default: rest) in the kinetic-energy metric."""
    motor_velocity = at_rest.qdot
    if qdot0 is None:
        qdot0 = np.zeros_like(motor_velocity)
    mass, velocity_map = dae.mass_diagonal, at_rest.velocity_map
    sdot = float(velocity_map @ (mass * (qdot0 - motor_velocity))) / at_rest.generalised_mass
    return velocity_map * sdot + motor_velocity


def _share_event(partition: Partition, limit: float):
    def share_above_limit(t: float, y: np.ndarray) -> float:
        return partition.share(partition.state(t, float(y[0]), float(y[1]))) - limit

    # scipy's solve_ivp reads these attributes off the event function (its documented protocol)
    share_above_limit.terminal = True  # type: ignore[attr-defined]
    share_above_limit.direction = -1  # type: ignore[attr-defined]
    return share_above_limit
