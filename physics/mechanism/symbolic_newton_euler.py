"""Newton–Euler equations of any mechanism structure on its spanning tree, numbers as parameter symbols.

As the seed report writes the triple pendulum's equations (and physics/derive/newton_euler.py any chain's): for
every tree joint, the bodies beyond it (its subtree) taken together, so that the joint's own reaction drops out:

* a pin at P: ``sum over the subtree of (G - P) x m a_G + I alpha = moments about P of gravity, of the cut
  joints' and motors' forces and torques on the subtree, and of damping``;
* a slider along ``e``: ``sum of m a_G . e = (gravity and the forces on the subtree) . e``.

The accelerations come from rigid-body kinematics, body after body from the ground: a point at ``rho`` from a
body's centre of mass moves with ``a_G + alpha perp(rho) - w^2 rho``; a pin adds its coordinate's rate to the
child's spin (with absolute rotations its rate is the child's spin); a slider adds the sliding terms ``u sdd + 2 w perp(u) sd`` along its turning guide. The closures
(cut joints, speed motors) are the same statements about their points' accelerations, with the multipliers as
the forces they apply. The matrix is read off the equations (:func:`physics.derive.formulation.linear_system`);
the constraint Jacobian off the velocity-level statements. Nothing comes from the Lagrange or DAE derivations:
only the structure and the tree's positions (:mod:`.symbolic_tree`).
"""

from __future__ import annotations

from types import SimpleNamespace

import sympy as sp

from ..derive.formulation import LinearSystem
from .joints import Rotation, Translation
from .joints.loads import BodyLoads, applied_loads
from .parameters import Structure
from .symbolic_parameters import ParameterSymbols
from .symbolic_tree import (
    ORIGIN,
    ZERO,
    LinearReader,
    TreeGeometry,
    TreeKinematics,
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
        shape = geometry.shape
        s, sd, sdd = geometry.s, geometry.sd, geometry.sdd
        for index, body in enumerate(geometry.tree.order):
            k, parent = geometry.tree.parent[body]
            joint = shape.joints[k]
            freedom = geometry.freedom(k)
            if isinstance(freedom, Rotation):
                child_arm, parent_arm = ((freedom.arm_a, freedom.arm_b) if joint.a == body
                                         else (freedom.arm_b, freedom.arm_a))
                velocity, acceleration = self.point(parent, parent_arm)
                if geometry.rotations == "absolute":  # the coordinate is the child's own rotation
                    self.spin[body], self.alpha[body] = sd[index], sdd[index]
                else:
                    self.spin[body] = plus(self.spin[parent], sd[index])
                    self.alpha[body] = plus(self.alpha[parent], sdd[index])
                end_arm = child_arm
            else:
                assert isinstance(freedom, Translation), f"joint {k}: a tree joint carries a rotation or a travel"
                sign = sp.Integer(1 if body == joint.a else -1)
                start_arm, end_arm = ((freedom.arm_b, freedom.arm_a) if body == joint.a
                                      else (freedom.arm_a, freedom.arm_b))
                velocity, acceleration = self.point(parent, start_arm)
                spin, alpha = self.spin[parent], self.alpha[parent]
                along = scale(sign, geometry.turned(parent, tuple(freedom.direction)))
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


class _Kinematics(TreeKinematics):
    """The joints' equations in the tree coordinates: positions from the tree, velocities and accelerations body
    after body (:class:`_Motion`)."""

    def __init__(self, geometry: TreeGeometry, motion: _Motion) -> None:
        super().__init__(geometry, motion.spin, motion.alpha)
        self.motion = motion

    def point(self, body, arm):
        return (self.geometry.world(body, arm), *self.motion.point(body, arm))


def derive_newton_euler(shape: Structure, params: ParameterSymbols, rotations: str = "relative") -> LinearSystem:
    """The system of the module's text; ``rotations``: what a pin's coordinate is (:mod:`.symbolic_tree`): the
    balances are the same statements either way, only the unknowns ``sdd`` they are read off in differ."""
    geometry = tree_geometry(shape, params, rotations)
    motion = _Motion(geometry)
    s, sd, sdd = geometry.s, geometry.sd, geometry.sdd
    tree = geometry.tree
    n, bodies = len(s), shape.bodies
    centre = geometry.centre
    kinematics = _Kinematics(geometry, motion)
    closures, row_names = geometry.closure_rows(kinematics)
    count = len(closures)
    lam = list(sp.symbols(f"lam0:{count}", real=True))

    loads = BodyLoads(bodies, kinematics)
    phi, velocity_rows, acceleration_rows = [], [], []
    for number, row in enumerate(closures):
        loads.apply(row, lam[number])
        phi.append(row.position)
        velocity_rows.append(row.velocity)
        acceleration_rows.append(row.acceleration)
    for row, magnitude in applied_loads(shape, params, kinematics):
        loads.apply(row, magnitude)
    forces, torques = loads.forces, loads.torques  # (force, point of application) and torques, by body

    beyond: dict[int, set[int]] = {body: {body} for body in tree.order}
    for body in reversed(tree.order):  # children before parents
        parent = tree.parent[body][1]
        if parent >= 0:
            beyond[parent] |= beyond[body]
    gravity = (ZERO, negative(params.g))
    balances, names = [], []
    for index, body in enumerate(tree.order):
        k = tree.parent[body][0]
        joint = shape.joints[k]
        members = sorted(beyond[body])
        mass = {i: params.bodies[i].mass for i in members}
        freedom = geometry.freedom(k)
        if isinstance(freedom, Rotation):
            pivot = geometry.world(body, freedom.arm_a if joint.a == body else freedom.arm_b)
            inertial = plus(*(plus(cross(sub(centre[i], pivot), scale(mass[i], motion.acceleration[i])),
                                   times(params.bodies[i].inertia, motion.alpha[i])) for i in members))
            applied = plus(*(cross(sub(centre[i], pivot), scale(mass[i], gravity)) for i in members),
                           *(cross(sub(point, pivot), force) for i in members for force, point in forces[i]),
                           *(torque for i in members for torque in torques[i]))
            names.append(f"AMB of the bodies beyond {{j{k}}} about it")
        else:
            along = geometry.guide(k)
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
        time_index=params.vector.index(params.t) if shape.speed_driven else None,
        kinematics=(settle(sp.Matrix(pose), memo), settle(pose_jacobian, memo), settle(-minus_bias, memo)),
    )
