"""Motion of any mechanism: one of its three formulations integrated, its closures held by projection,
Baumgarte terms or nothing.

DOP853 (:mod:`physics.mechanism.stepper`, scipy's steps without a restart at every sample) integrates the
chosen formulation's state (:mod:`physics.mechanism.formulations`): the DAE's ``(q, qdot)`` or a tree
formulation's ``(s, sd)``. With projection (the default, as for the chains) the state is moved back onto the
constraints after every accepted step, so the residual stays at rounding level over any run. Every sample
reports the pose and velocities in maximal coordinates and the chosen formulation's own reactions of every
joint. A mechanism its motors fully determine (mobility 0, like the Jansen leg) needs no integration at all:
each sample is position analysis from the one before, its velocities follow from the constraints, and the
chosen formulation gives the accelerations, the reactions and the motor torque.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from ..errors import LinkageError
from ..model import BAUMGARTE_ALPHA, BAUMGARTE_BETA
from .assembly import assemble, kinematics
from .dae import MechanismDAE
from .formulations import METHODS, STABILIZATIONS, formulation
from .model import Mechanism
from .reduced import simulate_reduced
from .run import MechanismRun
from .singularity import NEAR_SINGULAR_CONDITION, jacobian_condition, singular_message
from .stepper import Stepper

__all__ = ["MechanismRun", "RUN_METHODS", "project_velocity", "run_options", "simulate_mechanism"]

# the formulations, and the reduced model in one joint coordinate (mobility 1: physics/mechanism/reduced.py)
RUN_METHODS = (*METHODS, "reduced")


def project_velocity(dae: MechanismDAE, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
    """The velocity nearest ``qdot`` in kinetic energy that satisfies ``Phi_q qdot = nu``."""
    jacobian = dae.constraints.jacobian(q)
    inverse_mass = 1.0 / dae.mass_diagonal
    gap = jacobian @ qdot - dae.constraints.velocity_rhs()
    weighted = jacobian * inverse_mass
    correction, *_ = np.linalg.lstsq(weighted @ jacobian.T, gap, rcond=None)
    return qdot - inverse_mass * (jacobian.T @ correction)


class RunOptions(BaseModel):
    """The boundary of :func:`simulate_mechanism`: every option checked, one line naming the field and what
    it allows (:data:`ALLOWED`)."""

    model_config = ConfigDict(frozen=True, extra="forbid", strict=False)

    t_end: float = Field(gt=0.0, le=1e4)
    samples: int = Field(ge=2, le=1_000_000)
    t_start: float = Field(ge=-1e6, le=1e6)
    method: Literal["dae", "lagrange", "newton_euler", "reduced"]
    stabilization: Literal["none", "baumgarte", "projection"]
    rtol: float = Field(ge=1e-14, le=1e-2)
    atol: float = Field(ge=1e-16, le=1e-2)


ALLOWED = {
    "t_end": "allowed range 0 < t_end <= 1e4 (the run's duration from t_start, s)",
    "samples": "allowed range 2 <= samples <= 1000000",
    "t_start": "allowed range -1e6 <= t_start <= 1e6 (s)",
    "method": f"allowed values {', '.join(RUN_METHODS)}",
    "stabilization": f"allowed values {', '.join(STABILIZATIONS)}",
    "rtol": "allowed range 1e-14 <= rtol <= 1e-2",
    "atol": "allowed range 1e-16 <= atol <= 1e-2",
}


def run_options(**values) -> RunOptions:
    """Validated options; LinkageError ``"field = value: allowed ..."`` for the first bad one."""
    for name in ("t_end", "t_start", "rtol", "atol"):
        value = values[name]
        if isinstance(value, (int, float)) and not isinstance(value, bool) and not np.isfinite(value):
            raise LinkageError(f"{name} = {value}: {ALLOWED[name]}")
    try:
        return RunOptions(**values)
    except ValidationError as error:
        field = str(error.errors()[0]["loc"][0])
        raise LinkageError(f"{field} = {values[field]!r}: {ALLOWED[field]}") from None


def simulate_mechanism(
    mechanism: Mechanism,
    t_end: float,
    samples: int,
    *,
    q0: np.ndarray | None = None,
    qdot0: np.ndarray | None = None,
    t_start: float = 0.0,
    method: str = "dae",
    stabilization: str = "projection",
    rtol: float = 1e-10,
    atol: float = 1e-10,
    integrate: bool | None = None,
) -> MechanismRun:
    """Run for ``t_end`` seconds from ``t_start`` (a motor's angle follows absolute time), from the pose
    assembled nearest ``q0`` (default: the sketch) with velocities ``qdot0`` (default: rest) projected onto the
    constraints, sampled at ``linspace(t_start, t_start + t_end, samples)``. ``method`` chooses the formulation
    whose accelerations are integrated and whose reactions are reported; ``stabilization`` how the closures
    are held. ``integrate``: None chooses (kinematics alone when the motors fix every body); True forces
    integration. To continue a run, pass its last ``t``, ``q`` and ``qdot`` as ``t_start``, ``q0``, ``qdot0``."""
    options = run_options(t_end=t_end, samples=samples, t_start=t_start, method=method,
                          stabilization=stabilization, rtol=rtol, atol=atol)
    q0, qdot0 = (_state_vector(value, name, 3 * len(mechanism.bodies)) for value, name in ((q0, "q0"),
                                                                                          (qdot0, "qdot0")))
    if options.method == "reduced":
        return _reduced(mechanism, options, q0, qdot0, integrate)
    dae = MechanismDAE(mechanism)
    constraints = dae.constraints
    assembled = assemble(mechanism, q0, options.t_start)
    q = assembled.q
    driven = assembled.mobility == 0 and not integrate
    qdot = project_velocity(dae, q, np.zeros_like(q) if qdot0 is None else np.asarray(qdot0, dtype=float))
    gains = (BAUMGARTE_ALPHA, BAUMGARTE_BETA) if options.stabilization == "baumgarte" else (0.0, 0.0)
    equations = formulation(options.method, dae, *gains)
    times = options.t_start + np.linspace(0.0, options.t_end, options.samples)
    trace = _trace_point(mechanism)
    x, v = equations.start(q, qdot)
    size = equations.size
    stepper = None
    if not driven:
        def rhs(t: float, y: np.ndarray) -> np.ndarray:
            return np.concatenate([y[size:], equations.accelerations(t, y[:size], y[size:])])

        def project(t: float, y: np.ndarray) -> np.ndarray:
            return np.concatenate(equations.project(t, y[:size], y[size:]))

        stepper = Stepper(rhs, float(times[0]), np.concatenate([x, v]), options.rtol, options.atol,
                          project if options.stabilization == "projection" else None)

    out_q, out_qdot, out_reactions, kinetic, potential, residual, trace_xy = [], [], [], [], [], [], []
    condition = []
    for k, t in enumerate(times):
        if k > 0 and driven:
            q = assemble(mechanism, q, float(t)).q
            x, v = equations.start(q, kinematics(mechanism, q)[0])
        elif k > 0 and stepper is not None:
            try:
                y = stepper.advance_to(float(t))
            except LinkageError as error:
                # at or next to a singular pose the step size collapses, or a solve finds the matrix singular:
                # say where and which joints, from the stepper's last accepted state
                last_q = equations.sample_pose(stepper.t, stepper.y[:size])
                if "singular pose" in str(error) or jacobian_condition(constraints, last_q) > NEAR_SINGULAR_CONDITION:
                    raise LinkageError(f"{mechanism.name}: {singular_message(constraints, last_q, stepper.t)}; "
                                       f"{error}") from None
                raise LinkageError(f"{mechanism.name}: {error}") from None
            x, v = y[:size], y[size:]
        try:
            q, qdot, reactions = equations.sample(float(t), x, v)
        except LinkageError:
            pose = equations.sample_pose(float(t), x)
            raise LinkageError(f"{mechanism.name}: {singular_message(constraints, pose, float(t))}") from None
        condition.append(jacobian_condition(constraints, q))
        out_q.append(q)
        out_qdot.append(qdot)
        out_reactions.append(reactions)
        energy = dae.energy(q, qdot)
        kinetic.append(energy[0])
        potential.append(energy[1])
        residual.append(float(np.max(np.abs(constraints.residual(q, float(t))), initial=0.0)))
        trace_xy.append(constraints.body_point(q, *trace) if trace is not None else np.full(2, np.nan))
    return MechanismRun(
        t=times, q=np.array(out_q), qdot=np.array(out_qdot), reactions=np.array(out_reactions),
        kinetic=np.array(kinetic), potential=np.array(potential), residual=np.array(residual),
        trace_xy=np.array(trace_xy), row_names=tuple(f"{row.joint}: {row.meaning}" for row in constraints.rows),
        method=options.method, stabilization=options.stabilization, integrated=not driven,
        steps=0 if stepper is None else stepper.steps, evaluations=0 if stepper is None else stepper.evaluations,
        condition=np.array(condition),
    )


def _reduced(mechanism: Mechanism, options: RunOptions, q0, qdot0, integrate: bool | None) -> MechanismRun:
    """The reduced model's run (mobility 1), its closures held by position analysis at every evaluation: no
    stabilisation applies, and a mechanism its motors fix has no free coordinate to reduce to."""
    if options.stabilization != "projection":
        raise LinkageError(f"stabilization = {options.stabilization!r}: does not apply to method 'reduced' (its "
                           f"positions come from position analysis, so the loops close exactly); leave it out")
    if integrate is False:
        raise LinkageError("integrate = False: does not apply to method 'reduced' (it always integrates)")
    reduced = simulate_reduced(mechanism, options.t_end, options.samples, q0=q0, qdot0=qdot0,
                               t_start=options.t_start, rtol=options.rtol, atol=options.atol)
    return replace(reduced.run, method="reduced", stabilization="position analysis", integrated=True)


def _state_vector(value, name: str, size: int) -> np.ndarray | None:
    """``q0`` or ``qdot0`` as a float array of ``size`` finite numbers (x, y, phi per body), or None."""
    if value is None:
        return None
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        array = np.zeros(0)
    if array.shape != (size,) or not np.all(np.isfinite(array)):
        raise LinkageError(f"{name}: expected {size} finite numbers (x, y, phi of each body's centre of mass)")
    return array


def _trace_point(mechanism: Mechanism) -> tuple[int, tuple[float, float]] | None:
    if mechanism.trace is None:
        return None
    body, _, point = mechanism.trace.partition(".")
    names = [b.name for b in mechanism.bodies]
    if body not in names:
        return None
    return names.index(body), mechanism.body(body).points[point]
