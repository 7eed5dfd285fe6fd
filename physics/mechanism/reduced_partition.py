"""One choice of independent joint coordinate ``s`` of a one-degree-of-freedom mechanism: its positions, its
velocity transformation and its one equation of motion.

Bordering the constraint Jacobian with the coordinate's gradient gives a square matrix ``A = [Phi_q; c_q]``
(``3 B x 3 B`` when the mobility is 1 and no constraint is redundant, which assembly guarantees):

* positions: ``Phi(q, t) = 0, c(q) = s`` solved by Newton's method from the previous pose, predicted to first
  order, so the branch the mechanism is on is kept (a chord iteration on the previous pose's ``A^{-1}``; then
  ``A`` is inverted afresh at the converged pose);
* velocities: ``A qdot = [nu; sdot]``, i.e. ``qdot = B sdot + D`` with ``B = A^{-1} e`` (the velocity
  transformation) and ``D = A^{-1} [nu; 0]`` (non-zero only with a speed motor);
* accelerations: ``qddot = B sddot + a0`` with ``a0 = A^{-1} [gamma; gamma_c]`` (``a0`` is ``Bdot sdot`` for a
  mechanism without motors);
* ``M qddot = Q + Phi_q^T lambda`` projected on ``B`` (``Phi_q B = 0`` removes every reaction):
  ``(B^T M B) sddot = B^T (Q - M a0)``.

``A`` is singular where ``c`` stands still while the mechanism moves (a dead centre of that coordinate): the
reduced model switches coordinate long before (:mod:`physics.mechanism.reduced`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import LinkageError
from .dae import MechanismDAE
from .joint_coordinates import JointCoordinates

NEWTON_STEPS = 30
# Newton stops when a step moves no coordinate by more than this times the mechanism's size (rotations counted
# as lengths), or when steps below NEWTON_NOISE times the size stop shrinking (rounding noise). The steps use
# the reference pose's inverse (a chord iteration) while each is below CHORD_RATE times the one before, and a
# fresh inverse otherwise, so what is left after the last step is below CHORD_RATE times it: rounding level.
NEWTON_STEP_TOLERANCE = 1e-14
NEWTON_NOISE = 1e-12
CHORD_RATE = 0.1
# A pose whose residual stays above this (times the size) after NEWTON_STEPS has lost the branch.
NEWTON_FAILURE = 1e-9


@dataclass(frozen=True)
class ReducedState:
    """Everything at one ``(t, s, sdot)``: the pose ``q``, velocities ``qdot``, accelerations ``qddot``, the
    velocity transformation ``B`` (``dq/ds``), the generalised mass ``B^T M B`` and ``sddot``."""

    t: float
    s: float
    sdot: float
    q: np.ndarray
    qdot: np.ndarray
    qddot: np.ndarray
    velocity_map: np.ndarray
    generalised_mass: float
    sddot: float


class Partition:
    """The reduced model in the joint coordinate number ``which`` of ``coordinates``, started at pose ``q``."""

    def __init__(self, dae: MechanismDAE, coordinates: JointCoordinates, which: int, q: np.ndarray, t: float,
                 length: float) -> None:
        self.dae = dae
        self.constraints = dae.constraints
        self.coordinates = coordinates
        self.which = which
        self.name = coordinates.names[which]
        self.length = length
        self.weights = np.tile([1.0, 1.0, length], len(dae.mechanism.bodies))  # rotations counted as lengths
        self.nu = self.constraints.velocity_rhs()
        self._cached: ReducedState | None = None
        self.reset(q, t)

    def _invert(self, q: np.ndarray) -> np.ndarray:
        matrix = np.vstack([self.constraints.jacobian(q), self.coordinates.gradient(q, self.which)])
        if not np.all(np.isfinite(matrix)):
            raise LinkageError(f"{self.dae.mechanism.name}: non-finite pose while solving for joint {self.name!r}")
        return np.linalg.inv(matrix)  # small (3 B <= 72): one inverse, then products, is cheapest

    def _maps(self, inverse: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(B, D)``: the velocity per unit ``sdot`` and the velocity the motors impose at ``sdot = 0``."""
        return inverse[:, -1].copy(), inverse[:, :-1] @ self.nu

    def reset(self, q: np.ndarray, t: float) -> None:
        """Make ``q`` (at time ``t``, on the branch wanted) the pose the next one is predicted from (to first
        order in ``s``: its rates are not known here)."""
        q = np.array(q, dtype=float)
        self._inverse = self._invert(q)
        velocity_map, motor_velocity = self._maps(self._inverse)
        zero = np.zeros_like(q)
        self._reference = ReducedState(t=float(t), s=self.coordinates.value(q, self.which), sdot=0.0, q=q,
                                       qdot=zero, qddot=zero, velocity_map=velocity_map, generalised_mass=math.nan,
                                       sddot=0.0)
        self._cached = None

    def _closure(self, q: np.ndarray, t: float, s: float) -> np.ndarray:
        return np.append(self.constraints.residual(q, t), self.coordinates.value(q, self.which) - s)

    def pose(self, t: float, s: float) -> np.ndarray:
        """The pose with coordinate ``s`` at time ``t`` on the branch of the reference pose: predicted to second
        order in time from the reference state, corrected along ``B`` to the ``s`` asked for, then chord steps on
        the reference's inverse (a fresh inverse where those converge slowly)."""
        reference = self._reference
        elapsed = t - reference.t
        drift = reference.qdot * elapsed + 0.5 * reference.qddot * elapsed**2
        s_drift = reference.sdot * elapsed + 0.5 * reference.sddot * elapsed**2
        q = reference.q + drift + reference.velocity_map * (s - reference.s - s_drift)
        inverse = self._inverse
        previous = math.inf
        for _ in range(NEWTON_STEPS):
            step = inverse @ self._closure(q, t, s)
            q = q - step
            moved = float(np.max(np.abs(step * self.weights)))
            if moved <= NEWTON_STEP_TOLERANCE * self.length:
                return q
            if moved <= NEWTON_NOISE * self.length and moved >= 0.5 * previous:
                return q  # the steps no longer shrink: they are rounding noise
            if moved > CHORD_RATE * previous:
                inverse = self._invert(q)  # the chord steps converge slowly here: a full Newton step
            previous = moved
        residual = float(np.max(np.abs(self._closure(q, t, s))))
        if not residual <= NEWTON_FAILURE * self.length:
            raise LinkageError(
                f"{self.dae.mechanism.name}: position analysis in joint {self.name!r} at t = {t:.6g} s did not "
                f"converge (residual {residual:.3g}); a dead centre was passed between two steps"
            )
        return q

    def state(self, t: float, s: float, sdot: float) -> ReducedState:
        """Pose, velocities and accelerations at ``(t, s, sdot)``; becomes the reference of the next pose."""
        cached = self._cached
        if cached is not None and cached.t == t and cached.s == s and cached.sdot == sdot:
            return cached
        q = self.pose(t, s)
        inverse = self._invert(q)
        velocity_map, motor_velocity = self._maps(inverse)
        qdot = velocity_map * sdot + motor_velocity
        curvature = np.append(self.constraints.acceleration_rhs(q, qdot), self.coordinates.curvature(q, qdot, self.which))
        drift = inverse @ curvature
        mass = self.dae.mass_diagonal
        generalised_mass = float(velocity_map @ (mass * velocity_map))
        generalised_force = float(velocity_map @ (self.dae.applied(qdot, q) - mass * drift))
        sddot = generalised_force / generalised_mass
        self._inverse = inverse
        self._cached = ReducedState(t=float(t), s=float(s), sdot=float(sdot), q=q, qdot=qdot,
                                    qddot=velocity_map * sddot + drift, velocity_map=velocity_map,
                                    generalised_mass=generalised_mass, sddot=sddot)
        self._reference = self._cached
        return self._cached

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """``d/dt (s, sdot)``: the one ODE scipy integrates."""
        state = self.state(t, float(y[0]), float(y[1]))
        return np.array([state.sdot, state.sddot])

    def share(self, state: ReducedState) -> float:
        """This coordinate's speed share along the motion (1: the fastest joint, 0: a dead centre)."""
        return float(self.coordinates.speed_shares(state.q, state.velocity_map)[self.which])

    def coordinate_of(self, q: np.ndarray, qdot: np.ndarray) -> tuple[float, float]:
        """``(s, sdot)`` of a state given in maximal coordinates: read off exactly, nothing integrated."""
        return self.coordinates.value(q, self.which), self.coordinates.rate(q, qdot, self.which)
