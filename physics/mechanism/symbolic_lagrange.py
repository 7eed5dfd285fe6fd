"""Lagrange's equations of any mechanism structure on its spanning tree, numbers as parameter symbols.

    d/dt (dT/d sd_k) - dT/d s_k + dV/d s_k + dD/d sd_k = Q_k + (C^T lambda)_k

with ``T = sum 1/2 m_i |v_i|^2 + 1/2 I_i w_i^2``, ``V = sum m_i g y_i``, ``D`` the dampers' Rayleigh function
(pins: ``1/2 c (relative spin)^2``, sliders: ``1/2 c (sliding speed)^2``) and ``Q`` the torque motors' work.

The positions are those of :mod:`.symbolic_tree`: every point a sum of vectors, each turned by one body's angle
(a sum of pin coordinates) and some multiplied by a slider's travel. They are differentiated by the rotation rule
``d/ds_j R(phi_f) v = perp(R(phi_f) v)`` when pin j turns frame f, once per piece, as the chain's derivation
differentiates its bars' unit vectors (physics/derive/lagrange.py): never by walking a long expression, and with
no second derivative written out. From the partial velocities ``e_ij = d r_i / d s_j``, by the chain rule,

    dT/d sd_k = sum_i m_i v_i . e_ik + I_i w_i dw_i/dsd_k,         v_i = sum_j e_ij sd_j
    d/dt(dT/d sd_k) = sum_j M_kj sdd_j + sum_i m_i (a_i_rest . e_ik + v_i . de_ik/dt)
    dT/d s_k = sum_i m_i v_i . dv_i/ds_k

and ``de_ik/dt = dv_i/ds_k`` (the mixed partials commute), so those two terms cancel in the equation; ``dT/d s_k``
is still written whole in ``lagrangian_force`` (the variational integrator's dL/ds + Q). ``A`` is read off
directly: ``M_kj = sum_i m_i e_ij . e_ik + I_i (dw_i/dsd_j)(dw_i/dsd_k)``; ``a_i_rest``, the part of the
acceleration without ``sdd``, is ``sum_f (-W_f^2 r_f + 2 W_f perp(travel rates))`` over the frames f of the point.
The closures ``phi(s, t)`` (cut joints, speed motors) add ``C sdd = -(C' sd)`` rows and ``-C^T lambda`` columns.

Nothing here looks at the DAE or at Newton–Euler: it shares only the structure and the tree's positions.
"""

from __future__ import annotations

from types import SimpleNamespace

import sympy as sp

from ..derive.formulation import LinearSystem
from .parameters import ParameterSymbols, Structure
from .symbolic_tree import (
    ZERO,
    Place,
    TreeGeometry,
    add,
    dot,
    names_template,
    negative,
    perp,
    plus,
    scale,
    settle,
    times,
    tree_geometry,
)

TWO = sp.Integer(2)
ONE = sp.Integer(1)


class _Calculus:
    """Velocities, partial velocities and the velocity-product part of accelerations of a :class:`Place`."""

    def __init__(self, geometry: TreeGeometry) -> None:
        self.geometry = geometry
        self.pins = {body: frozenset(pins) for body, pins in geometry.pins.items()}
        self.spin: dict = {-1: ZERO}
        for index, body in enumerate(geometry.tree.order):
            parent = geometry.tree.parent[body][1]
            turning = index in self.pins[body] and index not in self.pins[parent]
            self.spin[body] = plus(self.spin[parent], geometry.sd[index]) if turning else self.spin[parent]
        self._frames: dict = {}

    def frames(self, place: Place) -> dict:
        """``frame -> (W_f, travel rate part)``: the place's vectors turned by ``frame`` summed, and the sum of
        its travel terms' ``R v sd_travel``."""
        found = self._frames.get(place)
        if found is None:
            grouped: dict = {}
            for term in place.terms:
                grouped.setdefault(term.frame, []).append(term)
            found = {}
            for frame, terms in grouped.items():
                rates = [scale(self.geometry.sd[term.travel], self.geometry.turned(frame, term.vector))
                         for term in terms if term.travel is not None]
                found[frame] = (add(*(self.geometry.term_value(term) for term in terms)), add(*rates))
            self._frames[place] = found
        return found

    def partial(self, place: Place, j: int) -> tuple:
        turned = [whole for frame, (whole, _) in self.frames(place).items() if j in self.pins[frame]]
        travels = [self.geometry.turned(term.frame, term.vector) for term in place.terms if term.travel == j]
        return add(perp(add(*turned)), *travels)

    def velocity(self, place: Place) -> tuple:
        return add(*(add(scale(self.spin[frame], perp(whole)), rates)
                     for frame, (whole, rates) in self.frames(place).items()))

    def bias(self, place: Place) -> tuple:
        """The acceleration's part without ``sdd``: ``-W^2 r + 2 W perp(travel rates)`` frame by frame."""
        out = []
        for frame, (whole, rates) in self.frames(place).items():
            spin = self.spin[frame]
            if spin != 0:
                out.append(scale(negative(times(spin, spin)), whole))
                out.append(scale(times(TWO, spin), perp(rates)))
        return add(*out)

    def velocity_partial(self, place: Place, k: int) -> tuple:
        """``dv / ds_k`` (only ``lagrangian_force`` needs it)."""
        out = [perp(add(scale(self.spin[frame], perp(whole)), rates))
               for frame, (whole, rates) in self.frames(place).items() if k in self.pins[frame]]
        out += [scale(self.spin[term.frame], perp(self.geometry.turned(term.frame, term.vector)))
                for term in place.terms if term.travel == k]
        return add(*out)

    def spin_gradient(self, a: int, b: int) -> dict:
        """``d(w_b - w_a) / d sd_j`` by coordinate, non-zero entries only."""
        gradient = {j: ONE for j in self.pins[b] - self.pins[a]}
        gradient.update({j: sp.Integer(-1) for j in self.pins[a] - self.pins[b]})
        return gradient


