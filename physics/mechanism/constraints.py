"""The constraint equations of a mechanism in maximal coordinates, and their Jacobian, in closed form.

Body i's pose is ``q_i = (x_i, y_i, phi_i)``: the position of its centre of mass G and its rotation from the
sketch, so a point drawn at ``s`` is at ``r_i + R(phi_i) (s - s_G)``. The sketch itself is ``q_i = (s_G, 0)``
(:meth:`Constraints.sketch_pose`); with G as the reference point the mass matrix is diagonal. Each joint contributes
equations ``Phi(q, t) = 0``:

* revolute between points ``s_a`` of body i and ``s_b`` of body j: ``p_i(s_a) - p_j(s_b) = 0`` (two rows);
* prismatic, point ``s_p`` of body i on the guide of body j through ``s_t`` along ``u``: the offset across the
  guide ``n_j . (p_i(s_p) - p_j(s_t)) = 0`` with ``n_j = R(phi_j) perp(u)``, and the relative rotation
  ``phi_i - phi_j = 0``;
* a speed driver on a revolute joint from body i (``a``) to body j (``b``): ``phi_j - phi_i - omega t = 0``
  (body b turns at ``omega`` relative to body a).

The ground has ``q = 0`` always and no columns. These are the equations position analysis solves and, later,
the DAE formulation differentiates; numeric here (numpy), with an exact Jacobian.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .model import GROUND, Mechanism, Revolute

_PERP = np.array([[0.0, -1.0], [1.0, 0.0]])  # rotation by +90 degrees: d/dphi R(phi) = PERP R(phi)


def rotation(phi: float) -> np.ndarray:
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[c, -s], [s, c]])


@dataclass(frozen=True)
class Row:
    """One scalar constraint, for error messages: which joint (or driver) and what it holds."""

    joint: str
    meaning: str


class Constraints:
    """``Phi(q, t)`` and ``Phi_q(q)`` of a mechanism; ``rows`` names every equation."""

    def __init__(self, mechanism: Mechanism) -> None:
        self.mechanism = mechanism
        self.body_index = {body.name: k for k, body in enumerate(mechanism.bodies)}
        self.centres = np.array([body.centre for body in mechanism.bodies], dtype=float).reshape(-1, 2)
        self.size = 3 * len(mechanism.bodies)
        self._items: list[tuple] = []
        rows: list[Row] = []
        speeds = {driver.joint: driver.speed for driver in mechanism.drivers if driver.speed is not None}
        for joint in mechanism.joints:
            if isinstance(joint, Revolute):
                a_body, b_body = joint.a.split(".")[0], joint.b.split(".")[0]
                s_a = self._relative(a_body, mechanism.point_of(joint.a, joint.name))
                s_b = self._relative(b_body, mechanism.point_of(joint.b, joint.name))
                self._items.append(("pin", self._index(a_body), s_a, self._index(b_body), s_b))
                rows += [Row(joint.name, "x gap"), Row(joint.name, "y gap")]
                if joint.name in speeds:
                    self._items.append(("speed", self._index(a_body), self._index(b_body), float(speeds[joint.name])))
                    rows.append(Row(joint.name, "driven angle"))
            else:
                s_p = self._relative(joint.body, mechanism.point_of(f"{joint.body}.{joint.point}", joint.name))
                s_t = self._relative(joint.on, mechanism.point_of(f"{joint.on}.{joint.through}", joint.name))
                u = np.array(joint.direction) / np.hypot(*joint.direction)
                self._items.append(("slide", self._index(joint.body), s_p, self._index(joint.on), s_t, _PERP @ u))
                rows += [Row(joint.name, "offset across the guide"), Row(joint.name, "relative rotation")]
        self.rows = tuple(rows)

    def _index(self, body: str) -> int:
        return -1 if body == GROUND else self.body_index[body]

    def _relative(self, body: str, sketch_xy: tuple[float, float]) -> np.ndarray:
        """A point of ``body`` relative to its centre of mass (ground points stay absolute)."""
        k = self._index(body)
        return np.array(sketch_xy, dtype=float) - (self.centres[k] if k >= 0 else 0.0)

    def sketch_pose(self) -> np.ndarray:
        """``q`` of the sketch: every centre of mass where it is drawn, no rotation."""
        q = np.zeros(self.size)
        q[0::3], q[1::3] = self.centres[:, 0], self.centres[:, 1]
        return q

    def body_point(self, q: np.ndarray, body: int, sketch_xy) -> np.ndarray:
        """Where the point drawn at ``sketch_xy`` on body number ``body`` is at pose ``q``."""
        return self.point(q, body, np.asarray(sketch_xy, dtype=float) - self.centres[body])

    @staticmethod
    def _pose(q: np.ndarray, k: int) -> tuple[np.ndarray, float]:
        if k < 0:
            return np.zeros(2), 0.0
        return q[3 * k : 3 * k + 2], float(q[3 * k + 2])

    def point(self, q: np.ndarray, k: int, s: np.ndarray) -> np.ndarray:
        """A point given relative to body k's centre of mass (absolute for the ground, k = -1)."""
        r, phi = self._pose(q, k)
        return r + rotation(phi) @ s

    def residual(self, q: np.ndarray, t: float = 0.0) -> np.ndarray:
        out: list[float] = []
        for item in self._items:
            if item[0] == "pin":
                _, i, s_a, j, s_b = item
                out.extend(self.point(q, i, s_a) - self.point(q, j, s_b))
            elif item[0] == "slide":
                _, i, s_p, j, s_t, m = item
                _, phi_j = self._pose(q, j)
                normal = rotation(phi_j) @ m
                out.append(float(normal @ (self.point(q, i, s_p) - self.point(q, j, s_t))))
                out.append(self._pose(q, i)[1] - phi_j)
            else:
                _, i, j, speed = item  # body b (j) turns relative to body a (i)
                out.append(self._pose(q, j)[1] - self._pose(q, i)[1] - speed * t)
        return np.array(out)

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        rows: list[np.ndarray] = []

        def point_columns(k: int, s: np.ndarray, sign: float, block: np.ndarray) -> None:
            if k < 0:
                return
            _, phi = self._pose(q, k)
            block[:, 3 * k : 3 * k + 2] += sign * np.eye(2)
            block[:, 3 * k + 2] += sign * (_PERP @ rotation(phi) @ s)

        for item in self._items:
            if item[0] == "pin":
                _, i, s_a, j, s_b = item
                block = np.zeros((2, self.size))
                point_columns(i, s_a, 1.0, block)
                point_columns(j, s_b, -1.0, block)
                rows.extend(block)
            elif item[0] == "slide":
                _, i, s_p, j, s_t, m = item
                _, phi_j = self._pose(q, j)
                normal = rotation(phi_j) @ m
                gap = self.point(q, i, s_p) - self.point(q, j, s_t)
                block = np.zeros((2, self.size))
                point_columns(i, s_p, 1.0, block)
                point_columns(j, s_t, -1.0, block)
                offset = normal @ block
                if j >= 0:
                    offset[3 * j + 2] += (_PERP @ normal) @ gap
                angle = np.zeros(self.size)
                if i >= 0:
                    angle[3 * i + 2] = 1.0
                if j >= 0:
                    angle[3 * j + 2] -= 1.0
                rows += [offset, angle]
            else:
                _, i, j, _speed = item
                angle = np.zeros(self.size)
                if j >= 0:
                    angle[3 * j + 2] = 1.0
                if i >= 0:
                    angle[3 * i + 2] -= 1.0
                rows.append(angle)
        return np.array(rows).reshape(len(rows), self.size)

    def velocity_rhs(self) -> np.ndarray:
        """``nu`` with ``Phi_q qdot = nu``: minus the explicit time derivative, non-zero on driven rows only."""
        out: list[float] = []
        for item in self._items:
            if item[0] == "pin":
                out += [0.0, 0.0]
            elif item[0] == "slide":
                out += [0.0, 0.0]
            else:
                out.append(item[3])
        return np.array(out)

    def acceleration_rhs(self, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
        """``gamma`` with ``Phi_q qddot = gamma``: the terms of the second time derivative of ``Phi`` that do not
        hold ``qddot`` (centripetal and Coriolis terms), moved to the right-hand side."""
        out: list[float] = []

        def rate(k: int) -> tuple[np.ndarray, float]:
            if k < 0:
                return np.zeros(2), 0.0
            return qdot[3 * k : 3 * k + 2], float(qdot[3 * k + 2])

        def point_velocity(k: int, s: np.ndarray) -> np.ndarray:
            if k < 0:
                return np.zeros(2)
            velocity, spin = rate(k)
            return velocity + spin * (_PERP @ rotation(self._pose(q, k)[1]) @ s)

        def centripetal(k: int, s: np.ndarray) -> np.ndarray:
            """The part of a point's acceleration without qddot: ``-R(phi) s phidot^2``."""
            if k < 0:
                return np.zeros(2)
            return -(rate(k)[1] ** 2) * (rotation(self._pose(q, k)[1]) @ s)

        for item in self._items:
            if item[0] == "pin":
                _, i, s_a, j, s_b = item
                out.extend(-(centripetal(i, s_a) - centripetal(j, s_b)))
            elif item[0] == "slide":
                _, i, s_p, j, s_t, m = item
                _, phi_j = self._pose(q, j)
                spin_j = rate(j)[1]
                normal = rotation(phi_j) @ m
                gap = self.point(q, i, s_p) - self.point(q, j, s_t)
                gap_rate = point_velocity(i, s_p) - point_velocity(j, s_t)
                quadratic = (
                    -(spin_j**2) * (normal @ gap)
                    + 2.0 * spin_j * ((_PERP @ normal) @ gap_rate)
                    + normal @ (centripetal(i, s_p) - centripetal(j, s_t))
                )
                out += [-float(quadratic), 0.0]
            else:
                out.append(0.0)
        return np.array(out)
