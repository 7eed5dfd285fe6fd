"""Lagrange's equations of any mechanism structure on its spanning tree, numbers as parameter symbols.

    d/dt (dT/d sd_k) - dT/d s_k + dV/d s_k + dD/d sd_k = Q_k + (C^T lambda)_k

with ``T = sum 1/2 m_i |v_i|^2 + 1/2 I_i w_i^2``, ``V = sum m_i g y_i``, ``D`` the dampers' Rayleigh function
(pins: ``1/2 c (relative spin)^2``, sliders: ``1/2 c (sliding speed)^2``) and ``Q`` the torque motors' work.

The positions are those of :mod:`.symbolic_tree`: every point a sum of vectors, each turned by one body's angle
(a sum of pin coordinates, or with absolute rotations one) and some multiplied by a slider's travel. They are differentiated by the rotation rule
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
from .joints.loads import applied_loads
from .parameters import Structure
from .symbolic_parameters import ParameterSymbols
from .symbolic_tree import (
    ZERO,
    LinearReader,
    Place,
    TreeGeometry,
    TreeKinematics,
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
        self.alpha: dict = {-1: ZERO}
        absolute = geometry.rotations == "absolute"
        for index, body in enumerate(geometry.tree.order):
            parent = geometry.tree.parent[body][1]
            turning = index in self.pins[body] and index not in self.pins[parent]
            if turning and absolute:  # the coordinate is the body's own rotation
                self.spin[body], self.alpha[body] = geometry.sd[index], geometry.sdd[index]
                continue
            self.spin[body] = plus(self.spin[parent], geometry.sd[index]) if turning else self.spin[parent]
            self.alpha[body] = plus(self.alpha[parent], geometry.sdd[index]) if turning else self.alpha[parent]
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


class _Kinematics(TreeKinematics):
    """The joints' equations in the tree coordinates: positions from the tree, velocities and accelerations by
    the rotation rule (:class:`_Calculus`), an acceleration ``sum_j e_j sdd_j`` plus its bias."""

    def __init__(self, geometry: TreeGeometry, calculus: _Calculus) -> None:
        super().__init__(geometry, calculus.spin, calculus.alpha)
        self.calculus = calculus

    def point(self, body, arm):
        place = self.geometry.point(body, arm)
        acceleration = add(self.calculus.bias(place), *(scale(self.geometry.sdd[j], self.calculus.partial(place, j))
                                                        for j in self.geometry.tree.path[body]))
        return self.geometry.value(place), self.calculus.velocity(place), acceleration


def _gradient(reader: LinearReader, rate, coordinates: dict) -> dict:
    """``d rate / d sd_j`` by coordinate ``j`` (non-zero entries only), read off ``rate``, linear in ``sd``."""
    coefficients, _ = reader.split(sp.sympify(rate))
    return {coordinates[u]: value for u, value in coefficients.items() if value != 0}


def derive_lagrange(shape: Structure, params: ParameterSymbols, rotations: str = "relative") -> LinearSystem:
    """The system of the module's text; ``rotations``: what a pin's coordinate is (:mod:`.symbolic_tree`)."""
    geometry = tree_geometry(shape, params, rotations)
    calculus = _Calculus(geometry)
    kinematics = _Kinematics(geometry, calculus)
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
    generalised = _generalised_forces(geometry, kinematics, n)

    closures, row_names = geometry.closure_rows(kinematics)
    rows = [row.position for row in closures]
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
    for r, (gradient, gamma, rate) in enumerate(_closures(geometry, closures)):
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
        time_index=params.vector.index(params.t) if shape.speed_driven else None,
        kinematics=(settle(sp.Matrix(pose), memo), settle(pose_jacobian, memo), settle(sp.Matrix(pose_bias), memo)),
    )


def _closures(geometry: TreeGeometry, closures):
    """For every closure row (the order of :meth:`TreeGeometry.closure_rows`): ``(d phi/ds by coordinate,
    gamma = -(phi'' without sdd), phi')``, the gradient read off ``phi'`` (linear in ``sd``) and gamma off
    ``phi''`` (linear in ``sdd``)."""
    coordinates = {u: j for j, u in enumerate(geometry.sd)}
    by_rates, by_accelerations = LinearReader(geometry.sd), LinearReader(geometry.sdd)
    for row in closures:
        _, rest = by_accelerations.split(sp.sympify(row.acceleration))
        yield _gradient(by_rates, row.velocity, coordinates), negative(rest), row.velocity


def _generalised_forces(geometry: TreeGeometry, kinematics: _Kinematics, n: int) -> list:
    """``Q_k - dD/d sd_k``: torque motors' work and the dampers' Rayleigh function, through the relative motion
    each acts on (:func:`~physics.mechanism.joints.loads.applied_loads`: a damped kind's
    :meth:`~physics.mechanism.joints.JointKind.damper`, a torque motor's joint's relative rotation) times its
    gradient in the tree coordinates, read off the motion's speed (not off the row's loads: Lagrange's own way)."""
    coordinates = {u: j for j, u in enumerate(geometry.sd)}
    reader = LinearReader(geometry.sd)
    out: list[list] = [[] for _ in range(n)]
    for row, magnitude in applied_loads(geometry.shape, geometry.params, kinematics):
        for j, value in _gradient(reader, row.velocity, coordinates).items():
            out[j].append(times(magnitude, value))
    return [plus(*terms) for terms in out]
