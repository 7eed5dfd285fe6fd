"""The samples of a reduced run, turned into a run with the DAE run's fields (a :class:`physics.Trajectory`).

Each integration segment of :mod:`physics.mechanism.reduced` is walked through every accepted step in order, so
each pose is solved from the one just before it and the branch is kept; the samples wanted are recorded on the
way. The run's reactions are the multipliers of ``Phi_q^T lambda = M qddot - Q`` at the reduced model's
accelerations (least squares on the full-rank ``Phi_q^T``), so they mean what the DAE's mean.
"""

from __future__ import annotations

import numpy as np

from ..simulate.trajectory import Trajectory
from .numeric_dae import MechanismDAE
from .reduced_engine import ReducedEngine, reduced_engine
from .reduced_partition import Partition, ReducedState
from .run_table import body_points, coordinate_names, traced_path


class Samples:
    """The run's samples as they are computed, segment after segment."""

    def __init__(self, times: np.ndarray) -> None:
        self.times = times
        self.states: list[ReducedState] = []
        self.coordinate: list[str] = []

    def wanted(self, t_from: float, t_to: float, include_end: bool) -> np.ndarray:
        """The sample times not yet recorded that fall in this segment."""
        done = len(self.states)
        pending = self.times[done:]
        return pending[(pending >= t_from) & ((pending <= t_to) if include_end else (pending < t_to))]

    def add(self, state: ReducedState, name: str, last: bool = False) -> None:
        """Record ``state`` (integrated in joint ``name``); ``last``: only if it is the next sample time's."""
        if len(self.states) < self.times.size and (not last or state.t >= self.times[len(self.states)]):
            self.states.append(state)
            self.coordinate.append(name)

    def run(self, dae: MechanismDAE, engine: ReducedEngine | None = None) -> Trajectory:
        """The samples with the DAE run's fields: energies, residuals, traced point and reactions, the constraints
        and applied forces of every sample from the compiled engine in one batched call each."""
        engine = engine if engine is not None else reduced_engine(dae)
        constraints = dae.constraints
        size = constraints.size
        count = len(self.states)
        q = np.array([state.q for state in self.states]).reshape(count, size)
        qdot = np.array([state.qdot for state in self.states]).reshape(count, size)
        qddot = np.array([state.qddot for state in self.states]).reshape(count, size)
        times = np.array([state.t for state in self.states], dtype=float)
        jacobians, phi, _ = engine.constraint_states(times, q, qdot)
        unbalanced = dae.mass_diagonal * qddot - engine.applied(q, qdot)  # = Phi_q^T lambda
        reactions = least_squares_reactions(jacobians, unbalanced)
        kinetic = 0.5 * np.sum(dae.mass_diagonal * qdot * qdot, axis=1)
        potential = -np.sum(dae.gravity[1::3] * q[:, 1::3], axis=1)
        points = body_points(dae.mechanism)
        # method, integrator and stabilization: the caller's (physics.mechanism.simulate names the reduced model)
        return Trajectory(
            method="dae", integrator="DOP853", stabilization="projection",
            t=self.times[:count].copy(), q=q, qdot=qdot, coordinate_names=coordinate_names(dae.mechanism),
            reaction_rows=reactions, kinetic=kinetic,
            potential=potential, energy=kinetic + potential, residual=np.max(np.abs(phi), axis=1, initial=0.0),
            trace_xy=traced_path(points, dae.mechanism.trace, q), body_points=points,
            row_names=tuple(f"{row.joint}: {row.meaning}" for row in constraints.rows),
        )


def least_squares_reactions(jacobians: np.ndarray, unbalanced: np.ndarray) -> np.ndarray:
    """``lambda`` (K, r) with ``Phi_q^T lambda = M qddot - Q`` in the least-squares sense at every sample, from
    ``Phi_q`` (K, r, 3 B) of full row rank and ``M qddot - Q`` (K, 3 B): by the QR factors of ``Phi_q^T``, all
    samples at once (``lambda = R^{-1} Q^T (M qddot - Q)``)."""
    count, rows = jacobians.shape[0], jacobians.shape[1]
    if count == 0 or rows == 0:
        return np.zeros((count, rows))
    orthogonal, triangular = np.linalg.qr(np.transpose(jacobians, (0, 2, 1)))
    projected = np.einsum("kij,ki->kj", orthogonal, unbalanced)
    return np.linalg.solve(triangular, projected[..., None])[..., 0]


def collect_segment(collected: Samples, partition: Partition, solution, start: ReducedState) -> ReducedState:
    """Record the samples of one segment, walking through every accepted step in order so each pose is solved
    from the one just before (the branch is kept); return the state at the segment's end."""
    t_from, t_to = float(solution.t[0]), float(solution.t[-1])
    wanted = collected.wanted(t_from, t_to, include_end=False)
    walk = np.union1d(solution.t, wanted)
    keep = np.isin(walk, wanted)
    y = solution.sol(walk)
    partition.reset(start.q, start.t)
    state = start
    for k, t in enumerate(walk):
        state = start if k == 0 else partition.state(float(t), float(y[0, k]), float(y[1, k]))
        if keep[k]:
            collected.add(state, partition.name)
    return partition.state(t_to, float(solution.y[0, -1]), float(solution.y[1, -1]))
