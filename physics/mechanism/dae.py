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
from .model import GROUND, Mechanism, Prismatic, Revolute

SINGULAR_RCOND = 1e-13  # reciprocal condition of the augmented matrix below which a pose counts as singular


@dataclass(frozen=True)
class Solution:
    """Accelerations ``qddot`` (3 B) and multipliers ``reactions`` (one per constraint row)."""

    qddot: np.ndarray
    reactions: np.ndarray


class MechanismDAE:
    """Mass matrix, applied forces and the augmented system of one mechanism."""

    def __init__(self, mechanism: Mechanism) -> None:
        self.mechanism = mechanism
        self.constraints = Constraints(mechanism)
        bodies = mechanism.bodies
        self.mass_diagonal = np.array([v for body in bodies for v in (body.mass, body.mass, body.inertia)])
        if np.any(self.mass_diagonal <= 0.0):
            body = bodies[int(np.argmax(self.mass_diagonal <= 0.0)) // 3]
            raise LinkageError(f"body {body.name!r}: mass and inertia must be positive for the equations of motion")
        self.gravity = np.zeros(self.constraints.size)
        self.gravity[1::3] = -mechanism.g * np.array([body.mass for body in bodies])
        index = self.constraints.body_index
        self._torques: list[tuple[int, int, float]] = []  # (body a, body b, torque on b)
        for driver in mechanism.drivers:
            if driver.torque is not None:
                joint = next(j for j in mechanism.joints if j.name == driver.joint)
                assert isinstance(joint, Revolute)
                a, b = (index.get(side.split(".")[0], -1) for side in (joint.a, joint.b))
                self._torques.append((a, b, float(driver.torque)))
        self._dampers: list[tuple[int, int, float]] = []
        for joint in mechanism.joints:
            if isinstance(joint, Revolute) and joint.damping:
                a_name, b_name = joint.a.split(".")[0], joint.b.split(".")[0]
                self._dampers.append((index.get(a_name, -1) if a_name != GROUND else -1,
                                      index.get(b_name, -1) if b_name != GROUND else -1, joint.damping))
        # viscous sliders: their damping per row of Constraints.sliding_jacobian (sliders in joint order)
        self.slide_damping = np.array([joint.damping for joint in mechanism.joints if isinstance(joint, Prismatic)])

    def slider_damping_force(self, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
        """The generalised force of viscous sliders, ``-J_s^T (c * J_s qdot)`` (``Constraints.sliding_jacobian``):
        ``-c v`` along each guide on the slider's body at its sliding point, and the opposite on the guide's."""
        if not np.any(self.slide_damping):
            return np.zeros(self.constraints.size)
        along = self.constraints.sliding_jacobian(q)
        return -along.T @ (self.slide_damping * (along @ qdot))

    def applied(self, qdot: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
        """``Q``: gravity, motor torques, pin damping torques and slider damping forces (these depend on ``q``:
        the guide turns with its body, so ``q`` is needed when a slider has damping)."""
        if q is None and np.any(self.slide_damping):
            raise ValueError("applied: a viscous slider's force depends on the pose; pass q")
        forces = self.gravity + (self.slider_damping_force(q, qdot) if q is not None else 0.0)
        for a, b, torque in self._torques:
            if b >= 0:
                forces[3 * b + 2] += torque
            if a >= 0:
                forces[3 * a + 2] -= torque
        for a, b, damping in self._dampers:
            relative = (qdot[3 * b + 2] if b >= 0 else 0.0) - (qdot[3 * a + 2] if a >= 0 else 0.0)
            if b >= 0:
                forces[3 * b + 2] -= damping * relative
            if a >= 0:
                forces[3 * a + 2] += damping * relative
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