def derive_lagrange(shape: Structure, params: ParameterSymbols) -> LinearSystem:
    geometry = tree_geometry(shape, params)
    calculus = _Calculus(geometry)
    s, sd, sdd = geometry.s, geometry.sd, geometry.sdd
    tree = geometry.tree
    n, bodies = len(s), shape.bodies
    mass = [params.bodies[i].mass for i in range(bodies)]
    inertia = [params.bodies[i].inertia for i in range(bodies)]
    places = [geometry.place[i] for i in range(bodies)]

    partial = {(i, j): calculus.partial(places[i], j) for i in range(bodies) for j in tree.path[i]}
    bias = [calculus.bias(place) for place in places]
    velocity = [calculus.velocity(place) for place in places]
    movers = {k: [i for i in range(bodies) if k in tree.path[i]] for k in range(n)}
    generalised = _generalised_forces(geometry, calculus, n)

    rows, row_names = geometry.closure_rows()
    count = len(rows)
    A = sp.zeros(n + count, n + count)
    b = sp.zeros(n + count, 1)
    lagrangian_force = []
    for k in range(n):
        for j in range(k, n):
            both = [i for i in movers[k] if j in tree.path[i]]
            turning = [i for i in both if j in calculus.pins[i] and k in calculus.pins[i]]
            A[k, j] = A[j, k] = plus(*(times(mass[i], dot(partial[i, j], partial[i, k])) for i in both),
                                     *(inertia[i] for i in turning))
        rest = plus(*(times(mass[i], dot(bias[i], partial[i, k])) for i in movers[k]))
        dV_ds = plus(*(times(mass[i], params.g, partial[i, k][1]) for i in movers[k]))
        b[k] = plus(generalised[k], negative(dV_ds), negative(rest))
        dT_ds = plus(*(times(mass[i], dot(velocity[i], calculus.velocity_partial(places[i], k))) for i in movers[k]))
        lagrangian_force.append(plus(dT_ds, negative(dV_ds), generalised[k]))

    jacobian = sp.zeros(count, n)
    rates = []
    for r, (row, gradient, gamma, rate) in enumerate(_closures(geometry, calculus, row_names)):
        for j, value in gradient.items():
            jacobian[r, j] = value
            A[n + r, j] = value
            A[j, n + r] = negative(value)
        b[n + r] = gamma
        rates.append(rate)

    pose, pose_jacobian, pose_bias = [], sp.zeros(3 * bodies, n), []
    for i in range(bodies):
        pose += [*geometry.value(places[i]), geometry.angle[i]]
        for j in tree.path[i]:
            pose_jacobian[3 * i, j], pose_jacobian[3 * i + 1, j] = partial[i, j]
            pose_jacobian[3 * i + 2, j] = ONE if j in calculus.pins[i] else ZERO
        pose_bias += [bias[i][0], bias[i][1], ZERO]
    memo: dict = {}
    A, b = settle(A, memo), settle(b, memo)
    lam = list(sp.symbols(f"lam0:{count}", real=True))
    names = [f"Lagrange equation for s{k} ({{j{tree.parent[body][0]}}})" for k, body in enumerate(tree.order)]
    return LinearSystem(
        formulation="lagrange",
        n=n,
        pinned=False,
        symbols=SimpleNamespace(theta=list(s), omega=list(sd), params=list(params.vector)),  # type: ignore[arg-type]  # LinearSystem.symbols is typed ChainSymbols
        A=A,
        b=b,
        unknowns=list(sdd) + lam,
        equation_names=names + names_template(shape, row_names),
        theta_ddot_index=list(range(n)),
        mass_matrix=A[:n, :n],
        lagrangian_force=settle(sp.Matrix(n, 1, lagrangian_force), memo),
        constraint_rows=tuple(range(n, n + count)),
        constraint=settle(sp.Matrix(count, 1, rows), memo),
        constraint_jacobian=settle(jacobian, memo),
        constraint_rate=settle(sp.Matrix(count, 1, rates), memo),
        multiplier_index=tuple(range(n, n + count)),
        time_index=params.vector.index(params.t) if any(d.kind == "speed" for d in shape.drivers) else None,
        kinematics=(settle(sp.Matrix(pose), memo), settle(pose_jacobian, memo), settle(sp.Matrix(pose_bias), memo)),
    )


