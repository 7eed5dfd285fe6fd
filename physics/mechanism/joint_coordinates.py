"""The joint coordinates of a mechanism as functions of its maximal coordinates: the one concept behind the
reduced model's candidate coordinates (:mod:`physics.mechanism.reduced`) and the tree formulations' state
(:mod:`physics.mechanism.tree_coordinates`).

Every joint whose kind carries a freedom (:meth:`~physics.mechanism.joints.JointKind.freedom`) offers one; a
coupler (a gear couples two pins' angles) offers none. A :class:`~physics.mechanism.joints.Rotation` is the
relative angle ``phi_b - phi_a`` (body ``b`` relative to body ``a``, zero in the sketch); a
:class:`~physics.mechanism.joints.Translation` is the travel, how far body ``a``'s point has moved along body
``b``'s guide from where the sketch draws it, ``U . (p_a - p_b) - u . (s_a - s_b)`` with ``U = R(phi_b) u`` the
guide's direction and ``s`` the sketch's points. Each one's value, its gradient ``c_q`` (a row of the reduced
model's bordered Jacobian; ``c_q qdot`` is its rate) and its *curvature* ``gamma_c = -(d/dt c_q) qdot``, the part
of ``d^2 c / dt^2`` without ``qddot`` (as ``gamma`` is for the constraints), are exact. To compare joints of both
kinds, an angle counts as a length: times the mechanism's size (:func:`physics.mechanism.assembly.sketch_size`),
the speed of a point that far from the pin.
"""

from __future__ import annotations

import numpy as np

from .assembly import sketch_size
from .constraints import Constraints, rotation
from .description import GROUND, Mechanism
from .joints import Rotation, Translation, kind_of

_PERP = np.array([[0.0, -1.0], [1.0, 0.0]])  # rotation by +90 degrees


class JointCoordinates:
    """One coordinate per joint of ``mechanism`` that carries a freedom, in the order of ``mechanism.joints``;
    ``names`` are the joints' names, ``ends`` their bodies ``(a, b)`` by name, ``forms`` ``"angle"`` or
    ``"travel"`` (the form of its freedom), ``speed_scale`` what turns each one's rate into a speed."""

    def __init__(self, mechanism: Mechanism, constraints: Constraints) -> None:
        self.constraints = constraints
        self.size = constraints.size
        length = sketch_size(mechanism)
        self._angles: list[tuple[int, int]] = []  # (body a, body b); -1 is the ground
        self._travels: list[tuple[int, np.ndarray, int, np.ndarray, np.ndarray, float]] = []
        self._where: list[tuple[str, int]] = []
        names, ends_by_name = [], []
        index = constraints.body_index

        def body(name: str) -> int:
            return -1 if name == GROUND else index[name]

        def sketch(k: int, arm: np.ndarray) -> np.ndarray:
            return arm + (constraints.centres[k] if k >= 0 else 0.0)

        for joint in mechanism.joints:
            kind = kind_of(joint)
            ends = kind.bodies(joint)
            freedom = None if ends is None else kind.freedom(kind.values(joint, mechanism))
            if ends is None or freedom is None:
                continue
            names.append(joint.name)
            ends_by_name.append(ends)
            a, b = body(ends[0]), body(ends[1])
            if isinstance(freedom, Rotation):
                self._where.append(("angle", len(self._angles)))
                self._angles.append((a, b))
                continue
            assert isinstance(freedom, Translation), f"joint {joint.name!r}: a freedom is a rotation or a travel"
            arm_a, arm_b = np.array(freedom.arm_a, dtype=float), np.array(freedom.arm_b, dtype=float)
            u = np.array(freedom.direction, dtype=float)
            drawn = float(u @ (sketch(a, arm_a) - sketch(b, arm_b)))
            self._where.append(("travel", len(self._travels)))
            self._travels.append((a, arm_a, b, arm_b, u, drawn))
        self.names = tuple(names)
        self.ends = tuple(ends_by_name)
        self.forms = tuple(form for form, _ in self._where)
        self.speed_scale = np.array([length if form == "angle" else 1.0 for form in self.forms])

    def index(self, name: str) -> int:
        return self.names.index(name)

    def _angle(self, q: np.ndarray, k: int) -> float:
        return 0.0 if k < 0 else float(q[3 * k + 2])

    def _point(self, q: np.ndarray, k: int, s: np.ndarray) -> np.ndarray:
        return self.constraints.point(q, k, s)

    def value(self, q: np.ndarray, which: int) -> float:
        form, n = self._where[which]
        if form == "angle":
            a, b = self._angles[n]
            return self._angle(q, b) - self._angle(q, a)
        i, s_p, j, s_t, u, drawn = self._travels[n]
        direction = rotation(self._angle(q, j)) @ u
        return float(direction @ (self._point(q, i, s_p) - self._point(q, j, s_t))) - drawn

    def gradient(self, q: np.ndarray, which: int) -> np.ndarray:
        """``c_q``, shape ``(3 B,)``."""
        row = np.zeros(self.size)
        form, n = self._where[which]
        if form == "angle":
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

    def rate(self, q: np.ndarray, qdot: np.ndarray, which: int) -> float:
        """``c_q qdot``: how fast the coordinate moves at the state ``(q, qdot)``."""
        return float(self.gradient(q, which) @ qdot)

    def gradients(self, q: np.ndarray) -> np.ndarray:
        """Every joint's ``c_q``, shape ``(joints, 3 B)``."""
        return np.array([self.gradient(q, which) for which in range(len(self.names))])

    def curvature(self, q: np.ndarray, qdot: np.ndarray, which: int) -> float:
        """``gamma_c`` with ``c_q qddot = d^2 c / dt^2 - ... = gamma_c``: zero for an angle (linear in q)."""
        form, n = self._where[which]
        if form == "angle":
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
