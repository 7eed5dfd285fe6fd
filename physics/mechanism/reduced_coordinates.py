"""The joint coordinates of a mechanism as functions of its maximal coordinates: the candidates for the one
independent coordinate of the reduced model (:mod:`physics.mechanism.reduced`).

Every joint that joins two bodies offers one (a gear couples two pins' angles and offers none): a pin's relative angle ``phi_b - phi_a`` (body ``b`` relative to body ``a``, zero in the
sketch) and a slider's travel, how far its sliding point has moved along the guide from where the sketch draws
it, ``U . (p_i(s_p) - p_j(s_t)) - U_0 . (s_p - s_t)`` with ``U = R(phi_j) u`` the guide's direction. The reduced
model needs each one's value, its gradient ``c_q`` (a row of the bordered Jacobian) and its *curvature*
``gamma_c = -(d/dt c_q) qdot``, the part of ``d^2 c / dt^2`` without ``qddot`` (as ``gamma`` is for the
constraints), all exact. To compare joints of both kinds, a pin's angle counts as a length: times the
mechanism's size (:func:`physics.mechanism.assembly.sketch_size`), the speed of a point that far from the pin.
"""

from __future__ import annotations

import numpy as np

from .assembly import sketch_size
from .constraints import Constraints, rotation
from .model import GROUND, Mechanism, Prismatic, Revolute

_PERP = np.array([[0.0, -1.0], [1.0, 0.0]])  # rotation by +90 degrees


class JointCoordinates:
    """One coordinate per joint of ``mechanism``, in the order of ``mechanism.joints``; ``names`` are the joints'
    names, ``kinds`` ``"angle"`` or ``"travel"``, ``speed_scale`` what turns each one's rate into a speed."""

    def __init__(self, mechanism: Mechanism, constraints: Constraints) -> None:
        self.constraints = constraints
        self.size = constraints.size
        length = sketch_size(mechanism)
        linking = [joint for joint in mechanism.joints if isinstance(joint, (Revolute, Prismatic))]  # a gear has none
        self.names = tuple(joint.name for joint in linking)
        self.kinds = tuple("angle" if isinstance(joint, Revolute) else "travel" for joint in linking)
        self.speed_scale = np.array([length if kind == "angle" else 1.0 for kind in self.kinds])
        self._angles: list[tuple[int, int]] = []  # (body a, body b); -1 is the ground
        self._travels: list[tuple[int, np.ndarray, int, np.ndarray, np.ndarray, float]] = []
        self._where: list[tuple[str, int]] = []
        index = constraints.body_index

        def body(name: str) -> int:
            return -1 if name == GROUND else index[name]

        def relative(k: int, xy: tuple[float, float]) -> np.ndarray:
            return np.array(xy, dtype=float) - (constraints.centres[k] if k >= 0 else 0.0)

        for joint in linking:
            if isinstance(joint, Revolute):
                self._where.append(("angle", len(self._angles)))
                self._angles.append((body(joint.a.split(".")[0]), body(joint.b.split(".")[0])))
            else:
                i, j = body(joint.body), body(joint.on)
                sliding = mechanism.point_of(f"{joint.body}.{joint.point}", joint.name)
                through = mechanism.point_of(f"{joint.on}.{joint.through}", joint.name)
                u = np.array(joint.direction, dtype=float) / np.hypot(*joint.direction)
                drawn = float(u @ (np.array(sliding) - np.array(through)))
                self._where.append(("travel", len(self._travels)))
                self._travels.append((i, relative(i, sliding), j, relative(j, through), u, drawn))

    def index(self, name: str) -> int:
        return self.names.index(name)

    def _angle(self, q: np.ndarray, k: int) -> float:
        return 0.0 if k < 0 else float(q[3 * k + 2])

    def _point(self, q: np.ndarray, k: int, s: np.ndarray) -> np.ndarray:
        return self.constraints.point(q, k, s)

    def value(self, q: np.ndarray, which: int) -> float:
        kind, n = self._where[which]
        if kind == "angle":
            a, b = self._angles[n]
            return self._angle(q, b) - self._angle(q, a)
        i, s_p, j, s_t, u, drawn = self._travels[n]
        direction = rotation(self._angle(q, j)) @ u
        return float(direction @ (self._point(q, i, s_p) - self._point(q, j, s_t))) - drawn

    def gradient(self, q: np.ndarray, which: int) -> np.ndarray:
        """``c_q``, shape ``(3 B,)``."""
        row = np.zeros(self.size)
        kind, n = self._where[which]
        if kind == "angle":
            a, b = self._angles[n]
            if b >= 0:
                row[3 * b + 2] += 1.0
            if a >= 0:
                row[3 * a + 2] -= 1.0
            return row
        i, s_p, j, s_t, u, _ = self._travels[n]
        direction = rotation(self._angle(q, j)) @ u
        if i >= 0:
            row[3 * i : 3 * i + 2] += direction
            row[3 * i + 2] += direction @ (_PERP @ rotation(self._angle(q, i)) @ s_p)
        if j >= 0:
            gap = self._point(q, i, s_p) - self._point(q, j, s_t)
            row[3 * j : 3 * j + 2] -= direction
            row[3 * j + 2] += -direction @ (_PERP @ rotation(self._angle(q, j)) @ s_t) + (_PERP @ direction) @ gap
        return row

    def gradients(self, q: np.ndarray) -> np.ndarray:
        """Every joint's ``c_q``, shape ``(joints, 3 B)``."""
        return np.array([self.gradient(q, which) for which in range(len(self.names))])

    def curvature(self, q: np.ndarray, qdot: np.ndarray, which: int) -> float:
        """``gamma_c`` with ``c_q qddot = d^2 c / dt^2 - ... = gamma_c``: zero for an angle (linear in q)."""
        kind, n = self._where[which]
        if kind == "angle":
            return 0.0
        i, s_p, j, s_t, u, _ = self._travels[n]

        def spin(k: int) -> float:
            return 0.0 if k < 0 else float(qdot[3 * k + 2])

        def velocity(k: int, s: np.ndarray) -> np.ndarray:
            if k < 0:
                return np.zeros(2)
            return qdot[3 * k : 3 * k + 2] + spin(k) * (_PERP @ rotation(self._angle(q, k)) @ s)

        def centripetal(k: int, s: np.ndarray) -> np.ndarray:
            return np.zeros(2) if k < 0 else -(spin(k) ** 2) * (rotation(self._angle(q, k)) @ s)

        direction = rotation(self._angle(q, j)) @ u
        gap = self._point(q, i, s_p) - self._point(q, j, s_t)
        gap_rate = velocity(i, s_p) - velocity(j, s_t)
        quadratic = (
            -(spin(j) ** 2) * (direction @ gap)
            + 2.0 * spin(j) * ((_PERP @ direction) @ gap_rate)
            + direction @ (centripetal(i, s_p) - centripetal(j, s_t))
        )
        return -float(quadratic)

    def speed_shares(self, q: np.ndarray, direction: np.ndarray) -> np.ndarray:
        """Each joint's rate along the velocity ``direction`` as a speed (angles times the size), divided by the
        largest: 1 for the joint that moves fastest, 0 for one at a dead centre (it stands still)."""
        speeds = np.abs(self.gradients(q) @ direction) * self.speed_scale
        return speeds / max(float(np.max(speeds)), 1e-300)
