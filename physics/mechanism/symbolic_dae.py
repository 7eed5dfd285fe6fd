"""The maximal-coordinate DAE of any mechanism structure, numbers as parameter symbols.

Body i's pose ``q_i = (x_i, y_i, phi_i)``: its centre of mass and its rotation from the sketch, so its point at
``arm`` (from the sketch's centre of mass) is at ``r_i + R(phi_i) arm``. As the chain's DAE
(physics/derive/dae.py), per body

    linear momentum   m_i a_i = sum of the forces on it + m_i g_vec
    angular momentum  I_i alpha_i = sum of (point - r_i) x force + torques        (about its centre of mass)

and, per joint, its constraints differentiated twice through rigid-body kinematics (a point at ``rho`` from G
accelerates with ``a + alpha perp(rho) - w^2 rho``): a pin's two points accelerate together; a slider's point
keeps its offset across the turning guide (``n'' . g + 2 n' . g' + n . g'' = 0``) and the two bodies their
relative angle; a speed motor's relative angular acceleration is zero. The multipliers are the forces the joints
apply, in the layout and signs of :class:`physics.mechanism.constraints.Constraints` (a pin's: the force ON
body ``a`` BY body ``b``; a slider's: the force across the guide on its body, at the sliding point, and the
torque on its body; a motor's: its torque on ``b``). ``A`` and ``b`` are read off these linear equations; the
constraint Jacobian off the velocity-level statements. Nothing is taken from the tree formulations.
"""

from __future__ import annotations

from types import SimpleNamespace

import sympy as sp

from ..derive.formulation import LinearSystem
from .joints import KINDS, MOTOR
from .parameters import ParameterSymbols, Structure
from .symbolic_tree import (
    ORIGIN,
    ZERO,
    LinearReader,
    add,
    cross,
    dot,
    negative,
    perp,
    plus,
    scale,
    settle,
    sub,
    times,
    turn,
)

TWO = sp.Integer(2)


