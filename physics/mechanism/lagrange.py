"""Lagrange's equations of any mechanism on a spanning tree, its cut joints closed by multipliers.

The tree of :mod:`physics.mechanism.topology` carries one coordinate per joint: the relative rotation of a
pin (child minus parent, zero in the sketch) or the travel of a slider along its guide. Every body's pose is
written symbolically in these coordinates (sympy), the kinetic and potential energies follow, and Lagrange's
equations give ``M(s) sdd = f(s, sd)``. Each joint left out of the tree (and each speed motor) adds constraint
rows ``C(s) sdd = gamma`` with multipliers: for a cut pin, the force ON body ``a`` BY body ``b``, exactly the
DAE's multipliers of the same joint, which is what the tests compare. This derivation never looks at the DAE
of :mod:`physics.mechanism.dae`: it shares only the description and the tree.

The reactions of the tree's own joints follow from this formulation's accelerations by Newton's second law per
body (:mod:`physics.mechanism.reactions`); the augmented system, Baumgarte terms included, is also compiled to
machine code for the integrator when a run first needs it (:mod:`physics.mechanism.native_system`).

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
from .model import Mechanism, Prismatic, Revolute
from .reactions import TreeReactions
from .tree import (
    baumgarte_terms,
    closure_rows,
    flat,
    native_builder,
    reactions_from_motion,
    sliding_coordinate,
    tree_poses,
    vector_call,
)

SINGULAR_RCOND = 1e-13


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
    motion: Callable  # (s, sd, sdd) -> (B, 9): x, y, phi, their rates and their accelerations, per body
    tree_reactions: TreeReactions
    native: Callable  # () -> NativeSystem of the augmented system, Baumgarte terms included (compiled once)

    def reactions(self, s: np.ndarray, sd: np.ndarray, sdd: np.ndarray, multipliers: np.ndarray) -> np.ndarray:
        """Every joint reaction, in the DAE's row layout: the multipliers for the cut joints and motors, Newton's
        second law on this formulation's own accelerations for the tree's joints."""
        return reactions_from_motion(self.tree_reactions, self.motion(s, sd, sdd), multipliers)

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
    poses = tree_poses(mechanism)
    s, sd, t = poses.s, poses.sd, poses.t
    angle, centre = poses.angle, poses.centre
    joints = {joint.name: joint for joint in mechanism.joints}
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
    force += _joint_torques(mechanism, joints, angle, s, sd, poses)

    rows, row_joints, speeds, kinds = closure_rows(poses)
    phi = sp.Matrix(rows) if rows else sp.zeros(0, 1)
    jacobian = phi.jacobian(s) if rows else sp.zeros(0, len(s))
    gamma = -(jacobian * sd).jacobian(s) * sd if rows else sp.zeros(0, 1)

    sdd = poses.sdd
    acceleration = jac_pos * sdd + velocity.jacobian(s) * sd
    angular_acceleration = jac_ang * sdd + spin.jacobian(s) * sd
    motion = sp.Matrix([[positions[k, 0], positions[k, 1], angles[k], velocity[2 * k], velocity[2 * k + 1], spin[k],
                         acceleration[2 * k], acceleration[2 * k + 1], angular_acceleration[k]]
                        for k in range(len(bodies))])

    k, count = len(s), len(rows)
    augmented = sp.zeros(k + count, k + count)
    augmented[:k, :k] = mass
    right = sp.Matrix(force)
    if rows:
        augmented[:k, k:], augmented[k:, :k] = -jacobian.T, jacobian
        right = right.col_join(gamma - baumgarte_terms(phi, jacobian, sd, speeds))

    def compile_(expr, *args):
        return sp.lambdify(args, expr, modules="numpy", cse=True)

    flat_s, flat_sd = list(s), list(sd)
    return TreeLagrange(
        mechanism=mechanism,
        coordinates=poses.coordinates,
        row_joints=tuple(row_joints),
        mass=vector_call(compile_(mass, flat_s), 1),
        force=vector_call(compile_(force, flat_s, flat_sd), 2),
        constraint=vector_call(compile_(phi, flat_s, t), 1, time=True),
        constraint_jacobian=vector_call(compile_(jacobian, flat_s), 1),
        gamma=vector_call(compile_(gamma, flat_s, flat_sd), 2),
        body_angles=flat(vector_call(compile_(angles, flat_s), 1)),
        body_centres=vector_call(compile_(positions, flat_s), 1),
        velocity_rhs=np.array(speeds),
        motion=_motion_call(compile_(motion, flat_s, flat_sd, list(sdd))),
        tree_reactions=TreeReactions(mechanism, poses.topology, poses.order, tuple(row_joints), tuple(kinds)),
        native=native_builder(s, sd, t, augmented, right),
    )


def _motion_call(function: Callable) -> Callable:
    return lambda s, sd, sdd: np.array(function(list(s), list(sd), list(sdd)), dtype=float)


def _joint_torques(mechanism, joints, angle, s, sd, poses) -> sp.Matrix:
    """Generalised forces of motor torques, pin damping and slider damping, by virtual power."""
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
            coordinate, _, _ = sliding_coordinate(poses, joint)
            gradient = sp.Matrix([sp.diff(coordinate, q) for q in s])
            out -= gradient * joint.damping * (gradient.T * sd)[0]
    return out