def _closures(geometry: TreeGeometry, calculus: _Calculus, row_names):
    """For every closure row (the order of :meth:`TreeGeometry.closure_rows`): ``(phi, d phi/ds by coordinate,
    gamma = -(phi'' without sdd), phi')``."""
    shape, params = geometry.shape, geometry.params
    n = len(geometry.s)
    for row in row_names:
        joint = shape.joints[row.joint]
        symbols = params.joints[row.joint]
        if row.kind == "angle":  # sum c angle(body): d/ds_j is the sum of c over the bodies pin j turns
            assert row.angle is not None
            gradient: dict = {}
            for c, body in row.angle.terms:
                for j in calculus.pins[body]:
                    gradient[j] = gradient.get(j, ZERO) + c
            rate = plus(*(times(c, calculus.spin[body]) for c, body in row.angle.terms), negative(row.angle.rate))
            yield row, {j: v for j, v in gradient.items() if v != 0}, ZERO, rate
            continue
        if row.kind == "slide" and row.part == 1:
            yield row, calculus.spin_gradient(joint.b, joint.a), ZERO, plus(calculus.spin[joint.a],
                                                                           negative(calculus.spin[joint.b]))
            continue
        gap = geometry.point(joint.a, symbols.arm_a) - geometry.point(joint.b, symbols.arm_b)
        if row.kind == "pin":
            axis = row.part
            gradient = {j: calculus.partial(gap, j)[axis] for j in range(n)}
            yield (row, {j: v for j, v in gradient.items() if v != 0}, negative(calculus.bias(gap)[axis]),
                   calculus.velocity(gap)[axis])
            continue
        # offset across the guide, n . g with n = R(phi_on) perp(u) turning at the guide's spin W:
        # d/ds_j = [pin j turns the guide] perp(n) . g + n . dg/ds_j;  phi'' = -W^2 n.g + 2 W perp(n).g' + n.g''
        _, normal = geometry.guide(row.joint)
        spin, turning = calculus.spin[joint.b], calculus.pins[joint.b]
        value, rate = geometry.value(gap), calculus.velocity(gap)
        swing = dot(perp(normal), value)
        gradient = {}
        for j in range(n):
            entry = plus(swing if j in turning else ZERO, dot(normal, calculus.partial(gap, j)))
            if entry != 0:
                gradient[j] = entry
        quadratic = plus(negative(times(spin, spin, dot(normal, value))), times(TWO, spin, dot(perp(normal), rate)),
                         dot(normal, calculus.bias(gap)))
        yield row, gradient, negative(quadratic), plus(times(spin, swing), dot(normal, rate))


def _generalised_forces(geometry: TreeGeometry, calculus: _Calculus, n: int) -> list:
    """``Q_k - dD/d sd_k``: torque motors' work and the dampers' Rayleigh function, through each joint's relative
    spin (pins) or sliding speed (sliders) and its gradient in the tree coordinates."""
    shape, params, sd = geometry.shape, geometry.params, geometry.sd
    out: list[list] = [[] for _ in range(n)]
    torques = {driver.joint: params.drivers[k] for k, driver in enumerate(shape.drivers) if driver.kind == "torque"}
    for number, joint in enumerate(shape.joints):
        symbols = params.joints[number]
        if "damping" not in symbols.fields:
            continue
        if joint.kind == "revolute":
            gradient = calculus.spin_gradient(joint.a, joint.b)
        else:
            # the sliding coordinate u_w . (sliding point - through point), u_w turning with the guide's body
            along, _ = geometry.guide(number)
            gap = geometry.point(joint.a, symbols.arm_a) - geometry.point(joint.b, symbols.arm_b)
            swing = dot(perp(along), geometry.value(gap))
            turning = calculus.pins[joint.b]
            gradient = {}
            for j in range(n):
                entry = plus(swing if j in turning else ZERO, dot(along, calculus.partial(gap, j)))
                if entry != 0:
                    gradient[j] = entry
        speed = plus(*(times(value, sd[j]) for j, value in gradient.items()))
        for j, value in gradient.items():
            out[j].append(negative(times(symbols.damping, speed, value)))
            if number in torques:
                out[j].append(times(torques[number], value))
    return [plus(*terms) for terms in out]