class _Bodies:
    """Poses, rates and accelerations of the bodies in the maximal coordinates; the ground at rest."""

    def __init__(self, count: int) -> None:
        self.q = tuple(sp.symbols(f"q0:{3 * count}", real=True))
        self.qd = tuple(sp.symbols(f"qd0:{3 * count}", real=True))
        self.qdd = tuple(sp.symbols(f"qdd0:{3 * count}", real=True))

    def angle(self, body: int):
        return ZERO if body < 0 else self.q[3 * body + 2]

    def spin(self, body: int):
        return ZERO if body < 0 else self.qd[3 * body + 2]

    def alpha(self, body: int):
        return ZERO if body < 0 else self.qdd[3 * body + 2]

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
    bodies = _Bodies(shape.bodies)
    size = 3 * shape.bodies
    speed_driven = shape.speed_driven
    count = sum(len(KINDS[joint.kind].meanings) + len(MOTOR.meanings) * (k in speed_driven)
                for k, joint in enumerate(shape.joints))
    lam = list(sp.symbols(f"lam0:{count}", real=True))
    forces: dict[int, list] = {body: [] for body in range(shape.bodies)}
    torques: dict[int, list] = {body: [] for body in range(shape.bodies)}

    def push(body: int, force, point) -> None:
        if body >= 0:
            forces[body].append((force, point))

    def twist(body: int, torque) -> None:
        if body >= 0:
            torques[body].append(torque)

    phi, velocity_rows, acceleration_rows, row_names = [], [], [], []
    row = 0

    def angle_rows(k: int, rows, meanings) -> None:
        """Rows ``sum c angle(body) - constant - rate t``: a torque ``c lambda`` on each body of the sum."""
        nonlocal row
        for part, angle_row in enumerate(rows):
            for c, body in angle_row.terms:
                twist(body, times(c, lam[row]))
            phi.append(plus(*(times(c, bodies.angle(body)) for c, body in angle_row.terms),
                            negative(angle_row.constant), negative(times(angle_row.rate, params.t))))
            velocity_rows.append(plus(*(times(c, bodies.spin(body)) for c, body in angle_row.terms),
                                      negative(angle_row.rate)))
            acceleration_rows.append(plus(*(times(c, bodies.alpha(body)) for c, body in angle_row.terms)))
            row_names.append((k, meanings[part]))
            row += 1

    for k, joint in enumerate(shape.joints):
        symbols = params.joints[k]
        kind = KINDS[joint.kind]
        if joint.kind not in ("revolute", "prismatic"):
            angle_rows(k, kind.angle_rows(joint.bodies, symbols.values), kind.meanings)
            continue
        (p_a, v_a, a_a), (p_b, v_b, a_b) = bodies.point(joint.a, symbols.arm_a), bodies.point(joint.b, symbols.arm_b)
        spin_a, spin_b = bodies.spin(joint.a), bodies.spin(joint.b)
        alpha_a, alpha_b = bodies.alpha(joint.a), bodies.alpha(joint.b)
        if joint.kind == "revolute":
            force = (lam[row], lam[row + 1])
            push(joint.a, force, p_a)
            push(joint.b, scale(sp.Integer(-1), force), p_b)
            phi += list(sub(p_a, p_b))
            velocity_rows += list(sub(v_a, v_b))
            acceleration_rows += list(sub(a_a, a_b))
            row_names += [(k, meaning) for meaning in kind.meanings]
            row += 2
            if k in speed_driven:  # the motor's torque on b, minus on a; holds phi_b - phi_a = speed t
                angle_rows(k, MOTOR.angle_rows(joint.bodies, params.drivers[speed_driven[k]]), MOTOR.meanings)
            continue
        assert symbols.direction is not None
        normal = turn(bodies.angle(joint.b), perp(tuple(symbols.direction)))
        push(joint.a, scale(lam[row], normal), p_a)
        push(joint.b, scale(negative(lam[row]), normal), p_a)
        twist(joint.a, lam[row + 1])
        twist(joint.b, negative(lam[row + 1]))
        gap, gap_rate, gap_acceleration = sub(p_a, p_b), sub(v_a, v_b), sub(a_a, a_b)
        # n' = w perp(n), n'' = alpha perp(n) - w^2 n, w the guide's spin
        phi += [dot(normal, gap), plus(bodies.angle(joint.a), negative(bodies.angle(joint.b)))]
        velocity_rows += [plus(times(spin_b, dot(perp(normal), gap)), dot(normal, gap_rate)),
                          plus(spin_a, negative(spin_b))]
        acceleration_rows += [plus(times(alpha_b, dot(perp(normal), gap)),
                                   negative(times(spin_b, spin_b, dot(normal, gap))),
                                   times(TWO, spin_b, dot(perp(normal), gap_rate)), dot(normal, gap_acceleration)),
                              plus(alpha_a, negative(alpha_b))]
        row_names += [(k, meaning) for meaning in kind.meanings]
        row += 2

    for number, driver in enumerate(shape.drivers):
        if driver.kind == "torque":
            joint = shape.joints[driver.joint]
            twist(joint.b, params.drivers[number])
            twist(joint.a, negative(params.drivers[number]))
    for number, joint in enumerate(shape.joints):
        symbols = params.joints[number]
        if "damping" not in symbols.fields:
            continue
        if joint.kind == "revolute":
            relative = plus(bodies.spin(joint.b), negative(bodies.spin(joint.a)))
            twist(joint.b, negative(times(symbols.damping, relative)))
            twist(joint.a, times(symbols.damping, relative))
            continue
        # -c (sliding speed) along the guide on the slider at its sliding point, the opposite on the guide's body
        assert symbols.direction is not None
        along = turn(bodies.angle(joint.b), tuple(symbols.direction))
        (p_a, v_a, _), (p_b, v_b, _) = bodies.point(joint.a, symbols.arm_a), bodies.point(joint.b, symbols.arm_b)
        speed = plus(times(bodies.spin(joint.b), dot(perp(along), sub(p_a, p_b))), dot(along, sub(v_a, v_b)))
        push(joint.a, scale(negative(times(symbols.damping, speed)), along), p_a)
        push(joint.b, scale(times(symbols.damping, speed), along), p_a)

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
