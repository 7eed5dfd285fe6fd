"""Newton–Euler equations of any mechanism structure on its spanning tree, numbers as parameter symbols.

As the seed report writes the triple pendulum's equations (and physics/derive/newton_euler.py any chain's): for
every tree joint, the bodies beyond it (its subtree) taken together, so that the joint's own reaction drops out:

* a pin at P: ``sum over the subtree of (G - P) x m a_G + I alpha = moments about P of gravity, of the cut
  joints' and motors' forces and torques on the subtree, and of damping``;
* a slider along ``e``: ``sum of m a_G . e = (gravity and the forces on the subtree) . e``.

The accelerations come from rigid-body kinematics, body after body from the ground: a point at ``rho`` from a
body's centre of mass moves with ``a_G + alpha perp(rho) - w^2 rho``; a pin adds its coordinate's rate to the
child's spin; a slider adds the sliding terms ``u sdd + 2 w perp(u) sd`` along its turning guide. The closures
(cut joints, speed motors) are the same statements about their points' accelerations, with the multipliers as
the forces they apply. The matrix is read off the equations (:func:`physics.derive.formulation.linear_system`);
the constraint Jacobian off the velocity-level statements. Nothing comes from the Lagrange or DAE derivations:
only the structure and the tree's positions (:mod:`.symbolic_tree`).
"""

from __future__ import annotations

from types import SimpleNamespace

import sympy as sp

from ..derive.formulation import LinearSystem
from .parameters import ParameterSymbols, Structure
from .symbolic_tree import (
    ORIGIN,
    ZERO,
    LinearReader,
    TreeGeometry,
    add,
    cross,
    dot,
    names_template,
    negative,
    perp,
    plus,
    scale,
    settle,
    sub,
    times,
    tree_geometry,
)

TWO = sp.Integer(2)


class _Motion:
    """Every body's spin, angular acceleration, centre velocity and acceleration, by rigid-body kinematics."""

    def __init__(self, geometry: TreeGeometry) -> None:
        self.geometry = geometry
        self.spin: dict = {-1: ZERO}
        self.alpha: dict = {-1: ZERO}
        self.velocity: dict = {-1: ORIGIN}
        self.acceleration: dict = {-1: ORIGIN}
        shape, params = geometry.shape, geometry.params
        s, sd, sdd = geometry.s, geometry.sd, geometry.sdd
        for index, body in enumerate(geometry.tree.order):
            k, parent = geometry.tree.parent[body]
            joint, symbols = shape.joints[k], params.joints[k]
            if joint.kind == "revolute":
                child_arm, parent_arm = ((symbols.arm_a, symbols.arm_b) if joint.a == body
                                         else (symbols.arm_b, symbols.arm_a))
                velocity, acceleration = self.point(parent, parent_arm)
                self.spin[body] = plus(self.spin[parent], sd[index])
                self.alpha[body] = plus(self.alpha[parent], sdd[index])
                end_arm = child_arm
            else:
                sign = sp.Integer(1 if body == joint.a else -1)
                start_arm, end_arm = (symbols.arm_b, symbols.arm_a) if body == joint.a else (symbols.arm_a, symbols.arm_b)
                velocity, acceleration = self.point(parent, start_arm)
                spin, alpha = self.spin[parent], self.alpha[parent]
                assert symbols.direction is not None
                along = scale(sign, geometry.turned(parent, tuple(symbols.direction)))
                travel = plus(geometry.offsets[k], s[index])
                # d/dt (u d) = w perp(u) d + u sd;  d2/dt2 = (alpha perp(u) - w^2 u) d + 2 w perp(u) sd + u sdd
                velocity = add(velocity, scale(times(spin, travel), perp(along)), scale(sd[index], along))
                acceleration = add(acceleration, scale(times(alpha, travel), perp(along)),
                                   scale(negative(times(spin, spin, travel)), along),
                                   scale(times(TWO, spin, sd[index]), perp(along)), scale(sdd[index], along))
                self.spin[body], self.alpha[body] = spin, alpha
            # the centre of mass is at -rho from the joint's point on this body
            rho = geometry.rho(body, tuple(end_arm))
            spin, alpha = self.spin[body], self.alpha[body]
            self.velocity[body] = sub(velocity, scale(spin, perp(rho)))
            self.acceleration[body] = sub(acceleration, add(scale(alpha, perp(rho)),
                                                            scale(negative(times(spin, spin)), rho)))

    def point(self, body: int, arm) -> tuple[tuple, tuple]:
        """Velocity and acceleration of the point at ``arm`` from ``body``'s centre of mass (ground: at rest)."""
        if body < 0:
            return ORIGIN, ORIGIN
        rho = self.geometry.rho(body, tuple(arm))
        spin, alpha = self.spin[body], self.alpha[body]
        velocity = add(self.velocity[body], scale(spin, perp(rho)))
        acceleration = add(self.acceleration[body], scale(alpha, perp(rho)), scale(negative(times(spin, spin)), rho))
        return velocity, acceleration


