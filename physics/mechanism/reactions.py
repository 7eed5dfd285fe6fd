"""Every joint reaction of a tree formulation, from its own motion: Newton's second law per body, leaves inward.

Lagrange and Newton–Euler on a spanning tree solve for the tree accelerations and for the multipliers of the
joints they close by constraints (cut joints, speed motors); the tree's own joints carry forces that those
equations never name. Given a formulation's motion (every body's centre of mass, angle, angular rate and
accelerations) and its multipliers, the force each tree joint exerts follows body by body, children before
parents, as :mod:`physics.reactions` does for chains:

    m a_G = m g + (loads of cut joints, motors) - (forces this body exerts on its tree children) + F_joint

and, for a slider (which also holds the relative angle), the moment balance about G gives its torque. A pin's
moment balance is not needed: the accelerations already satisfy it. The result is written in the DAE's row
layout and sign convention (:mod:`physics.mechanism.constraints`: a pin's force ON body ``a`` BY body ``b``; a
slider's force across the guide on ``body`` and the torque on ``body``; a motor's torque on ``b``) without
calling the DAE, so that the three formulations can be compared reaction by reaction.
"""

from __future__ import annotations

import numpy as np

from .model import GROUND, Mechanism, Prismatic, Revolute
from .topology import Topology


def _cross(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def _turn(phi: float, vector: np.ndarray) -> np.ndarray:
    c, s = np.cos(phi), np.sin(phi)
    return np.array([c * vector[0] - s * vector[1], s * vector[0] + c * vector[1]])


def _side(reference: str) -> str:
    return reference.split(".")[0]


def reaction_row_names(mechanism: Mechanism) -> tuple[str, ...]:
    """``"joint: meaning"`` of every reaction row, in the layout of the DAE's multipliers: a pin's x and y (and
    its motor's torque when speed-driven), a slider's force across the guide and its relative-rotation torque."""
    speeds = {driver.joint for driver in mechanism.drivers if driver.speed is not None}
    names: list[str] = []
    for joint in mechanism.joints:
        if isinstance(joint, Revolute):
            names += [f"{joint.name}: x gap", f"{joint.name}: y gap"]
            if joint.name in speeds:
                names.append(f"{joint.name}: driven angle")
        else:
            names += [f"{joint.name}: offset across the guide", f"{joint.name}: relative rotation"]
    return tuple(names)


class TreeReactions:
    """Reactions of every joint of one mechanism from a tree formulation's motion and multipliers.

    ``order`` lists the bodies parents first (:func:`physics.mechanism.tree.bfs_order`); ``row_joints`` and
    ``row_kinds`` describe the formulation's multipliers (:func:`physics.mechanism.tree.closure_rows`)."""

    def __init__(self, mechanism: Mechanism, topology: Topology, order: list[str], row_joints: tuple[str, ...],
                 row_kinds: tuple[str, ...]) -> None:
        self.mechanism = mechanism
        self.names = [body.name for body in mechanism.bodies]
        self.index = {name: k for k, name in enumerate(self.names)}
        self.mass = np.array([body.mass for body in mechanism.bodies])
        self.inertia = np.array([body.inertia for body in mechanism.bodies])
        self.drawn_centres = {body.name: np.array(body.centre, dtype=float) for body in mechanism.bodies}
        self.joints = {joint.name: joint for joint in mechanism.joints}
        self.parent = topology.parent
        self.order = order
        self.row_joints = row_joints
        self.row_kinds = row_kinds
        self.row_names = reaction_row_names(mechanism)
        self.row_of = {name: k for k, name in enumerate(self.row_names)}

    def _point(self, body: str, drawn, centres: np.ndarray, angles: np.ndarray) -> np.ndarray:
        """World position of the point drawn at ``drawn`` on ``body`` (ground points stay where drawn)."""
        drawn = np.asarray(drawn, dtype=float)
        if body == GROUND:
            return drawn
        k = self.index[body]
        return centres[k] + _turn(float(angles[k]), drawn - self.drawn_centres[body])

    def solve(self, centres: np.ndarray, angles: np.ndarray, rates: np.ndarray, accelerations: np.ndarray,
              angular_accelerations: np.ndarray, multipliers: np.ndarray,
              velocities: np.ndarray | None = None) -> np.ndarray:
        """Every reaction row at one state. ``centres (B, 2)``, ``angles (B,)``, ``rates (B,)`` (angular),
        ``accelerations (B, 2)`` (of the centres), ``angular_accelerations (B,)``, ``multipliers`` (the
        formulation's cut-joint and motor rows), ``velocities (B, 2)`` of the centres (needed by viscous sliders)."""
        mechanism = self.mechanism
        count = len(self.names)
        force = np.zeros((count, 2))  # known loads on each body, excluding its own tree joint
        moment = np.zeros(count)  # their moments about the body's centre of mass
        out = np.zeros(len(self.row_names))

        def load(body: str, vector: np.ndarray, at: np.ndarray) -> None:
            if body != GROUND:
                k = self.index[body]
                force[k] += vector
                moment[k] += _cross(at - centres[k], vector)

        def torque(body: str, value: float) -> None:
            if body != GROUND:
                moment[self.index[body]] += value

        row = 0
        while row < len(self.row_joints):
            joint = self.joints[self.row_joints[row]]
            kind = self.row_kinds[row]
            if kind == "pin":
                assert isinstance(joint, Revolute)
                pull = np.array(multipliers[row : row + 2], dtype=float)
                load(_side(joint.a), pull, self._point(_side(joint.a), self._drawn(joint.a, joint), centres, angles))
                load(_side(joint.b), -pull, self._point(_side(joint.b), self._drawn(joint.b, joint), centres, angles))
                out[self.row_of[f"{joint.name}: x gap"]], out[self.row_of[f"{joint.name}: y gap"]] = pull
                row += 2
            elif kind == "slide":
                assert isinstance(joint, Prismatic)
                normal, sliding = self._guide(joint, centres, angles)
                load(joint.body, normal * multipliers[row], sliding)
                load(joint.on, -normal * multipliers[row], sliding)
                torque(joint.body, float(multipliers[row + 1]))
                torque(joint.on, -float(multipliers[row + 1]))
                out[self.row_of[f"{joint.name}: offset across the guide"]] = multipliers[row]
                out[self.row_of[f"{joint.name}: relative rotation"]] = multipliers[row + 1]
                row += 2
            else:
                assert isinstance(joint, Revolute)
                torque(_side(joint.b), float(multipliers[row]))
                torque(_side(joint.a), -float(multipliers[row]))
                out[self.row_of[f"{joint.name}: driven angle"]] = multipliers[row]
                row += 1
        for driver in mechanism.drivers:
            if driver.torque is not None:
                joint = self.joints[driver.joint]
                torque(_side(joint.b), driver.torque)  # type: ignore[union-attr]
                torque(_side(joint.a), -driver.torque)  # type: ignore[union-attr]
        for joint in mechanism.joints:
            if isinstance(joint, Revolute) and joint.damping:
                a_body, b_body = _side(joint.a), _side(joint.b)
                relative = (rates[self.index[b_body]] if b_body != GROUND else 0.0) - (
                    rates[self.index[a_body]] if a_body != GROUND else 0.0)
                torque(b_body, -joint.damping * relative)
                torque(a_body, joint.damping * relative)
            elif isinstance(joint, Prismatic) and joint.damping:
                assert velocities is not None, "a viscous slider's force needs the bodies' velocities"
                along, sliding = self._along(joint, angles), self._guide(joint, centres, angles)[1]
                speed = float(along @ (self._velocity(joint.body, sliding, centres, rates, velocities)
                                       - self._velocity(joint.on, sliding, centres, rates, velocities)))
                load(joint.body, -joint.damping * speed * along, sliding)
                load(joint.on, joint.damping * speed * along, sliding)
        force[:, 1] -= self.mass * mechanism.g

        for body in reversed(self.order):  # children first: their joints' forces are known when a parent comes
            k = self.index[body]
            joint_name, parent = self.parent[body]
            joint = self.joints[joint_name]
            needed = self.mass[k] * accelerations[k] - force[k]  # what the body's tree joint must supply
            if isinstance(joint, Revolute):
                child_side = joint.a if _side(joint.a) == body else joint.b
                at = self._point(body, self._drawn(child_side, joint), centres, angles)
                sign = 1.0 if child_side == joint.a else -1.0  # rows hold the force ON a BY b
                out[self.row_of[f"{joint.name}: x gap"]], out[self.row_of[f"{joint.name}: y gap"]] = sign * needed
                load(parent, -needed, at)
                continue
            normal, sliding = self._guide(joint, centres, angles)
            spin_needed = self.inertia[k] * angular_accelerations[k] - moment[k] - _cross(sliding - centres[k], needed)
            sign = 1.0 if body == joint.body else -1.0  # rows hold the force and torque on the slider's body
            out[self.row_of[f"{joint.name}: offset across the guide"]] = sign * float(normal @ needed)
            out[self.row_of[f"{joint.name}: relative rotation"]] = sign * spin_needed
            load(parent, -needed, sliding)
            torque(parent, -spin_needed)
        return out

    def _drawn(self, reference: str, joint) -> tuple[float, float]:
        return self.mechanism.point_of(reference, joint.name)

    def _along(self, joint: Prismatic, angles: np.ndarray) -> np.ndarray:
        """The guide's unit direction, turned with ``on``."""
        u = np.array(joint.direction, dtype=float) / np.hypot(*joint.direction)
        return _turn(0.0 if joint.on == GROUND else float(angles[self.index[joint.on]]), u)

    def _velocity(self, body: str, at: np.ndarray, centres: np.ndarray, rates: np.ndarray,
                  velocities: np.ndarray) -> np.ndarray:
        """Velocity of the material point of ``body`` at world position ``at`` (zero on the ground)."""
        if body == GROUND:
            return np.zeros(2)
        k = self.index[body]
        arm = at - centres[k]
        return velocities[k] + rates[k] * np.array([-arm[1], arm[0]])

    def _guide(self, joint: Prismatic, centres: np.ndarray, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The guide's unit normal (perpendicular to its direction, turned with ``on``) and the sliding point."""
        u = np.array(joint.direction, dtype=float) / np.hypot(*joint.direction)
        turn = 0.0 if joint.on == GROUND else float(angles[self.index[joint.on]])
        normal = _turn(turn, np.array([-u[1], u[0]]))
        sliding = self._point(joint.body, self._drawn(f"{joint.body}.{joint.point}", joint), centres, angles)
        return normal, sliding
