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

Every row comes from its joint kind (:meth:`~physics.mechanism.joints.JointKind.rows`, the motors'
:meth:`~physics.mechanism.joints.motor.Motor.rows`): the same functions the symbolic derivations call with
symbols, called here with numpy arrays (:class:`_Numbers`).

The ground has ``q = 0`` always and no columns. These are the equations position analysis solves and, later,
the DAE formulation differentiates; numeric here (numpy), with an exact Jacobian.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .description import GROUND, Mechanism
from .joints import KINDS, MOTOR, Kinematics, Translation, kind_of


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


class _Numbers(Kinematics):
    """The joints' equations (:meth:`~physics.mechanism.joints.JointKind.rows`) evaluated in numpy for every joint
    of one kind at once: body ``s`` of the equations is the ``s``-th body each joint reaches (its ``bodies[s]``),
    every quantity an array over the joints. Rates may carry a leading axis (one set of rates per column of the
    Jacobian, :meth:`Constraints.jacobian`): the equations are elementwise, so they broadcast."""

    def __init__(self, frame: _Frame, bodies: np.ndarray, t: float, rate=None) -> None:
        self.x, self.y, self.angles = frame.at(frame.x, bodies), frame.at(frame.y, bodies), frame.at(frame.angle, bodies)
        self.cos, self.sin = frame.at(frame.cos, bodies), frame.at(frame.sin, bodies)  # (slots, J) or (slots, T, J)
        self.rate = rate  # by slot: (vx, vy, w), arrays broadcasting against (J,); None: at rest
        self.time = t

    def angle(self, body):
        return self.angles[body]

    def spin(self, body):
        return 0.0 if self.rate is None else self.rate[body][2]

    def alpha(self, body):
        return 0.0  # the numeric rows are read at zero accelerations: what is left is gamma's part

    def turned(self, body, vector):
        c, s = self.cos[body], self.sin[body]
        return (c * vector[0] - s * vector[1], s * vector[0] + c * vector[1])

    def point(self, body, arm):
        rho = self.turned(body, arm)
        position = (self.x[body] + rho[0], self.y[body] + rho[1])
        if self.rate is None:
            return position, (0.0, 0.0), (0.0, 0.0)
        vx, vy, w = self.rate[body]
        square = -w * w
        return position, (vx - w * rho[1], vy + w * rho[0]), (square * rho[0], square * rho[1])

    def plus(self, *terms):
        out = terms[0] if terms else 0.0
        for term in terms[1:]:
            out = out + term
        return out

    def times(self, *factors):
        out = factors[0] if factors else 1.0
        for factor in factors[1:]:
            out = out * factor
        return out

    def negative(self, x):
        return -x


