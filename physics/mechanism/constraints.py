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
  (body b turns at ``omega`` relative to body a);
* a gear pair of joints 1 and 2: ``(phi_b2 - phi_a2) - ratio (phi_b1 - phi_a1) - offset = 0``.

The rows of a sum of body angles (motor, gear, each kind's :meth:`~physics.mechanism.joints.JointKind.angle_rows`)
come from the joint kinds themselves, the same functions the symbolic derivations call with symbols.

The ground has ``q = 0`` always and no columns. These are the equations position analysis solves and, later,
the DAE formulation differentiates; numeric here (numpy), with an exact Jacobian.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .joints import MOTOR, kind_of
from .model import GROUND, Mechanism, Prismatic, Revolute

_PERP = np.array([[0.0, -1.0], [1.0, 0.0]])  # rotation by +90 degrees: d/dphi R(phi) = PERP R(phi)


def rotation(phi: float) -> np.ndarray:
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[c, -s], [s, c]])


def points_at_poses(q: np.ndarray, body: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """Points fixed in bodies at poses ``q`` (..., 3 B): point k of body ``body[k]`` at ``offset[k]`` from its
    centre of mass in the sketch is at ``r + R(phi) offset`` -> (..., K, 2). The batched form of
    :meth:`Constraints.body_point` (a drawing's every point over a chunk of samples in one pass)."""
    q = np.asarray(q, dtype=float)
    x, y, phi = q[..., 0::3], q[..., 1::3], q[..., 2::3]
    cos, sin = np.cos(phi[..., body]), np.sin(phi[..., body])
    sx, sy = offset[:, 0], offset[:, 1]
    return np.stack([x[..., body] + cos * sx - sin * sy, y[..., body] + sin * sx + cos * sy], axis=-1)


def _perp(vectors: np.ndarray) -> np.ndarray:
    """Each row turned by +90 degrees."""
    return np.column_stack([-vectors[:, 1], vectors[:, 0]])


class _JointArrays:
    """The joints of each form as arrays (body numbers, arms, rows), so that the equations are evaluated for all
    joints of a form at once: the integrator evaluates them thousands of times a second. The ground is body
    number ``B`` here (a spare slot whose pose is always zero). Rows that hold a sum of body angles (a speed
    motor's, a gear's: :class:`~physics.mechanism.joints.AngleRow`) are one sparse matrix ``angle_matrix`` (rows
    by bodies) with their constants and rates."""

    def __init__(self, items: list[tuple], bodies: int) -> None:
        row = 0
        pins, slides, angles = [], [], []
        for item in items:
            if item[0] == "pin":
                pins.append((row, *item[1:]))
                row += 2
            elif item[0] == "slide":
                slides.append((row, *item[1:]))
                row += 2
            else:
                angles.append((row, item[1]))
                row += 1

        def body(k: int) -> int:
            return bodies if k < 0 else k

        def arms(entries, column) -> np.ndarray:
            return np.array([entry[column] for entry in entries], dtype=float).reshape(-1, 2)

        self.pin_rows = np.array([p[0] for p in pins], dtype=int)
        self.pin_a, self.pin_sa = np.array([body(p[1]) for p in pins], dtype=int), arms(pins, 2)
        self.pin_b, self.pin_sb = np.array([body(p[3]) for p in pins], dtype=int), arms(pins, 4)
        self.slide_rows = np.array([s[0] for s in slides], dtype=int)
        self.slide_body, self.slide_sp = np.array([body(s[1]) for s in slides], dtype=int), arms(slides, 2)
        self.slide_on, self.slide_st = np.array([body(s[3]) for s in slides], dtype=int), arms(slides, 4)
        self.slide_m = arms(slides, 5)
        self.slide_u = arms(slides, 6)  # the guide's direction in the sketch (slide_m is it turned by +90 degrees)
        self.angle_rows = np.array([r for r, _ in angles], dtype=int)
        self.angle_matrix = np.zeros((len(angles), bodies + 1))
        for number, (_, angle_row) in enumerate(angles):
            for c, k in angle_row.terms:
                self.angle_matrix[number, body(k)] += float(c)
        self.angle_matrix[:, bodies] = 0.0  # the ground's angle is zero
        self.angle_constant = np.array([float(r.constant) for _, r in angles], dtype=float)
        self.angle_rate = np.array([float(r.rate) for _, r in angles], dtype=float)


class _Frame:
    """Every body's pose (and rates) at one state, the ground appended as body ``B`` at rest at the origin."""

    def __init__(self, arrays: _JointArrays, q: np.ndarray, qdot: np.ndarray | None = None) -> None:
        pose = np.vstack([np.reshape(q, (-1, 3)), np.zeros((1, 3))])
        self.position = pose[:, :2]
        self.angle = pose[:, 2]
        self.cos, self.sin = np.cos(self.angle), np.sin(self.angle)
        if qdot is not None:
            rate = np.vstack([np.reshape(qdot, (-1, 3)), np.zeros((1, 3))])
            self.velocity, self.spin = rate[:, :2], rate[:, 2]

    def turned(self, body: np.ndarray, arm: np.ndarray) -> np.ndarray:
        """``R(phi_body) arm`` row by row."""
        c, s = self.cos[body], self.sin[body]
        return np.column_stack([c * arm[:, 0] - s * arm[:, 1], s * arm[:, 0] + c * arm[:, 1]])

    def points(self, body: np.ndarray, arm: np.ndarray) -> np.ndarray:
        return self.position[body] + self.turned(body, arm)

    def point_velocities(self, body: np.ndarray, arm: np.ndarray) -> np.ndarray:
        return self.velocity[body] + self.spin[body][:, None] * _perp(self.turned(body, arm))

    def centripetal(self, body: np.ndarray, arm: np.ndarray) -> np.ndarray:
        """The part of a point's acceleration without qddot: ``-R(phi) s phidot^2``."""
        return -(self.spin[body] ** 2)[:, None] * self.turned(body, arm)


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
            kind = kind_of(joint)
            rows += [Row(joint.name, meaning) for meaning in kind.meanings]
            if isinstance(joint, Revolute):
                a_body, b_body = joint.a.split(".")[0], joint.b.split(".")[0]
                s_a = self._relative(a_body, mechanism.point_of(joint.a, joint.name))
                s_b = self._relative(b_body, mechanism.point_of(joint.b, joint.name))
                self._items.append(("pin", self._index(a_body), s_a, self._index(b_body), s_b))
                if joint.name in speeds:
                    ends = (self._index(a_body), self._index(b_body))
                    self._items += [("angle", row) for row in MOTOR.angle_rows(ends, float(speeds[joint.name]))]
                    rows += [Row(joint.name, meaning) for meaning in MOTOR.meanings]
            elif isinstance(joint, Prismatic):
                s_p = self._relative(joint.body, mechanism.point_of(f"{joint.body}.{joint.point}", joint.name))
                s_t = self._relative(joint.on, mechanism.point_of(f"{joint.on}.{joint.through}", joint.name))
                u = np.array(joint.direction) / np.hypot(*joint.direction)
                self._items.append(("slide", self._index(joint.body), s_p, self._index(joint.on), s_t, _PERP @ u, u))
            else:
                bodies = kind.structure_bodies(joint, self._index, mechanism)
                self._items += [("angle", row) for row in kind.angle_rows(bodies, kind.values(joint, mechanism))]
        self.rows = tuple(rows)
        self._arrays = _JointArrays(self._items, len(mechanism.bodies))

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
        frame = _Frame(self._arrays, q)
        arrays = self._arrays
        out = np.empty(len(self.rows))
        if arrays.pin_rows.size:
            gap = frame.points(arrays.pin_a, arrays.pin_sa) - frame.points(arrays.pin_b, arrays.pin_sb)
            out[arrays.pin_rows], out[arrays.pin_rows + 1] = gap[:, 0], gap[:, 1]
        if arrays.slide_rows.size:
            normal = frame.turned(arrays.slide_on, arrays.slide_m)
            gap = frame.points(arrays.slide_body, arrays.slide_sp) - frame.points(arrays.slide_on, arrays.slide_st)
            out[arrays.slide_rows] = np.sum(normal * gap, axis=1)
            out[arrays.slide_rows + 1] = frame.angle[arrays.slide_body] - frame.angle[arrays.slide_on]
        if arrays.angle_rows.size:
            out[arrays.angle_rows] = (arrays.angle_matrix @ frame.angle - arrays.angle_constant
                                      - arrays.angle_rate * t)
        return out

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        frame = _Frame(self._arrays, q)
        arrays = self._arrays
        out = np.zeros((len(self.rows), self.size + 3))  # three spare columns take the ground's entries
        if arrays.pin_rows.size:
            rows = arrays.pin_rows
            for sign, body, arm in ((1.0, arrays.pin_a, arrays.pin_sa), (-1.0, arrays.pin_b, arrays.pin_sb)):
                swing = _perp(frame.turned(body, arm))
                column = 3 * body
                out[rows, column] += sign
                out[rows + 1, column + 1] += sign
                out[rows, column + 2] += sign * swing[:, 0]
                out[rows + 1, column + 2] += sign * swing[:, 1]
        if arrays.slide_rows.size:
            rows, body, on = arrays.slide_rows, arrays.slide_body, arrays.slide_on
            normal = frame.turned(on, arrays.slide_m)
            gap = frame.points(body, arrays.slide_sp) - frame.points(on, arrays.slide_st)
            out[rows, 3 * body] += normal[:, 0]
            out[rows, 3 * body + 1] += normal[:, 1]
            out[rows, 3 * body + 2] += np.sum(normal * _perp(frame.turned(body, arrays.slide_sp)), axis=1)
            out[rows, 3 * on] -= normal[:, 0]
            out[rows, 3 * on + 1] -= normal[:, 1]
            out[rows, 3 * on + 2] += np.sum(_perp(normal) * gap - normal * _perp(frame.turned(on, arrays.slide_st)),
                                            axis=1)
            out[rows + 1, 3 * body + 2] += 1.0
            out[rows + 1, 3 * on + 2] -= 1.0
        if arrays.angle_rows.size:
            out[arrays.angle_rows, 2::3] += arrays.angle_matrix
        return out[:, : self.size]

    def sliding_jacobian(self, q: np.ndarray) -> np.ndarray:
        """``(S, 3 B)``: for each slider (in joint order) the gradient of its sliding coordinate, the distance of
        the sliding point from the guide's through point along the guide, ``u_j . (p_i(s_p) - p_j(s_t))`` with
        ``u_j = R(phi_j) u``. Its product with ``qdot`` is the sliding speed (the speed of the sliding point
        relative to the guide's body, along the guide); a viscous slider's force is ``-c`` times it along the
        guide, ``-c J_s^T J_s qdot`` as a generalised force, whose power is ``-c (J_s qdot)^2``."""
        frame = _Frame(self._arrays, q)
        arrays = self._arrays
        out = np.zeros((arrays.slide_rows.size, self.size + 3))
        if arrays.slide_rows.size:
            rows = np.arange(arrays.slide_rows.size)
            body, on = arrays.slide_body, arrays.slide_on
            along = frame.turned(on, arrays.slide_u)
            gap = frame.points(body, arrays.slide_sp) - frame.points(on, arrays.slide_st)
            np.add.at(out, (rows, 3 * body), along[:, 0])
            np.add.at(out, (rows, 3 * body + 1), along[:, 1])
            np.add.at(out, (rows, 3 * body + 2), np.sum(along * _perp(frame.turned(body, arrays.slide_sp)), axis=1))
            np.add.at(out, (rows, 3 * on), -along[:, 0])
            np.add.at(out, (rows, 3 * on + 1), -along[:, 1])
            np.add.at(out, (rows, 3 * on + 2),
                      np.sum(_perp(along) * gap - along * _perp(frame.turned(on, arrays.slide_st)), axis=1))
        return out[:, : self.size]

    def velocity_rhs(self) -> np.ndarray:
        """``nu`` with ``Phi_q qdot = nu``: minus the explicit time derivative, non-zero on driven rows only."""
        out = np.zeros(len(self.rows))
        out[self._arrays.angle_rows] = self._arrays.angle_rate
        return out

    def acceleration_rhs(self, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
        """``gamma`` with ``Phi_q qddot = gamma``: the terms of the second time derivative of ``Phi`` that do not
        hold ``qddot`` (centripetal and Coriolis terms), moved to the right-hand side."""
        frame = _Frame(self._arrays, q, qdot)
        arrays = self._arrays
        out = np.zeros(len(self.rows))
        if arrays.pin_rows.size:
            gamma = -(frame.centripetal(arrays.pin_a, arrays.pin_sa) - frame.centripetal(arrays.pin_b, arrays.pin_sb))
            out[arrays.pin_rows], out[arrays.pin_rows + 1] = gamma[:, 0], gamma[:, 1]
        if arrays.slide_rows.size:
            body, on = arrays.slide_body, arrays.slide_on
            spin_on = frame.spin[on][:, None]
            normal = frame.turned(on, arrays.slide_m)
            gap = frame.points(body, arrays.slide_sp) - frame.points(on, arrays.slide_st)
            gap_rate = frame.point_velocities(body, arrays.slide_sp) - frame.point_velocities(on, arrays.slide_st)
            quadratic = (-(spin_on**2) * normal * gap + 2.0 * spin_on * _perp(normal) * gap_rate
                         + normal * (frame.centripetal(body, arrays.slide_sp) - frame.centripetal(on, arrays.slide_st)))
            out[arrays.slide_rows] = -np.sum(quadratic, axis=1)
        return out
