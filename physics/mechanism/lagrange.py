"""Lagrange's equations of any mechanism on a spanning tree, its cut joints closed by multipliers.

The tree of :mod:`physics.mechanism.topology` carries one coordinate per joint: the relative rotation of a
pin (child minus parent, zero in the sketch) or the travel of a slider along its guide. Every body's pose is
written symbolically in these coordinates (sympy), the kinetic and potential energies follow, and Lagrange's
equations give ``M(s) sdd = f(s, sd)``. Each joint left out of the tree (and each speed motor) adds constraint
rows ``C(s) sdd = gamma`` with multipliers: for a cut pin, the force ON body ``a`` BY body ``b``, exactly the
DAE's multipliers of the same joint, which is what the tests compare. This derivation never looks at the DAE
of :mod:`physics.mechanism.dae`: it shares only the description and the tree.

sympy is imported here, at derivation; the result is turned into numpy functions once per mechanism.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..errors import LinkageError
from .model import GROUND, Mechanism, Prismatic, Revolute
from .topology import analyse

SINGULAR_RCOND = 1e-13


def _rotation(phi) -> sp.Matrix:
    return sp.Matrix([[sp.cos(phi), -sp.sin(phi)], [sp.sin(phi), sp.cos(phi)]])


@dataclass(frozen=True)
class TreeLagrange:
    """Numeric functions of the derived system; ``coordinates`` names each tree coordinate by its joint."""

    mechanism: Mechanism
    coordinates: tuple[str, ...]
    row_joints: tuple[str, ...]
    mass: Callable  # (s) -> (k, k)
    force: Callable  # (s, sd) -> (k,)
    constraint: Callable  # (s, t) -> (rows,)
    constraint_jacobian: Callable  # (s) -> (rows, k)
    gamma: Callable  # (s, sd) -> (rows,)
    body_angles: Callable  # (s) -> (B,)
    body_centres: Callable  # (s) -> (B, 2)
    velocity_rhs: np.ndarray  # (rows,): the motors' speeds on their rows

    def solve(self, s: np.ndarray, sd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(sdd, multipliers)`` at one state; LinkageError at a singular pose."""
        mass = np.atleast_2d(self.mass(s))
        force = np.ravel(self.force(s, sd))
        jacobian = np.atleast_2d(self.constraint_jacobian(s)).reshape(len(self.row_joints), len(self.coordinates))
        k, rows = mass.shape[0], jacobian.shape[0]
        matrix = np.zeros((k + rows, k + rows))
        matrix[:k, :k] = mass
        matrix[:k, k:] = -jacobian.T
        matrix[k:, :k] = jacobian
        rhs = np.concatenate([force, np.ravel(self.gamma(s, sd)) if rows else np.zeros(0)])
        if 1.0 / np.linalg.cond(matrix) < SINGULAR_RCOND:
            raise LinkageError(f"{self.mechanism.name}: singular pose (a dead centre or a redundant constraint)")
        x = np.linalg.solve(matrix, rhs)
        return x[:k], x[k:]


def derive_tree_lagrange(mechanism: Mechanism) -> TreeLagrange:
    """Derive (once per mechanism description) and compile to numpy."""
    return _derive(mechanism.model_dump_json())


