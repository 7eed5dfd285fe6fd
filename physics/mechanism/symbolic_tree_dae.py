"""The maximal-coordinate DAE of a mechanism structure, integrated in its spanning tree's joint coordinates.

The seed's DAE (course report, section 2.3 and its ode45 call) integrates the chain's joint angles and rates;
at each state it solves the one linear system of every centre-of-mass acceleration, every angular acceleration
and every joint reaction. The mechanism's own DAE (:mod:`.symbolic_dae`) integrates the maximal coordinates
``(q, qdot)`` instead. This module writes the seed's form for any mechanism: the state is the tree coordinates and
rates ``(s, sd)`` of :mod:`.symbolic_tree` (the tree formulations' state, in their order), and the system solved
at each state is the DAE's, unchanged, with

* the bodies' poses and velocities in the tree coordinates (forward kinematics: every body's centre a sum of
  vectors turned by its frames' angles, some multiplied by a slider's travel; its velocity by the rotation rule),
  substituted for ``q`` and ``qdot``, and
* one more unknown and one more row per tree coordinate: its acceleration read off the bodies' accelerations
  (a pin's ``sdd = alpha_child - alpha_parent``, or ``alpha_child`` with absolute rotations; a slider's travel ``c = U . (p_a - p_b) - offset`` with
  ``U = R(phi_b) u`` differentiated twice through rigid-body kinematics, linear in the bodies' accelerations).

So one solve gives ``[qddot (3 B), every reaction (the DAE's rows, in its layout), sdd (n)]``; the integrators
read ``sdd``. The constraints the integrator holds (projection, Baumgarte terms) are the tree formulations'
closures: the DAE's rows of the joints left out of the tree and of the speed motors, in the DAE's order, their
positions and rates in ``(s, sd)`` and their Jacobian read off the rates (linear in ``sd``); the tree's own joints
hold by construction. Numbers are parameter symbols, as in every mechanism derivation.
"""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import sympy as sp

from ..derive.formulation import LinearSystem
from .joints import KINDS, MOTOR, Rotation, Translation
from .parameters import Structure
from .symbolic_parameters import ParameterSymbols
from .symbolic_tree import (
    ZERO,
    LinearReader,
    TreeGeometry,
    add,
    dot,
    negative,
    perp,
    plus,
    scale,
    settle,
    sub,
    times,
    tree_geometry,
    turn,
)

ONE = sp.Integer(1)
TWO = sp.Integer(2)


def _forward_kinematics(geometry: TreeGeometry):
    """Every body's pose ``(x, y, phi)`` in ``s``, ``d pose / d s`` (3 B, n) and the bias ``(d/dt d pose/ds) sd``
    (3 B): each term ``R(phi_f) v`` of a centre differentiated by the rotation rule, a travel's by the product
    rule (``d/dt (s R v) = sd R v + s W perp(R v)``)."""
    s, sd = geometry.s, geometry.sd
    n, bodies = len(s), geometry.shape.bodies
    spin = {frame: plus(*(sd[j] for j in pins)) for frame, pins in geometry.pins.items()}
    pose, bias = [], []
    jacobian = sp.zeros(3 * bodies, n)
    for i in range(bodies):
        partial: dict[int, list] = {}
        bias_terms = []
        for term in geometry.place[i].terms:
            turned = geometry.turned(term.frame, term.vector)
            pins = geometry.pins[term.frame]
            whirl = spin[term.frame]
            if term.travel is None:
                for j in pins:
                    partial.setdefault(j, []).append(perp(turned))
                bias_terms.append(scale(negative(times(whirl, whirl)), turned))
            else:
                travel, rate = s[term.travel], sd[term.travel]
                for j in pins:
                    partial.setdefault(j, []).append(scale(travel, perp(turned)))
                partial.setdefault(term.travel, []).append(turned)
                bias_terms.append(scale(negative(times(whirl, whirl, travel)), turned))
                bias_terms.append(scale(times(TWO, rate, whirl), perp(turned)))
        for j, vectors in partial.items():
            jacobian[3 * i, j], jacobian[3 * i + 1, j] = add(*vectors)
        for j in geometry.pins[i]:
            jacobian[3 * i + 2, j] = ONE
        pose += [*geometry.value(geometry.place[i]), geometry.angle[i]]
        bias += [*add(*bias_terms), ZERO]
    return sp.Matrix(pose), jacobian, sp.Matrix(bias)


def _travel_acceleration(freedom: Translation, a: int, b: int, q, qd, qdd):
    """``c''`` of a slider's travel ``c = U . (p_a - p_b) - offset``, ``U = R(phi_b) u``, in the maximal
    coordinates: ``U'' . g + 2 U' . g' + U . g''`` with ``U' = w_b perp(U)``, ``U'' = alpha_b perp(U) - w_b^2 U``
    and ``g = p_a - p_b`` (a point at ``rho`` from G accelerating with ``a + alpha perp(rho) - w^2 rho``)."""

    def point(body: int, arm):
        if body < 0:
            return tuple(arm), (ZERO, ZERO), (ZERO, ZERO)
        rho = turn(q[3 * body + 2], tuple(arm))
        w, alpha = qd[3 * body + 2], qdd[3 * body + 2]
        return (add(q[3 * body : 3 * body + 2], rho), add(qd[3 * body : 3 * body + 2], scale(w, perp(rho))),
                add(qdd[3 * body : 3 * body + 2], scale(alpha, perp(rho)), scale(negative(times(w, w)), rho)))

    pa, va, aa = point(a, freedom.arm_a)
    pb, vb, ab = point(b, freedom.arm_b)
    gap, gap_rate, gap_acceleration = sub(pa, pb), sub(va, vb), sub(aa, ab)
    if b < 0:
        guide = tuple(freedom.direction)
        return dot(guide, gap_acceleration)
    guide = turn(q[3 * b + 2], tuple(freedom.direction))
    w, alpha = qd[3 * b + 2], qdd[3 * b + 2]
    guide_rate = scale(w, perp(guide))
    guide_acceleration = add(scale(alpha, perp(guide)), scale(negative(times(w, w)), guide))
    return plus(dot(guide_acceleration, gap), times(TWO, dot(guide_rate, gap_rate)), dot(guide, gap_acceleration))


