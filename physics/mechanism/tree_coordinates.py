"""Tree coordinates of a maximal-coordinate state: the numbers the tree formulations integrate.

A pin joint's coordinate is the child's rotation relative to its parent (zero in the sketch); a slider's is its
travel along the guide from where the sketch draws it. The spanning tree is :func:`physics.mechanism.topology.
analyse`'s, its bodies parents first (:func:`bfs_order`): the order of the generated tree formulations'
coordinates (:mod:`physics.mechanism.symbolic_tree`). Numbers only (no sympy): a run on a warm cache needs it.
"""

from __future__ import annotations

import numpy as np

from .model import GROUND, Mechanism, Prismatic, Revolute
from .topology import analyse


def bfs_order(parent: dict[str, tuple[str, str]]) -> list[str]:
    """Bodies ordered so that every parent comes before its children."""
    depth: dict[str, int] = {}

    def level(body: str) -> int:
        if body == GROUND:
            return 0
        if body not in depth:
            depth[body] = level(parent[body][1]) + 1
        return depth[body]

    return sorted(parent, key=lambda body: (level(body), list(parent).index(body)))


def tree_state(mechanism: Mechanism, q: np.ndarray, qdot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tree coordinates and rates ``(s, sd)`` of a maximal-coordinate state ``(q, qdot)`` (3 per body, centres
    of mass and rotations from the sketch): a pin's relative rotation, a slider's travel along its guide."""
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
    for body in bfs_order(topology.parent):
        joint_name, parent = topology.parent[body]
        joint = joints[joint_name]
        _, phi_c, _, w_c = pose(body)
        _, phi_p, _, w_p = pose(parent)
        if isinstance(joint, Revolute):
            values.append(phi_c - phi_p)
            rates.append(w_c - w_p)
            continue
        assert isinstance(joint, Prismatic)  # a tree joint joins two bodies: a pin or a slider
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
