"""Tree coordinates of a maximal-coordinate state: the numbers the tree formulations integrate.

A tree joint's coordinate is the one its kind carries (:meth:`~physics.mechanism.joints.JointKind.freedom`): a
rotation (a pin's: the child's rotation relative to its parent, zero in the sketch) or a travel (a slider's: along
the guide from where the sketch draws it). The spanning tree is :func:`physics.mechanism.topology.
analyse`'s, its bodies parents first (:func:`bfs_order`): the order of the generated tree formulations'
coordinates (:mod:`physics.mechanism.symbolic_tree`). Numbers only (no sympy): a run on a warm cache needs it.
"""

from __future__ import annotations

import numpy as np

from .joints import Rotation, Translation, kind_of
from .model import GROUND, Mechanism
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
    of mass and rotations from the sketch): the coordinate each tree joint's kind carries
    (:meth:`~physics.mechanism.joints.JointKind.freedom`), a relative rotation or a travel along a guide."""
    names = [body.name for body in mechanism.bodies]
    centres = {body.name: np.array(body.centre, dtype=float) for body in mechanism.bodies}

    def pose(body: str):
        if body == GROUND:
            return np.zeros(2), 0.0, np.zeros(2), 0.0
        k = names.index(body)
        return q[3 * k : 3 * k + 2], q[3 * k + 2], qdot[3 * k : 3 * k + 2], qdot[3 * k + 2]

    def turned(phi: float, vector) -> np.ndarray:
        c, s_ = np.cos(phi), np.sin(phi)
        return np.array([[c, -s_], [s_, c]]) @ np.asarray(vector, dtype=float)

    def point(body: str, arm) -> tuple[np.ndarray, np.ndarray]:
        """A point at ``arm`` from ``body``'s sketch centre of mass (a ground point: at ``arm``), and its velocity."""
        r, phi, v, w = pose(body)
        rho = turned(phi, arm)
        return r + rho, v + w * np.array([-rho[1], rho[0]])

    def sketch(body: str, arm) -> np.ndarray:
        return np.asarray(arm, dtype=float) + (centres[body] if body != GROUND else 0.0)

    topology = analyse(mechanism)
    joints = {joint.name: joint for joint in mechanism.joints}
    values, rates = [], []
    for body in bfs_order(topology.parent):
        joint_name, parent = topology.parent[body]
        joint = joints[joint_name]
        kind = kind_of(joint)
        freedom = kind.freedom(kind.values(joint, mechanism))
        ends = kind.bodies(joint)
        assert ends is not None  # a tree joint joins two bodies
        a, b = ends
        _, phi_c, _, w_c = pose(body)
        _, phi_p, _, w_p = pose(parent)
        if isinstance(freedom, Rotation):
            values.append(phi_c - phi_p)
            rates.append(w_c - w_p)
            continue
        assert isinstance(freedom, Translation), f"joint {joint_name!r}: a tree joint carries a rotation or a travel"
        u = np.asarray(freedom.direction, dtype=float)
        sliding, sliding_rate = point(a, freedom.arm_a)
        guide, guide_rate = point(b, freedom.arm_b)
        _, phi_on, _, w_on = pose(b)
        direction = turned(phi_on, u)
        drawn = sketch(a, freedom.arm_a) - sketch(b, freedom.arm_b)
        values.append(float(direction @ (sliding - guide)) - float(u @ drawn))
        rates.append(float(w_on * np.array([-direction[1], direction[0]]) @ (sliding - guide)
                           + direction @ (sliding_rate - guide_rate)))
    return np.array(values), np.array(rates)
