"""Motion of any mechanism: one of its three formulations integrated, its closures held by projection,
Baumgarte terms or nothing.

The compiled engine (:mod:`physics.mechanism.engine`: the formulation generated once per structure, its numbers a
parameter vector, the chains' DOP853 kernel with dense output) integrates the chosen formulation's state: the
DAE's ``(q, qdot)`` or a tree formulation's ``(s, sd)``. With projection (the default, as for the chains) the state is moved back onto the
constraints after every accepted step, so the residual stays at rounding level over any run. Every sample
reports the pose and velocities in maximal coordinates and the chosen formulation's own reactions of every
joint. A mechanism its motors fully determine (mobility 0, like the Jansen leg) needs no integration at all:
each sample is position analysis from the one before (the kernels' projection onto the formulation's own
constraints), its velocities follow from the constraints, and the chosen formulation gives the accelerations,
the reactions and the motor torque.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from ..errors import LinkageError
from ..model import STABILIZATIONS
from . import engine
from .assembly import assemble
from .dae import MechanismDAE
from .model import Mechanism
from .reduced import simulate_reduced
from .run import MechanismRun

__all__ = ["MechanismRun", "RUN_METHODS", "project_velocity", "run_options", "simulate_mechanism"]

METHODS = engine.ENGINE_METHODS
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
    assembled = assemble(mechanism, q0, options.t_start)
    q = assembled.q
    driven = assembled.mobility == 0 and not integrate
    qdot = project_velocity(dae, q, np.zeros_like(q) if qdot0 is None else np.asarray(qdot0, dtype=float))
    times = options.t_start + np.linspace(0.0, options.t_end, options.samples)
    return engine.run(mechanism, options.method, q, qdot, times, stabilization=options.stabilization,
                      rtol=options.rtol, atol=options.atol, driven=driven)


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