def derive_newton_euler(shape: Structure, params: ParameterSymbols) -> LinearSystem:
    geometry = tree_geometry(shape, params)
    motion = _Motion(geometry)
    s, sd, sdd = geometry.s, geometry.sd, geometry.sdd
    tree = geometry.tree
    n, bodies = len(s), shape.bodies
    centre = geometry.centre
    phi, row_names = geometry.closure_rows()
    count = len(phi)
    lam = list(sp.symbols(f"lam0:{count}", real=True))

    forces: dict[int, list] = {body: [] for body in range(bodies)}  # (force, point of application)
    torques: dict[int, list] = {body: [] for body in range(bodies)}

    def push(body: int, force, point) -> None:
        if body >= 0:
            forces[body].append((force, point))

    def twist(body: int, torque) -> None:
        if body >= 0:
            torques[body].append(torque)

    velocity_rows, acceleration_rows = [], []
    row = 0
    while row < count:
        closure = row_names[row]
        joint, symbols = shape.joints[closure.joint], params.joints[closure.joint]
        if closure.kind == "angle":  # sum c angle(body): a torque c lambda on each body; sum c w = rate
            assert closure.angle is not None
            for c, body in closure.angle.terms:
                twist(body, times(c, lam[row]))
            velocity_rows.append(plus(*(times(c, motion.spin[body]) for c, body in closure.angle.terms),
                                      negative(closure.angle.rate)))
            acceleration_rows.append(plus(*(times(c, motion.alpha[body]) for c, body in closure.angle.terms)))
            row += 1
            continue
        point_a, point_b = geometry.world(joint.a, symbols.arm_a), geometry.world(joint.b, symbols.arm_b)
        (v_a, a_a), (v_b, a_b) = motion.point(joint.a, symbols.arm_a), motion.point(joint.b, symbols.arm_b)
        if closure.kind == "pin":  # force ON a BY b at the pin; the two points move together
            force = (lam[row], lam[row + 1])
            push(joint.a, force, point_a)
            push(joint.b, scale(sp.Integer(-1), force), point_b)
            velocity_rows += list(sub(v_a, v_b))
            acceleration_rows += list(sub(a_a, a_b))
        else:  # force across the guide at the sliding point and the torque holding the relative angle
            _, normal = geometry.guide(closure.joint)
            push(joint.a, scale(lam[row], normal), point_a)
            push(joint.b, scale(negative(lam[row]), normal), point_a)
            twist(joint.a, lam[row + 1])
            twist(joint.b, negative(lam[row + 1]))
            spin, alpha = motion.spin[joint.b], motion.alpha[joint.b]
            gap, gap_rate, gap_acceleration = sub(point_a, point_b), sub(v_a, v_b), sub(a_a, a_b)
            # n' = w perp(n), n'' = alpha perp(n) - w^2 n
            velocity_rows.append(plus(times(spin, dot(perp(normal), gap)), dot(normal, gap_rate)))
            acceleration_rows.append(plus(times(alpha, dot(perp(normal), gap)),
                                          negative(times(spin, spin, dot(normal, gap))),
                                          times(TWO, spin, dot(perp(normal), gap_rate)),
                                          dot(normal, gap_acceleration)))
            velocity_rows.append(plus(motion.spin[joint.a], negative(motion.spin[joint.b])))
            acceleration_rows.append(plus(motion.alpha[joint.a], negative(motion.alpha[joint.b])))
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
            relative = plus(motion.spin[joint.b], negative(motion.spin[joint.a]))
            twist(joint.b, negative(times(symbols.damping, relative)))
            twist(joint.a, times(symbols.damping, relative))
            continue
        # -c (sliding speed) along the guide on the slider at its sliding point, the opposite on the guide's body
        along, _ = geometry.guide(number)
        point_a, point_b = geometry.world(joint.a, symbols.arm_a), geometry.world(joint.b, symbols.arm_b)
        (v_a, _), (v_b, _) = motion.point(joint.a, symbols.arm_a), motion.point(joint.b, symbols.arm_b)
        speed = plus(times(motion.spin[joint.b], dot(perp(along), sub(point_a, point_b))), dot(along, sub(v_a, v_b)))
        push(joint.a, scale(negative(times(symbols.damping, speed)), along), point_a)
        push(joint.b, scale(times(symbols.damping, speed), along), point_a)

    beyond: dict[int, set[int]] = {body: {body} for body in tree.order}
    for body in reversed(tree.order):  # children before parents
        parent = tree.parent[body][1]
        if parent >= 0:
            beyond[parent] |= beyond[body]
    gravity = (ZERO, negative(params.g))
    balances, names = [], []
    for index, body in enumerate(tree.order):
        k = tree.parent[body][0]
        joint, symbols = shape.joints[k], params.joints[k]
        members = sorted(beyond[body])
        mass = {i: params.bodies[i].mass for i in members}
        if joint.kind == "revolute":
            pivot = geometry.world(body, symbols.arm_a if joint.a == body else symbols.arm_b)
            inertial = plus(*(plus(cross(sub(centre[i], pivot), scale(mass[i], motion.acceleration[i])),
                                   times(params.bodies[i].inertia, motion.alpha[i])) for i in members))
            applied = plus(*(cross(sub(centre[i], pivot), scale(mass[i], gravity)) for i in members),
                           *(cross(sub(point, pivot), force) for i in members for force, point in forces[i]),
                           *(torque for i in members for torque in torques[i]))
            names.append(f"AMB of the bodies beyond {{j{k}}} about it")
        else:
            along, _ = geometry.guide(k)
            inertial = plus(*(times(mass[i], dot(motion.acceleration[i], along)) for i in members))
            applied = plus(*(times(mass[i], dot(gravity, along)) for i in members),
                           *(dot(force, along) for i in members for force, _ in forces[i]))
            names.append(f"LMB of the bodies beyond {{j{k}}} along its guide")
        balances.append(plus(inertial, negative(applied)))

    memo: dict = {}
    A, b = LinearReader(list(sdd) + lam).system(balances + acceleration_rows)
    by_rates = LinearReader(sd)
    jacobian, _ = by_rates.system(velocity_rows) if count else (sp.zeros(0, n), None)
    pose, rates, accelerations = [], [], []
    for i in range(bodies):
        pose += [*centre[i], geometry.angle[i]]
        rates += [*motion.velocity[i], motion.spin[i]]
        accelerations += [*motion.acceleration[i], motion.alpha[i]]
    pose_jacobian, _ = by_rates.system(rates)
    _, minus_bias = LinearReader(sdd).system(accelerations)
    return LinearSystem(
        formulation="newton_euler",
        n=n,
        pinned=False,
        symbols=SimpleNamespace(theta=list(s), omega=list(sd), params=list(params.vector)),  # type: ignore[arg-type]  # LinearSystem.symbols is typed ChainSymbols
        A=settle(A, memo),
        b=settle(b, memo),
        unknowns=list(sdd) + lam,
        equation_names=names + names_template(shape, row_names),
        theta_ddot_index=list(range(n)),
        constraint_rows=tuple(range(n, n + count)),
        constraint=settle(sp.Matrix(count, 1, phi), memo),
        constraint_jacobian=settle(jacobian, memo),
        constraint_rate=settle(sp.Matrix(count, 1, velocity_rows), memo),
        multiplier_index=tuple(range(n, n + count)),
        time_index=params.vector.index(params.t) if any(d.kind == "speed" for d in shape.drivers) else None,
        kinematics=(settle(sp.Matrix(pose), memo), settle(pose_jacobian, memo), settle(-minus_bias, memo)),
    )