def _held_rows(shape: Structure, cut: tuple[int, ...]) -> list[int]:
    """The DAE's rows (counted from its first multiplier) of the joints left out of the tree and of every speed
    motor: the constraints a run in tree coordinates holds, in the DAE's order."""
    held: list[int] = []
    row = 0
    for k, joint in enumerate(shape.joints):
        count = len(KINDS[joint.kind].meanings)
        if k in cut:
            held += range(row, row + count)
        row += count
        if k in shape.speed_driven:
            held += range(row, row + len(MOTOR.meanings))
            row += len(MOTOR.meanings)
    return held


def derive_tree_dae(shape: Structure, params: ParameterSymbols, dae: LinearSystem, rotations: str = "relative"
                    ) -> LinearSystem:
    """The system of the module's text from ``dae``, the structure's maximal DAE (:mod:`.symbolic_dae`, in the
    same parameter symbols ``params``); ``rotations``: what a pin's coordinate is (:mod:`.symbolic_tree`)."""
    geometry = tree_geometry(shape, params, rotations)
    tree = geometry.tree
    s, sd, sdd = geometry.s, geometry.sd, geometry.sdd
    n, size = len(s), 3 * shape.bodies
    q, qd = list(dae.symbols.theta), list(dae.symbols.omega)
    qdd = list(dae.unknowns[:size])
    count = len(dae.unknowns) - size
    memo: dict = {}
    pose, pose_jacobian, pose_bias = (settle(part, memo) for part in _forward_kinematics(geometry))
    velocity = settle(pose_jacobian * sp.Matrix(sd), memo)
    to_tree = {**dict(zip(q, pose)), **dict(zip(qd, velocity))}

    # one row per tree coordinate: sdd_m minus its value in the bodies' accelerations, in the maximal coordinates
    rows = []
    for m, body in enumerate(tree.order):
        number, parent = tree.parent[body]
        joint = shape.joints[number]
        freedom = geometry.freedom(number)
        if isinstance(freedom, Rotation):
            # relative: sdd = alpha_child - alpha_parent; absolute: sdd = alpha_child
            parent_alpha = qdd[3 * parent + 2] if parent >= 0 and geometry.rotations == "relative" else ZERO
            rows.append(plus(sdd[m], negative(qdd[3 * body + 2]), parent_alpha))
        else:
            assert isinstance(freedom, Translation), f"joint {number}: a tree joint carries a rotation or a travel"
            rows.append(plus(sdd[m], negative(_travel_acceleration(freedom, joint.a, joint.b, q, qd, qdd))))
    unknowns = qdd + list(dae.unknowns[size:]) + list(sdd)
    extra_A, extra_b = LinearReader(unknowns).system(rows)
    A = sp.zeros(size + count + n, size + count + n)
    A[: size + count, : size + count] = dae.A
    A[size + count :, :] = extra_A
    b = sp.Matrix.vstack(dae.b, extra_b)
    A = settle(A.xreplace(to_tree), memo)
    b = settle(b.xreplace(to_tree), memo)

    held = _held_rows(shape, tree.cut)
    assert dae.constraint is not None and dae.constraint_rate is not None
    phi = settle(sp.Matrix([dae.constraint[r] for r in held]).xreplace(to_tree), memo) if held else sp.zeros(0, 1)
    rate = settle(sp.Matrix([dae.constraint_rate[r] for r in held]).xreplace(to_tree), memo) if held else \
        sp.zeros(0, 1)
    jacobian = sp.zeros(len(held), n)
    coordinate = {u: j for j, u in enumerate(sd)}
    reader = LinearReader(sd)
    for r in range(len(held)):
        coefficients, _ = reader.split(rate[r])
        for u, value in coefficients.items():
            jacobian[r, coordinate[u]] = value
    jacobian = settle(jacobian, memo)
    names = [*dae.equation_names,
             *(f"tree coordinate s{m} ({{j{tree.parent[body][0]}}}) from the bodies' accelerations"
               for m, body in enumerate(tree.order))]
    return dataclasses.replace(
        dae,
        formulation="tree_dae",
        n=n,
        symbols=SimpleNamespace(theta=list(s), omega=list(sd), params=list(params.vector)),  # type: ignore[arg-type]  # LinearSystem.symbols is typed ChainSymbols
        A=A,
        b=b,
        unknowns=unknowns,
        equation_names=names,
        theta_ddot_index=list(range(size + count, size + count + n)),
        constraint_rows=tuple(size + r for r in held),
        constraint=phi,
        constraint_jacobian=jacobian,
        constraint_rate=rate,
        multiplier_index=tuple(range(size, size + count)),
        kinematics=(pose, pose_jacobian, pose_bias),
    )
