"""Newton–Euler equations of any mechanism on a spanning tree: momentum balances of the tree's subtrees.

The seed report writes the triple pendulum's equations as angular-momentum balances about the joints, each of
the bars beyond a joint taken together, so the joint's own reaction drops out. The same holds for any tree:
for every tree joint, the bodies beyond it (its subtree) satisfy

* a pin at P: ``sum over the subtree of (G - P) x m a_G + I alpha = moments about P of gravity, of the forces
  and torques of the cut joints and motors acting on the subtree, and of joint damping``;
* a slider along ``e``: ``sum of m a_G . e = (gravity and cut-joint forces on the subtree) . e``.

With one balance per tree coordinate and the closures of :func:`physics.mechanism.tree.closure_rows`, the
unknowns are the tree accelerations and the closures' multipliers, found in one linear solve. Nothing here
is taken from the Lagrange or DAE derivations: only the description, the tree and its poses. The tree joints'
own reactions follow from these accelerations by Newton's second law per body
(:mod:`physics.mechanism.reactions`).
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
from .reactions import TreeReactions
from .tree import (
    TreePoses,
    baumgarte_terms,
    closure_rows,
    flat,
    native_builder,
    reactions_from_motion,
    rotation,
    sliding_coordinate,
    tree_poses,
    vector_call,
)

SINGULAR_RCOND = 1e-13


def _cross(a: sp.Matrix, b: sp.Matrix) -> sp.Expr:
    return a[0] * b[1] - a[1] * b[0]


@dataclass(frozen=True)
class TreeNewtonEuler:
    """``matrix(s) x = rhs(s, sd)`` with ``x = (tree accelerations, multipliers)``."""

    mechanism: Mechanism
    coordinates: tuple[str, ...]
    row_joints: tuple[str, ...]
    matrix: Callable
    rhs: Callable
    body_angles: Callable
    constraint: Callable  # (s, t) -> (rows,): the closures, for projection and Baumgarte terms
    constraint_jacobian: Callable  # (s) -> (rows, k)
    velocity_rhs: np.ndarray  # (rows,): the motors' speeds on their rows
    motion: Callable  # (s, sd, sdd) -> (B, 9): x, y, phi, their rates and their accelerations, per body
    tree_reactions: TreeReactions
    native: Callable  # () -> NativeSystem of matrix and rhs, Baumgarte terms included (compiled once)

    def reactions(self, s: np.ndarray, sd: np.ndarray, sdd: np.ndarray, multipliers: np.ndarray) -> np.ndarray:
        """Every joint reaction, in the DAE's row layout: the multipliers for the cut joints and motors, Newton's
        second law on this formulation's own accelerations for the tree's joints."""
        return reactions_from_motion(self.tree_reactions, self.motion(s, sd, sdd), multipliers)

    def solve(self, s: np.ndarray, sd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        matrix = np.atleast_2d(self.matrix(s))
        if 1.0 / np.linalg.cond(matrix) < SINGULAR_RCOND:
            raise LinkageError(f"{self.mechanism.name}: singular pose (a dead centre or a redundant constraint)")
        x = np.linalg.solve(matrix, np.ravel(self.rhs(s, sd)))
        k = len(self.coordinates)
        return x[:k], x[k:]


def derive_tree_newton_euler(mechanism: Mechanism) -> TreeNewtonEuler:
    return _derive(mechanism.model_dump_json())


def _subtrees(poses: TreePoses) -> dict[str, set[str]]:
    """Every tree body and the bodies beyond it, itself included."""
    beyond: dict[str, set[str]] = {body: {body} for body in poses.order}
    for body in reversed(poses.order):  # children before parents
        parent = poses.topology.parent[body][1]
        if parent != GROUND:
            beyond[parent] |= beyond[body]
    return beyond


@functools.lru_cache(maxsize=16)
def _derive(description: str) -> TreeNewtonEuler:
    mechanism = Mechanism.model_validate(json.loads(description))
    poses = tree_poses(mechanism)
    s, sd, sdd = poses.s, poses.sd, poses.sdd
    rows, row_joints, speeds, kinds = closure_rows(poses)
    multipliers = sp.Matrix(sp.symbols(f"lam0:{len(rows)}", real=True)) if rows else sp.zeros(0, 1)
    joints = {joint.name: joint for joint in mechanism.joints}
    bodies = {body.name: body for body in mechanism.bodies}
    gravity = sp.Matrix([0, -mechanism.g])

    def acceleration(vector: sp.Matrix) -> sp.Matrix:
        """Second time derivative of an expression of ``s``: ``J sdd + (J sd)_s sd``."""
        jacobian = vector.jacobian(s)
        return jacobian * sdd + (jacobian * sd).jacobian(s) * sd

    angle_rate = {name: (sp.Matrix([poses.angle[name]]).jacobian(s) * sd)[0] for name in bodies}
    angle_acceleration = {name: acceleration(sp.Matrix([poses.angle[name]]))[0] for name in bodies}
    centre_acceleration = {name: acceleration(poses.centre[name]) for name in bodies}

    # external loads on each body: (force, point of application) pairs and pure torques
    forces: dict[str, list[tuple[sp.Matrix, sp.Matrix]]] = {name: [] for name in bodies}
    torques: dict[str, list[sp.Expr]] = {name: [] for name in bodies}

    def add_force(body: str, force: sp.Matrix, point: sp.Matrix) -> None:
        if body != GROUND:
            forces[body].append((force, point))

    def add_torque(body: str, torque: sp.Expr) -> None:
        if body != GROUND:
            torques[body].append(torque)

    row = 0
    while row < len(rows):
        joint = joints[row_joints[row]]
        if kinds[row] == "pin":  # a cut pin: force ON a BY b at the pin
            assert isinstance(joint, Revolute)
            force = sp.Matrix([multipliers[row], multipliers[row + 1]])
            a_body, b_body = joint.a.split(".")[0], joint.b.split(".")[0]
            add_force(a_body, force, poses.world(a_body, mechanism.point_of(joint.a, joint.name)))
            add_force(b_body, -force, poses.world(b_body, mechanism.point_of(joint.b, joint.name)))
            row += 2
        elif kinds[row] == "slide":  # a cut slider: force across the guide at the sliding point, torque
            assert isinstance(joint, Prismatic)
            u = np.array(joint.direction, dtype=float) / np.hypot(*joint.direction)
            normal = rotation(poses.angle[joint.on]) * sp.Matrix([-u[1], u[0]])
            sliding = poses.world(joint.body, mechanism.point_of(f"{joint.body}.{joint.point}", joint.name))
            add_force(joint.body, normal * multipliers[row], sliding)
            add_force(joint.on, -normal * multipliers[row], sliding)
            add_torque(joint.body, multipliers[row + 1])
            add_torque(joint.on, -multipliers[row + 1])
            row += 2
        else:  # a speed motor's torque: on body b, and minus it on body a
            assert isinstance(joint, Revolute)
            add_torque(joint.b.split(".")[0], multipliers[row])
            add_torque(joint.a.split(".")[0], -multipliers[row])
            row += 1
    for driver in mechanism.drivers:
        if driver.torque is not None:
            joint = joints[driver.joint]
            assert isinstance(joint, Revolute)
            add_torque(joint.b.split(".")[0], sp.Float(driver.torque))
            add_torque(joint.a.split(".")[0], -sp.Float(driver.torque))
    for joint in mechanism.joints:
        if isinstance(joint, Revolute) and joint.damping:
            a_body, b_body = joint.a.split(".")[0], joint.b.split(".")[0]
            relative = (angle_rate[b_body] if b_body != GROUND else 0) - (angle_rate[a_body] if a_body != GROUND else 0)
            add_torque(b_body, -joint.damping * relative)
            add_torque(a_body, joint.damping * relative)
        elif isinstance(joint, Prismatic) and joint.damping:
            # -c v along the guide on the slider at its sliding point, the opposite on the guide's body there
            coordinate, along, sliding = sliding_coordinate(poses, joint)
            speed = (sp.Matrix([coordinate]).jacobian(s) * sd)[0]
            add_force(joint.body, -joint.damping * speed * along, sliding)
            add_force(joint.on, joint.damping * speed * along, sliding)

    balances: list[sp.Expr] = []
    subtrees = _subtrees(poses)
    for index, body in enumerate(poses.order):
        joint = joints[poses.coordinates[index]]
        members = subtrees[body]
        if isinstance(joint, Revolute):
            child_side = joint.a if joint.a.split(".")[0] == body else joint.b
            pivot = poses.world(body, mechanism.point_of(child_side, joint.name))
            inertial = sum(
                (_cross(poses.centre[name] - pivot, bodies[name].mass * centre_acceleration[name])
                 + bodies[name].inertia * angle_acceleration[name] for name in members),
                sp.Integer(0),
            )
            applied = sum((_cross(poses.centre[name] - pivot, bodies[name].mass * gravity) for name in members),
                          sp.Integer(0))
            applied += sum((_cross(point - pivot, force) for name in members for force, point in forces[name]),
                           sp.Integer(0))
            applied += sum((torque for name in members for torque in torques[name]), sp.Integer(0))
        else:
            u = np.array(joint.direction, dtype=float) / np.hypot(*joint.direction)
            along = rotation(poses.angle[joint.on]) * sp.Matrix(u)
            inertial = sum(((bodies[name].mass * centre_acceleration[name]).dot(along) for name in members),
                           sp.Integer(0))
            applied = sum(((bodies[name].mass * gravity).dot(along) for name in members), sp.Integer(0))
            applied += sum((force.dot(along) for name in members for force, _ in forces[name]), sp.Integer(0))
        balances.append(inertial - applied)

    phi = sp.Matrix(rows) if rows else sp.zeros(0, 1)
    closures = list(phi.jacobian(s) * sdd + (phi.jacobian(s) * sd).jacobian(s) * sd) if rows else []
    equations = sp.Matrix(balances + closures)
    unknowns = list(sdd) + list(multipliers)
    matrix = equations.jacobian(unknowns)
    zero = {symbol: 0 for symbol in unknowns}
    rhs = -equations.xreplace(zero)

    def compile_(expr, *args):
        return sp.lambdify(args, expr, modules="numpy", cse=True)

    flat_s, flat_sd = list(s), list(sd)
    angles = sp.Matrix([poses.angle[body.name] for body in mechanism.bodies])
    centre_velocity = {name: poses.centre[name].jacobian(s) * sd for name in bodies}
    motion = sp.Matrix([[*poses.centre[name], poses.angle[name], *centre_velocity[name], angle_rate[name],
                         *centre_acceleration[name], angle_acceleration[name]] for name in bodies])
    phi_jacobian = phi.jacobian(s) if rows else sp.zeros(0, len(s))
    stabilised = sp.Matrix(rhs)
    if rows:
        stabilised[len(s):, 0] = rhs[len(s):, 0] - baumgarte_terms(phi, phi_jacobian, sd, speeds)
    return TreeNewtonEuler(
        mechanism=mechanism,
        coordinates=poses.coordinates,
        row_joints=tuple(row_joints),
        matrix=vector_call(compile_(matrix, flat_s), 1),
        rhs=flat(vector_call(compile_(rhs, flat_s, flat_sd), 2)),
        body_angles=flat(vector_call(compile_(angles, flat_s), 1)),
        constraint=vector_call(compile_(phi, flat_s, poses.t), 1, time=True),
        constraint_jacobian=vector_call(compile_(phi_jacobian, flat_s), 1),
        velocity_rhs=np.array(speeds),
        motion=_motion_call(compile_(motion, flat_s, flat_sd, list(sdd))),
        tree_reactions=TreeReactions(mechanism, poses.topology, poses.order, tuple(row_joints), tuple(kinds)),
        native=native_builder(s, sd, poses.t, matrix, stabilised),
    )


def _motion_call(function: Callable) -> Callable:
    return lambda s, sd, sdd: np.array(function(list(s), list(sd), list(sdd)), dtype=float)
