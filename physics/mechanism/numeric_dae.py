"""The maximal-coordinate DAE of any planar mechanism: every body's accelerations and every joint reaction in
one linear system, the general form of the seed report's 15 x 15 and 17 x 17 systems.

With each body's pose referred to its centre of mass, the mass matrix is ``diag(m, m, I_G)`` per body, and

    M qddot - Phi_q^T lambda = Q          (momentum balances of every body)
    Phi_q qddot            = gamma        (the joints, differentiated twice)

``Q`` holds gravity, motor torques and joint damping. The multipliers are the joint reactions: for a pin the two
components of the force ON body ``a`` BY body ``b`` (body ``b`` feels the opposite), for a slider the force
across the guide and the torque that keeps the relative angle, for a speed motor the torque it applies to body
``b`` (minus on body ``a``): the driving torque a student plots over a crank turn (inverse dynamics).

This module evaluates the system numerically from the constraint equations of
:mod:`physics.mechanism.constraints`: every sample's reactions, and the check for a singular pose. Between samples
the integrator calls the generated DAE of the same constraints (:mod:`physics.mechanism.symbolic_dae`, run by :mod:`physics.mechanism.engine`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import LinkageError
from .constraints import Constraints
from .description import Mechanism

SINGULAR_RCOND = 1e-13  # reciprocal condition of the augmented matrix below which a pose counts as singular


# eq=False, repr=False: its arrays compare elementwise and print whole; generating __eq__ and __repr__ cost
# every process about 0.5 ms a class (benchmarks/small_cuts.py)
@dataclass(frozen=True, eq=False, repr=False)
class Solution:
    """Accelerations ``qddot`` (3 B) and multipliers ``reactions`` (one per constraint row)."""

    qddot: np.ndarray
    reactions: np.ndarray


class MechanismDAE:
    """Mass matrix, applied forces and the augmented system of one mechanism."""

    def __init__(self, mechanism: Mechanism, constraints: Constraints | None = None, *,
                 massless_allowed: bool = False) -> None:
        """``constraints``: the mechanism's own equations when a caller already holds them
        (:mod:`physics.mechanism.prepared`); built here otherwise. ``massless_allowed``: keep a body without mass
        or inertia instead of refusing it, for a caller that never inverts the mass matrix (a chain run in tree
        coordinates, :mod:`physics.simulate.mechanism_route`: a chain's bar may have no mass, its tree formulation's
        matrix stays regular; only this object's Newton's-law reactions are read, which multiply by it)."""
        self.mechanism = mechanism
        self.constraints = Constraints(mechanism) if constraints is None else constraints
        bodies = mechanism.bodies
        self.mass_diagonal = np.array([v for body in bodies for v in (body.mass, body.mass, body.inertia)])
        if np.any(self.mass_diagonal <= 0.0) and not massless_allowed:
            body = bodies[int(np.argmax(self.mass_diagonal <= 0.0)) // 3]
            raise LinkageError(f"body {body.name!r}: mass and inertia must be positive for the equations of motion")
        self.gravity = np.zeros(self.constraints.size)
        self.gravity[1::3] = -mechanism.g * np.array([body.mass for body in bodies])

    def damping_force(self, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
        """The generalised force of the joints' viscous dampers, ``-J_d^T (c * J_d qdot)``
        (:meth:`Constraints.damper_jacobian`): a pin's ``-c`` times the relative spin as a torque on ``b`` (the
        opposite on ``a``), a slider's ``-c v`` along the guide on its body at the sliding point (the opposite on
        the guide's)."""
        if not np.any(self.constraints.damping):
            return np.zeros(np.shape(qdot))
        along = self.constraints.damper_jacobian(q)  # (D, 3 B), or (T, D, 3 B) for samples
        speeds = np.einsum("...dn,...n->...d", along, qdot)
        return -np.einsum("...dn,...d->...n", along, self.constraints.damping * speeds)

    def applied(self, qdot: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
        """``Q``: gravity, motor torques and the dampers' forces (a slider's depends on ``q``: the guide turns
        with its body, so ``q`` is needed when a joint has damping). ``q`` and ``qdot`` may be a run's samples
        (T, 3 B): then ``Q`` of each, (T, 3 B), in one pass."""
        if q is None and np.any(self.constraints.damping):
            raise ValueError("applied: a damper's force depends on the pose; pass q")
        pose = q if q is not None else self.constraints.sketch_pose()
        forces = self.gravity + self.damping_force(pose, qdot)
        if self.constraints.torque.size:  # a torque motor's on its joint's relative rotation (J_t: constant)
            forces = forces + np.einsum("...kn,k->...n", self.constraints.driven_jacobian(pose), self.constraints.torque)
        return forces

    def solve(self, q: np.ndarray, qdot: np.ndarray) -> Solution:
        """Accelerations and reactions at one state; LinkageError at a singular pose (a dead centre, a
        redundant constraint)."""
        jacobian = self.constraints.jacobian(q)
        size, rows = self.constraints.size, jacobian.shape[0]
        matrix = np.zeros((size + rows, size + rows))
        matrix[:size, :size] = np.diag(self.mass_diagonal)
        matrix[:size, size:] = -jacobian.T
        matrix[size:, :size] = jacobian
        rhs = np.concatenate([self.applied(qdot, q), self.constraints.acceleration_rhs(q, qdot)])
        if 1.0 / np.linalg.cond(matrix) < SINGULAR_RCOND:
            raise LinkageError(f"{self.mechanism.name}: singular pose (a dead centre or a redundant constraint)")
        x = np.linalg.solve(matrix, rhs)
        return Solution(qddot=x[:size], reactions=x[size:])

    def energy(self, q: np.ndarray, qdot: np.ndarray) -> tuple[float, float]:
        """``(kinetic, potential)``; potential zero at y = 0."""
        kinetic = 0.5 * float(np.sum(self.mass_diagonal * qdot * qdot))
        potential = float(-np.sum(self.gravity[1::3] * q[1::3]))
        return kinetic, potential
