"""The samples of a reduced run, turned into a run with the DAE run's fields (a :class:`physics.Trajectory`).

Each integration segment of :mod:`physics.mechanism.reduced` is walked through every accepted step in order, so
each pose is solved from the one just before it and the branch is kept; the samples wanted are recorded on the
way. The run's reactions are the multipliers of ``Phi_q^T lambda = M qddot - Q`` at the reduced model's
accelerations (least squares on the full-rank ``Phi_q^T``), so they mean what the DAE's mean.
"""

from __future__ import annotations

import numpy as np

from ..simulate.trajectory import Trajectory
from .dae import MechanismDAE
from .reduced_partition import Partition, ReducedState
from .run import body_points, coordinate_names, traced_path


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

    def run(self, dae: MechanismDAE) -> Trajectory:
        """The samples with the DAE run's fields: energies, residuals, traced point and reactions."""
        constraints = dae.constraints
        shape = (len(self.states), constraints.size)  # (0, 3 B) when no sample was recorded
        q = np.array([state.q for state in self.states]).reshape(shape)
        qdot = np.array([state.qdot for state in self.states]).reshape(shape)
        reactions, kinetic, potential, residual = [], [], [], []
        for state in self.states:
            jacobian = constraints.jacobian(state.q)
            unbalanced = dae.mass_diagonal * state.qddot - dae.applied(state.qdot, state.q)  # = Phi_q^T lambda
            reactions.append(np.linalg.lstsq(jacobian.T, unbalanced, rcond=None)[0])
            energy = dae.energy(state.q, state.qdot)
            kinetic.append(energy[0])
            potential.append(energy[1])
            residual.append(float(np.max(np.abs(constraints.residual(state.q, state.t)), initial=0.0)))
        kinetic_, potential_ = np.array(kinetic), np.array(potential)
        points = body_points(dae.mechanism)
        # method, integrator and stabilization: the caller's (physics.mechanism.simulate names the reduced model)
        return Trajectory(
            method="dae", integrator="DOP853", stabilization="projection",
            t=self.times[:len(self.states)].copy(), q=q, qdot=qdot, coordinate_names=coordinate_names(dae.mechanism),
            reaction_rows=np.array(reactions), kinetic=kinetic_, potential=potential_, energy=kinetic_ + potential_,
            residual=np.array(residual), trace_xy=traced_path(points, dae.mechanism.trace, q), body_points=points,
            row_names=tuple(f"{row.joint}: {row.meaning}" for row in constraints.rows),
        )


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