@functools.lru_cache(maxsize=16)
def _derive(description: str) -> TreeLagrange:
    mechanism = Mechanism.model_validate(json.loads(description))
    topology = analyse(mechanism)
    joints = {joint.name: joint for joint in mechanism.joints}
    centres = {body.name: sp.Matrix(body.centre) for body in mechanism.bodies}
    order = [body for body in _bfs_order(topology.parent)]
    coordinates = [topology.parent[body][0] for body in order]
    s = sp.Matrix(sp.symbols(f"s0:{len(order)}", real=True))
    sd = sp.Matrix(sp.symbols(f"sd0:{len(order)}", real=True))
    t = sp.Symbol("t", real=True)
    angle: dict[str, sp.Expr] = {GROUND: sp.Integer(0)}
    centre: dict[str, sp.Matrix] = {GROUND: sp.zeros(2, 1)}

    def world(body: str, sketch_xy) -> sp.Matrix:
        """Where the point drawn at ``sketch_xy`` on ``body`` is, in the tree coordinates."""
        drawn = sp.Matrix(sketch_xy)
        if body == GROUND:
            return drawn
        return centre[body] + _rotation(angle[body]) * (drawn - centres[body])

    for index, body in enumerate(order):
        joint_name, parent = topology.parent[body]
        joint = joints[joint_name]
        if isinstance(joint, Revolute):
            child_side, parent_side = (joint.a, joint.b) if joint.a.split(".")[0] == body else (joint.b, joint.a)
            angle[body] = angle[parent] + s[index]
            pivot = world(parent, mechanism.point_of(parent_side, joint_name))
            drawn = sp.Matrix(mechanism.point_of(child_side, joint_name))
            centre[body] = pivot - _rotation(angle[body]) * (drawn - centres[body])
        else:
            _place_slider(mechanism, joint, body, parent, s[index], angle, centre, centres, world)

    bodies = [body.name for body in mechanism.bodies]
    positions = sp.Matrix([[centre[name][0], centre[name][1]] for name in bodies])
    angles = sp.Matrix([angle[name] for name in bodies])
    jac_pos = positions.reshape(2 * len(bodies), 1).jacobian(s)
    jac_ang = angles.jacobian(s)
    velocity = jac_pos * sd
    spin = jac_ang * sd
    masses = [body.mass for body in mechanism.bodies]
    inertias = [body.inertia for body in mechanism.bodies]
    kinetic = sum(
        sp.Rational(1, 2) * m * (velocity[2 * k] ** 2 + velocity[2 * k + 1] ** 2) + sp.Rational(1, 2) * i * spin[k] ** 2
        for k, (m, i) in enumerate(zip(masses, inertias))
    )
    potential = sum(m * mechanism.g * positions[k, 1] for k, m in enumerate(masses))
    lagrangian = kinetic - potential
    mass = sp.hessian(kinetic, sd)
    momentum = sp.Matrix([sp.diff(lagrangian, v) for v in sd])
    force = sp.Matrix([sp.diff(lagrangian, q) for q in s]) - momentum.jacobian(s) * sd
    force += _joint_torques(mechanism, joints, angle, s, sd)

    rows: list[sp.Expr] = []
    row_joints: list[str] = []
    speeds: list[float] = []
    tree = set(topology.tree_joints)
    for joint in mechanism.joints:
        if joint.name not in tree:
            for expression in _cut_rows(mechanism, joint, angle, world):
                rows.append(expression)
                row_joints.append(joint.name)
                speeds.append(0.0)
    for driver in mechanism.drivers:
        if driver.speed is None:
            continue
        joint = joints[driver.joint]
        assert isinstance(joint, Revolute)
        relative = angle[joint.b.split(".")[0]] - angle[joint.a.split(".")[0]]
        rows.append(relative - driver.speed * t)
        row_joints.append(joint.name)
        speeds.append(float(driver.speed))
    phi = sp.Matrix(rows) if rows else sp.zeros(0, 1)
    jacobian = phi.jacobian(s) if rows else sp.zeros(0, len(order))
    gamma = -(jacobian * sd).jacobian(s) * sd if rows else sp.zeros(0, 1)

    def compile_(expr, *args):
        return sp.lambdify(args, expr, modules="numpy", cse=True)

    flat_s, flat_sd = list(s), list(sd)
    return TreeLagrange(
        mechanism=mechanism,
        coordinates=tuple(coordinates),
        row_joints=tuple(row_joints),
        mass=_vector_call(compile_(mass, flat_s), 1),
        force=_vector_call(compile_(force, flat_s, flat_sd), 2),
        constraint=_vector_call(compile_(phi, flat_s, t), 1, time=True),
        constraint_jacobian=_vector_call(compile_(jacobian, flat_s), 1),
        gamma=_vector_call(compile_(gamma, flat_s, flat_sd), 2),
        body_angles=_flat(_vector_call(compile_(angles, flat_s), 1)),
        body_centres=_vector_call(compile_(positions, flat_s), 1),
        velocity_rhs=np.array(speeds),
    )


def _vector_call(function: Callable, arrays: int, time: bool = False) -> Callable:
    """Call a lambdified function of lists of symbols with plain arrays: ``f(s)``, ``f(s, sd)``, ``f(s, t)``."""
    if time:
        return lambda s, t: np.array(function(list(s), t), dtype=float)
    if arrays == 1:
        return lambda s: np.array(function(list(s)), dtype=float)
    return lambda s, sd: np.array(function(list(s), list(sd)), dtype=float)


def _flat(function: Callable) -> Callable:
    return lambda *args: np.ravel(function(*args))


def _bfs_order(parent: dict[str, tuple[str, str]]) -> list[str]:
    depth = {}

    def level(body: str) -> int:
        if body == GROUND:
            return 0
        if body not in depth:
            depth[body] = level(parent[body][1]) + 1
        return depth[body]

    return sorted(parent, key=lambda body: (level(body), list(parent).index(body)))


def _place_slider(mechanism, joint: Prismatic, body, parent, travel, angle, centre, centres, world) -> None:
    """A slider's child pose: the same rotation as its parent, the sliding point ``travel`` further along the
    guide line (through the guide's point ``through``, direction ``u``) than in the sketch."""
    u = np.array(joint.direction, dtype=float) / np.hypot(*joint.direction)
    point = np.array(mechanism.point_of(f"{joint.body}.{joint.point}", joint.name))
    through = np.array(mechanism.point_of(f"{joint.on}.{joint.through}", joint.name))
    drawn_offset = float(u @ (point - through))  # where the sketch puts the sliding point along the guide
    angle[body] = angle[parent]
    rotation = _rotation(angle[body])
    guide = rotation * sp.Matrix(u) * (drawn_offset + travel)
    if body == joint.body:  # the slider rides on its parent's guide
        sliding_point = world(parent, through) + guide
        centre[body] = sliding_point - rotation * (sp.Matrix(point) - centres[body])
    else:  # the guide's carrier hangs from the slider
        guide_point = world(parent, point) - guide
        centre[body] = guide_point - rotation * (sp.Matrix(through) - centres[body])