class _Frame:
    """Every body's pose at one ``q`` (3 B), or at each of ``T`` samples (``q``: (T, 3 B)), the ground appended
    as body ``B`` at rest at the origin. A quantity by body is (B + 1,), or (B + 1, T) for samples."""

    def __init__(self, q: np.ndarray) -> None:
        q = np.asarray(q, dtype=float)
        self.batched = q.ndim == 2
        pose = np.zeros((q.shape[-1] // 3 + 1, 3, *q.shape[:-1]))
        pose[:-1] = np.reshape(q.T, (-1, 3, *q.shape[:-1]))
        self.x, self.y, self.angle = pose[:, 0], pose[:, 1], pose[:, 2]
        self.cos, self.sin = np.cos(self.angle), np.sin(self.angle)

    def at(self, quantity: np.ndarray, bodies: np.ndarray) -> np.ndarray:
        """``quantity`` of the bodies each joint reaches: (slots, J), or (slots, T, J) for samples, so that
        it broadcasts against the joints' values (J,) as the equations do for one pose."""
        picked = quantity[bodies]
        return picked.swapaxes(1, 2) if self.batched else picked


class _Group:
    """The joints of one kind (or the speed motors) as arrays: the bodies each reaches (``bodies``: slots by
    joints, the ground as body ``B``, a spare slot at rest), their parameter values and the global numbers of
    their rows (``rows``: rows by joints). ``equations(k)`` gives the rows in ``k``'s numbers."""

    def __init__(self, bodies: list[tuple[int, ...]], values: list[list[float]], rows: list[list[int]],
                 equations) -> None:
        self.bodies = np.array(bodies, dtype=int).T  # (slots, J)
        self.values = [np.array(column, dtype=float) for column in zip(*values, strict=True)] if values else []
        self.rows = np.array(rows, dtype=int).T  # (rows, J)
        self.equations = equations
        self.slots = range(len(self.bodies))
        columns = 3 * len(self.bodies)
        eye = np.eye(columns + 1, columns)[:, :, None]  # (columns + 1, columns, 1): the last set of rates all zero
        self._unit = [(eye[:, 3 * slot], eye[:, 3 * slot + 1], eye[:, 3 * slot + 2]) for slot in self.slots]
        eye = eye[..., None]  # for samples: (columns + 1, columns, 1, 1) broadcasts against (T, J)
        self._unit_samples = [(eye[:, 3 * slot], eye[:, 3 * slot + 1], eye[:, 3 * slot + 2]) for slot in self.slots]
        # the global column of each local one, by joint: (columns, J)
        self._columns = 3 * self.bodies[np.repeat(np.arange(len(self.bodies)), 3)] + np.arange(columns)[:, None] % 3
        self._flat: dict[int, np.ndarray] = {}

    def evaluate(self, frame: _Frame, t: float, rate=None) -> list:
        return self.equations(self.slots, self.values, _Numbers(frame, self.bodies, t, rate))

    def rates(self, qdot: np.ndarray) -> list:
        """Rates by slot from the bodies' rates (the ground's appended at rest)."""
        rate = np.vstack([np.reshape(np.asarray(qdot, dtype=float), (-1, 3)), np.zeros((1, 3))])[self.bodies]
        return [(slot[:, 0], slot[:, 1], slot[:, 2]) for slot in rate]

    def gradient(self, frame: _Frame, out: np.ndarray) -> None:
        """Add ``d row / d q`` of the group's rows to ``out`` (rows, width), or to every sample's (T, rows,
        width) for a frame of samples (the ground's columns last), read off their velocity forms at unit rates
        (one set per local column, a last set at rest for what does not hold a rate). ``out`` is C-contiguous
        (as :meth:`Constraints._gradients` makes it): its entries are added through a flat view of it, not
        ``out.flat`` (an iterator, thirty times slower over a run's samples)."""
        if not out.flags.c_contiguous:
            raise ValueError("gradient: out must be C-contiguous")
        entries_of_out = out.reshape(-1)  # a view
        width = out.shape[-1]
        flat = self._flat.get(width)
        if flat is None:  # where each (row, local column, joint) entry goes in one sample's ``out``, flattened
            flat = self._flat[width] = np.concatenate([(row[None, :] * width + self._columns).ravel()
                                                       for row in self.rows])
        columns = self._columns.shape[0]
        if not frame.batched:
            shape = (columns + 1, self.bodies.shape[1])
            entries = []
            for row in self.evaluate(frame, 0.0, self._unit):
                velocity = np.broadcast_to(row.velocity, shape)
                entries.append((velocity[:columns] - velocity[columns]).ravel())
            entries_of_out += np.bincount(flat, weights=np.concatenate(entries), minlength=out.size)
            return
        samples = out.shape[0]
        batch_shape = (columns + 1, samples, self.bodies.shape[1])
        entries = []
        for row in self.evaluate(frame, 0.0, self._unit_samples):
            velocity = np.broadcast_to(row.velocity, batch_shape)
            entries.append((velocity[:columns] - velocity[columns]).swapaxes(0, 1).reshape(samples, -1))
        where = flat[None, :] + (np.arange(samples) * (out.size // samples))[:, None]
        entries_of_out += np.bincount(where.ravel(), weights=np.concatenate(entries, axis=1).ravel(),
                                      minlength=out.size)


@dataclass(frozen=True)
class Row:
    """One scalar constraint, for error messages: which joint (or driver) and what it holds."""

    joint: str
    meaning: str


class Constraints:
    """``Phi(q, t)`` and ``Phi_q(q)`` of a mechanism; ``rows`` names every equation.

    Each joint kind's rows are its own (:meth:`~physics.mechanism.joints.JointKind.rows`, the function the
    derivations call with symbols), evaluated here in numpy for all joints of a kind at once; ``Phi_q`` is read
    off their velocity forms (exact: they are linear in the rates) and ``gamma`` off their acceleration forms."""

    def __init__(self, mechanism: Mechanism) -> None:
        self.mechanism = mechanism
        self.body_index = {body.name: k for k, body in enumerate(mechanism.bodies)}
        self.centres = np.array([body.centre for body in mechanism.bodies], dtype=float).reshape(-1, 2)
        self.size = 3 * len(mechanism.bodies)
        spare = len(mechanism.bodies)  # the ground's slot

        def body(name: str) -> int:
            return spare if name == GROUND else self.body_index[name]

        rows: list[Row] = []
        grouped: dict[str, tuple[list, list, list]] = {}  # kind -> (bodies, values, rows) by joint
        motors: tuple[list, list, list] = ([], [], [])
        dampers: tuple[list, list, list, list] = ([], [], [], [])  # kind, bodies, values, coefficient
        torques: tuple[list, list] = ([], [])  # bodies, torque
        speeds = {driver.joint: driver.speed for driver in mechanism.drivers if driver.speed is not None}
        for joint in mechanism.joints:
            kind = kind_of(joint)
            reach = kind.structure_bodies(joint, body, mechanism)
            values = kind.values(joint, mechanism)
            group = grouped.setdefault(kind.name, ([], [], []))
            group[0].append(reach)
            group[1].append(values)
            group[2].append(list(range(len(rows), len(rows) + len(kind.meanings))))
            rows += [Row(joint.name, meaning) for meaning in kind.meanings]
            if "damping" in kind.fields:
                dampers[0].append(kind.name)
                dampers[1].append(reach)
                dampers[2].append(values)
                dampers[3].append(values[kind.fields.index("damping")])
            if joint.name in speeds:
                motors[0].append(reach[:2])
                motors[1].append([float(speeds[joint.name])])
                motors[2].append(list(range(len(rows), len(rows) + len(MOTOR.meanings))))
                rows += [Row(joint.name, meaning) for meaning in MOTOR.meanings]
        for driver in mechanism.drivers:
            if driver.torque is not None:
                joint = next(j for j in mechanism.joints if j.name == driver.joint)
                torques[0].append(kind_of(joint).structure_bodies(joint, body, mechanism)[:2])
                torques[1].append(float(driver.torque))
        self.rows = tuple(rows)
        self._groups = [_Group(*group, KINDS[name].rows) for name, group in grouped.items()]
        if motors[0]:
            self._groups.append(_Group(*motors, _motor_rows))
        # one row per damped joint, in joint order: the relative motion its damper resists
        self.damping = np.array(dampers[3], dtype=float)
        by_kind: dict[str, tuple[list, list, list]] = {}
        for number, (name, reach, values) in enumerate(zip(*dampers[:3], strict=True)):
            group = by_kind.setdefault(name, ([], [], []))
            group[0].append(reach)
            group[1].append(values)
            group[2].append([number])
        self._dampers = [_Group(*group, _damper_rows(KINDS[name])) for name, group in by_kind.items()]
        self._sliding = [number for number, (name, values) in enumerate(zip(dampers[0], dampers[2], strict=True))
                         if isinstance(KINDS[name].freedom(values), Translation)]
        self.torque = np.array(torques[1], dtype=float)
        self._driven = ([_Group(torques[0], [], [[n] for n in range(len(torques[0]))], _driven_rows)]
                        if torques[0] else [])

    def _gradients(self, groups: list[_Group], count: int, q: np.ndarray) -> np.ndarray:
        """The rows' gradients at ``q`` (count, 3 B), or at every sample of ``q`` (T, 3 B) -> (T, count, 3 B)
        in one pass (a run's reactions and conditions, not a loop over its samples)."""
        frame = _Frame(q)
        out = np.zeros((*np.shape(q)[:-1], count, self.size + 3))  # three spare columns take the ground's entries
        for group in groups:
            group.gradient(frame, out)
        return out[..., : self.size]

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
        frame = _Frame(q)
        out = np.empty(len(self.rows))
        for group in self._groups:
            for number, row in enumerate(group.evaluate(frame, t)):
                out[group.rows[number]] = row.position
        return out

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        return self._gradients(self._groups, len(self.rows), q)

    def damper_jacobian(self, q: np.ndarray) -> np.ndarray:
        """``(D, 3 B)``: for each joint with a damper (joint order; ``damping`` its coefficients) the gradient of
        the relative motion its damper resists (:meth:`~physics.mechanism.joints.JointKind.damper`). Its
        product with ``qdot`` is that motion's speed; the damper's generalised force is ``-c J_d^T J_d qdot``,
        whose power is ``-c (J_d qdot)^2``."""
        return self._gradients(self._dampers, len(self.damping), q)

    def sliding_jacobian(self, q: np.ndarray) -> np.ndarray:
        """``(S, 3 B)``: the rows of :meth:`damper_jacobian` of the joints that carry a travel
        (:class:`~physics.mechanism.joints.Translation`, the sliders), in joint order: the gradient of the
        sliding point's distance from the guide's through point along the guide."""
        return self.damper_jacobian(q)[self._sliding]

    def driven_jacobian(self, q: np.ndarray) -> np.ndarray:
        """``(T, 3 B)``: for each torque motor (driver order; ``torque`` its torques) the gradient of its joint's
        relative rotation: the motor's generalised force is ``J_t^T torque``."""
        return self._gradients(self._driven, len(self.torque), q)

    def velocity_rhs(self) -> np.ndarray:
        """``nu`` with ``Phi_q qdot = nu``: minus the explicit time derivative, non-zero on driven rows only."""
        frame = _Frame(self.sketch_pose())
        out = np.zeros(len(self.rows))
        for group in self._groups:
            for number, row in enumerate(group.evaluate(frame, 0.0)):
                out[group.rows[number]] = -np.broadcast_to(row.velocity, group.rows[number].shape)
        return out

    def acceleration_rhs(self, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
        """``gamma`` with ``Phi_q qddot = gamma``: the terms of the second time derivative of ``Phi`` that do not
        hold ``qddot`` (centripetal and Coriolis terms), moved to the right-hand side."""
        frame = _Frame(q)
        out = np.zeros(len(self.rows))
        for group in self._groups:
            for number, row in enumerate(group.evaluate(frame, 0.0, group.rates(qdot))):
                out[group.rows[number]] = -np.broadcast_to(row.acceleration, group.rows[number].shape)
        return out


def _motor_rows(bodies, values, k):
    return MOTOR.rows(bodies, values[0], k)


def _driven_rows(bodies, values, k):
    return [MOTOR.driven(bodies, k)]


def _damper_rows(kind):
    def rows(bodies, values, k):
        return [kind.damper(bodies, values, k)]

    return rows
