"""The maximal-coordinate DAE of any mechanism structure, numbers as parameter symbols.

Body i's pose ``q_i = (x_i, y_i, phi_i)``: its centre of mass and its rotation from the sketch, so its point at
``arm`` (from the sketch's centre of mass) is at ``r_i + R(phi_i) arm``. As the chain's DAE
(physics/derive/dae.py), per body

    linear momentum   m_i a_i = sum of the forces on it + m_i g_vec
    angular momentum  I_i alpha_i = sum of (point - r_i) x force + torques        (about its centre of mass)

and, per joint, its constraints differentiated twice through rigid-body kinematics (a point at ``rho`` from G
accelerates with ``a + alpha perp(rho) - w^2 rho``), as its kind writes them
(:meth:`physics.mechanism.joints.JointKind.rows` against this module's kinematics): a pin's two points accelerate
together; a slider's point keeps its offset across the turning guide and the two bodies their relative angle; a
speed motor's relative angular acceleration is zero. The multipliers are the loads each kind's rows name, in the
layout and signs of :class:`physics.mechanism.constraints.Constraints` (a pin's: the force ON body ``a`` BY body
``b``; a slider's: the force across the guide on its body, at the sliding point, and the torque on its body; a
motor's: its torque on ``b``). ``A`` and ``b`` are read off these linear equations; the
constraint Jacobian off the velocity-level statements. Nothing is taken from the tree formulations.
"""

from __future__ import annotations

from types import SimpleNamespace

import sympy as sp

from ..derive.formulation import LinearSystem
from .joints import KINDS, MOTOR, Kinematics
from .joints.loads import BodyLoads, applied_loads
from .parameters import Structure
from .symbolic_parameters import ParameterSymbols
from .symbolic_tree import (
    ORIGIN,
    ZERO,
    LinearReader,
    SympyNumbers,
    add,
    cross,
    negative,
    perp,
    plus,
    scale,
    settle,
    sub,
    times,
    turn,
)


class _Bodies(SympyNumbers, Kinematics):
    """Poses, rates and accelerations of the bodies in the maximal coordinates; the ground at rest."""

    def __init__(self, count: int, t) -> None:
        self.time = t
        self.q = tuple(sp.symbols(f"q0:{3 * count}", real=True))
        self.qd = tuple(sp.symbols(f"qd0:{3 * count}", real=True))
        self.qdd = tuple(sp.symbols(f"qdd0:{3 * count}", real=True))

    def angle(self, body: int):
        return ZERO if body < 0 else self.q[3 * body + 2]

    def spin(self, body: int):
        return ZERO if body < 0 else self.qd[3 * body + 2]

    def alpha(self, body: int):
        return ZERO if body < 0 else self.qdd[3 * body + 2]

    def turned(self, body: int, vector):
        return turn(self.angle(body), tuple(vector))

    def centre(self, body: int):
        return self.q[3 * body : 3 * body + 2]

    def point(self, body: int, arm) -> tuple[tuple, tuple, tuple]:
        """Position, velocity and acceleration of the point at ``arm`` from ``body``'s centre of mass."""
        if body < 0:
            return tuple(arm), ORIGIN, ORIGIN
        rho = turn(self.angle(body), tuple(arm))
        spin, alpha = self.spin(body), self.alpha(body)
        position = add(self.centre(body), rho)
        velocity = add(self.qd[3 * body : 3 * body + 2], scale(spin, perp(rho)))
        acceleration = add(self.qdd[3 * body : 3 * body + 2], scale(alpha, perp(rho)),
                           scale(negative(times(spin, spin)), rho))
        return position, velocity, acceleration


def derive_dae(shape: Structure, params: ParameterSymbols) -> LinearSystem:
    bodies = _Bodies(shape.bodies, params.t)
    size = 3 * shape.bodies
    speed_driven = shape.speed_driven
    joint_rows = []  # (joint, meanings, rows): each joint's rows, then its speed motor's
    for k, joint in enumerate(shape.joints):
        kind = KINDS[joint.kind]
        joint_rows.append((k, kind.meanings, kind.rows(joint.bodies, params.joints[k].values, bodies)))
        if k in speed_driven:  # the motor's torque on b, minus on a; holds phi_b - phi_a = speed t
            joint_rows.append((k, MOTOR.meanings,
                               MOTOR.rows(joint.bodies[:2], params.drivers[speed_driven[k]], bodies)))
    count = sum(len(rows) for _, _, rows in joint_rows)
    lam = list(sp.symbols(f"lam0:{count}", real=True))
    loads = BodyLoads(shape.bodies, bodies)
    phi: list = []
    velocity_rows: list = []
    acceleration_rows: list = []
    row_names: list[tuple[int, str]] = []
    for k, meanings, rows in joint_rows:
        for part, row in enumerate(rows):
            loads.apply(row, lam[len(phi)])
            phi.append(row.position)
            velocity_rows.append(row.velocity)
            acceleration_rows.append(row.acceleration)
            row_names.append((k, meanings[part]))
    for row, magnitude in applied_loads(shape, params, bodies):
        loads.apply(row, magnitude)
    forces, torques = loads.forces, loads.torques

    balances, names = [], []
    for i in range(shape.bodies):
        mass, inertia = params.bodies[i].mass, params.bodies[i].inertia
        centre = bodies.centre(i)
        net = add((ZERO, negative(times(mass, params.g))), *(force for force, _ in forces[i]))
        moment = plus(*(cross(sub(point, centre), force) for force, point in forces[i]), *torques[i])
        balances += [plus(times(mass, bodies.qdd[3 * i]), negative(net[0])),
                     plus(times(mass, bodies.qdd[3 * i + 1]), negative(net[1])),
                     plus(times(inertia, bodies.qdd[3 * i + 2]), negative(moment))]
        names += [f"LMB {{b{i}}} (x)", f"LMB {{b{i}}} (y)", f"AMB {{b{i}}} about its centre of mass"]

    memo: dict = {}
    A, b = LinearReader(list(bodies.qdd) + lam).system(balances + acceleration_rows)
    jacobian, _ = LinearReader(bodies.qd).system(velocity_rows) if count else (sp.zeros(0, size), None)
    names += [f"{{j{k}}}: {meaning}''" for k, meaning in row_names]
    return LinearSystem(
        formulation="dae",
        n=size,
        pinned=False,
        symbols=SimpleNamespace(theta=list(bodies.q), omega=list(bodies.qd), params=list(params.vector)),  # type: ignore[arg-type]  # LinearSystem.symbols is typed ChainSymbols
        A=settle(A, memo),
        b=settle(b, memo),
        unknowns=list(bodies.qdd) + lam,
        equation_names=names,
        theta_ddot_index=list(range(size)),
        constraint_rows=tuple(range(size, size + count)),
        constraint=settle(sp.Matrix(count, 1, phi), memo),
        constraint_jacobian=settle(jacobian, memo),
        constraint_rate=settle(sp.Matrix(count, 1, velocity_rows), memo),
        multiplier_index=tuple(range(size, size + count)),
        time_index=params.vector.index(params.t) if speed_driven else None,
        kinematics=None,
    )