def _joint_torques(mechanism, joints, angle, s, sd) -> sp.Matrix:
    """Generalised forces of motor torques and pin damping, by virtual power."""
    out = sp.zeros(len(s), 1)
    for driver in mechanism.drivers:
        if driver.torque is None:
            continue
        joint = joints[driver.joint]
        relative = angle[joint.b.split(".")[0]] - angle[joint.a.split(".")[0]]
        out += sp.Matrix([sp.diff(relative, q) for q in s]) * driver.torque
    for joint in mechanism.joints:
        if isinstance(joint, Revolute) and joint.damping:
            relative = angle[joint.b.split(".")[0]] - angle[joint.a.split(".")[0]]
            gradient = sp.Matrix([sp.diff(relative, q) for q in s])
            rate = (gradient.T * sd)[0]
            out -= gradient * joint.damping * rate
        elif isinstance(joint, Prismatic) and joint.damping:
            raise LinkageError(f"joint {joint.name!r}: damping: sliders take no damping yet (set it to 0)")
    return out


def _cut_rows(mechanism, joint, angle, world) -> list[sp.Expr]:
    """The constraint rows a joint left out of the tree adds (same form as the DAE's, independently written)."""
    if isinstance(joint, Revolute):
        a_body, b_body = joint.a.split(".")[0], joint.b.split(".")[0]
        at_a = world(a_body, mechanism.point_of(joint.a, joint.name))
        gap = at_a - world(b_body, mechanism.point_of(joint.b, joint.name))
        return [gap[0], gap[1]]
    u = np.array(joint.direction, dtype=float) / np.hypot(*joint.direction)
    normal = _rotation(angle[joint.on]) * sp.Matrix([-u[1], u[0]])
    gap = world(joint.body, mechanism.point_of(f"{joint.body}.{joint.point}", joint.name)) - world(
        joint.on, mechanism.point_of(f"{joint.on}.{joint.through}", joint.name))
    return [(normal.T * gap)[0], angle[joint.body] - angle[joint.on]]


def tree_state(tree: TreeLagrange, q: np.ndarray, qdot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tree coordinates and rates ``(s, sd)`` of a maximal-coordinate state ``(q, qdot)`` (3 per body, centres
    of mass and rotations from the sketch): a pin's relative rotation, a slider's travel along its guide."""
    mechanism = tree.mechanism
    names = [body.name for body in mechanism.bodies]
    centres = {body.name: np.array(body.centre) for body in mechanism.bodies}

    def pose(body: str):
        if body == GROUND:
            return np.zeros(2), 0.0, np.zeros(2), 0.0
        k = names.index(body)
        return q[3 * k : 3 * k + 2], q[3 * k + 2], qdot[3 * k : 3 * k + 2], qdot[3 * k + 2]

    def point(body: str, sketch_xy) -> tuple[np.ndarray, np.ndarray]:
        drawn = np.array(sketch_xy, dtype=float)
        if body == GROUND:
            return drawn, np.zeros(2)
        r, phi, v, w = pose(body)
        c, s_ = np.cos(phi), np.sin(phi)
        arm = np.array([[c, -s_], [s_, c]]) @ (drawn - centres[body])
        return r + arm, v + w * np.array([-arm[1], arm[0]])

    topology = analyse(mechanism)
    joints = {joint.name: joint for joint in mechanism.joints}
    values, rates = [], []
    for body in _bfs_order(topology.parent):
        joint_name, parent = topology.parent[body]
        joint = joints[joint_name]
        _, phi_c, _, w_c = pose(body)
        _, phi_p, _, w_p = pose(parent)
        if isinstance(joint, Revolute):
            values.append(phi_c - phi_p)
            rates.append(w_c - w_p)
            continue
        u = np.array(joint.direction, dtype=float) / np.hypot(*joint.direction)
        sliding, sliding_rate = point(joint.body, mechanism.point_of(f"{joint.body}.{joint.point}", joint.name))
        guide, guide_rate = point(joint.on, mechanism.point_of(f"{joint.on}.{joint.through}", joint.name))
        _, phi_on, _, w_on = pose(joint.on)
        cos_on, sin_on = np.cos(phi_on), np.sin(phi_on)
        direction = np.array([cos_on * u[0] - sin_on * u[1], sin_on * u[0] + cos_on * u[1]])
        drawn = np.array(mechanism.point_of(f"{joint.body}.{joint.point}", joint.name)) - np.array(
            mechanism.point_of(f"{joint.on}.{joint.through}", joint.name))
        values.append(float(direction @ (sliding - guide)) - float(u @ drawn))
        rates.append(float(w_on * np.array([-direction[1], direction[0]]) @ (sliding - guide)
                           + direction @ (sliding_rate - guide_rate)))
    return np.array(values), np.array(rates)
