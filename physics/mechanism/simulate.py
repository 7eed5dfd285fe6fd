"""Motion of any mechanism: the maximal-coordinate DAE integrated with projection onto its constraints.

Between samples scipy's DOP853 integrates ``(q, qdot)``; at every sample the pose is projected back onto
``Phi(q, t) = 0`` (minimum-norm Newton, :func:`physics.mechanism.assembly.assemble`) and the velocities onto
``Phi_q qdot = nu`` in the metric of the mass matrix, so the residual stays at rounding level over any run
(projection, the default of the chains too). A mechanism its motors fully determine (mobility 0, like the
Jansen leg) needs no integration at all: each sample is position analysis from the one before, its velocities
and accelerations follow from the constraints, and the DAE gives the reactions and the motor torque.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from ..errors import LinkageError
from .assembly import assemble, kinematics
from .dae import MechanismDAE
from .model import Mechanism


@dataclass(frozen=True)
class MechanismRun:
    """Samples of a run: ``t (T,)``, ``q, qdot (T, 3 B)``, ``reactions (T, rows)``, ``kinetic, potential
    (T,)``, ``residual (T,)`` (largest constraint residual), ``trace_xy (T, 2)`` (the traced point, if any)."""

    t: np.ndarray
    q: np.ndarray
    qdot: np.ndarray
    reactions: np.ndarray
    kinetic: np.ndarray
    potential: np.ndarray
    residual: np.ndarray
    trace_xy: np.ndarray
    row_names: tuple[str, ...]

    @property
    def energy(self) -> np.ndarray:
        return self.kinetic + self.potential


def project_velocity(dae: MechanismDAE, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
    """The velocity nearest ``qdot`` in kinetic energy that satisfies ``Phi_q qdot = nu``."""
    jacobian = dae.constraints.jacobian(q)
    inverse_mass = 1.0 / dae.mass_diagonal
    gap = jacobian @ qdot - dae.constraints.velocity_rhs()
    weighted = jacobian * inverse_mass
    correction, *_ = np.linalg.lstsq(weighted @ jacobian.T, gap, rcond=None)
    return qdot - inverse_mass * (jacobian.T @ correction)


def simulate_mechanism(
    mechanism: Mechanism,
    t_end: float,
    samples: int,
    *,
    q0: np.ndarray | None = None,
    qdot0: np.ndarray | None = None,
    rtol: float = 1e-10,
    atol: float = 1e-10,
    integrate: bool | None = None,
) -> MechanismRun:
    """Integrate from the assembled sketch (or ``q0``) at rest (or ``qdot0``, projected) for ``t_end`` s.
    ``integrate``: None chooses (kinematics alone when the motors fix every body); True forces integration."""
    if not (np.isfinite(t_end) and 0.0 < t_end <= 1e4):
        raise LinkageError(f"t_end = {t_end}: allowed range 0 < t_end <= 1e4")
    if not 2 <= samples <= 1_000_000:
        raise LinkageError(f"samples = {samples}: allowed range 2 <= samples <= 1000000")
    dae = MechanismDAE(mechanism)
    constraints = dae.constraints
    assembled = assemble(mechanism, q0, 0.0)
    q = assembled.q
    driven = assembled.mobility == 0 and not integrate
    qdot = project_velocity(dae, q, np.zeros_like(q) if qdot0 is None else np.asarray(qdot0, dtype=float))
    size = constraints.size
    times = np.linspace(0.0, t_end, samples)
    trace = _trace_point(mechanism)

    def rhs(_t: float, y: np.ndarray) -> np.ndarray:
        solution = dae.solve(y[:size], y[size:])
        return np.concatenate([y[size:], solution.qddot])

    out_q, out_qdot, out_reactions, kinetic, potential, residual, trace_xy = [], [], [], [], [], [], []
    for k, t in enumerate(times):
        if k > 0 and driven:
            q = assemble(mechanism, q, float(t)).q
            qdot = kinematics(mechanism, q)[0]
        elif k > 0:
            result = solve_ivp(rhs, (times[k - 1], t), np.concatenate([q, qdot]), method="DOP853", rtol=rtol,
                               atol=atol)
            if not result.success:
                raise LinkageError(f"{mechanism.name}: the integration failed at t = {times[k - 1]:.4g} s "
                                   f"({result.message})")
            q = assemble(mechanism, result.y[:size, -1], float(t)).q
            qdot = project_velocity(dae, q, result.y[size:, -1])
        solution = dae.solve(q, qdot)
        out_q.append(q)
        out_qdot.append(qdot)
        out_reactions.append(solution.reactions)
        energy = dae.energy(q, qdot)
        kinetic.append(energy[0])
        potential.append(energy[1])
        residual.append(float(np.max(np.abs(constraints.residual(q, float(t))), initial=0.0)))
        trace_xy.append(constraints.body_point(q, *trace) if trace is not None else np.full(2, np.nan))
    return MechanismRun(
        t=times, q=np.array(out_q), qdot=np.array(out_qdot), reactions=np.array(out_reactions),
        kinetic=np.array(kinetic), potential=np.array(potential), residual=np.array(residual),
        trace_xy=np.array(trace_xy), row_names=tuple(f"{row.joint}: {row.meaning}" for row in constraints.rows),
    )


def _trace_point(mechanism: Mechanism) -> tuple[int, tuple[float, float]] | None:
    if mechanism.trace is None:
        return None
    body, _, point = mechanism.trace.partition(".")
    names = [b.name for b in mechanism.bodies]
    if body not in names:
        return None
    return names.index(body), mechanism.body(body).points[point]
