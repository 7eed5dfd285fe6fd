"""The spanning tree of a mechanism in symbols: one coordinate per tree joint, every body's pose in them.

Shared geometry of the tree formulations (Lagrange, Newton–Euler): each writes its own dynamics on top. A pin
joint's coordinate is the child's rotation relative to its parent (zero in the sketch); a slider's is its
travel along the guide from where the sketch draws it. The joints left out of the tree, and the speed motors,
become constraint rows ``Phi(s, t) = 0`` written here in the same form as the DAE's, so the multipliers of
every formulation mean the same: for a pin, the force ON body ``a`` BY body ``b``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from .model import GROUND, Mechanism, Prismatic, Revolute
from .topology import Topology, analyse


def rotation(phi) -> sp.Matrix:
    return sp.Matrix([[sp.cos(phi), -sp.sin(phi)], [sp.sin(phi), sp.cos(phi)]])


@dataclass
class TreePoses:
    """Symbols ``s``, ``sd``, ``sdd``, ``t``; every body's ``angle`` and centre of mass ``centre`` in them."""

    mechanism: Mechanism
    topology: Topology
    order: list[str]
    coordinates: tuple[str, ...]
    s: sp.Matrix
    sd: sp.Matrix
    sdd: sp.Matrix
    t: sp.Symbol
    drawn_centres: dict[str, sp.Matrix]
    angle: dict[str, sp.Expr] = field(default_factory=dict)
    centre: dict[str, sp.Matrix] = field(default_factory=dict)

    def world(self, body: str, sketch_xy) -> sp.Matrix:
        """Where the point drawn at ``sketch_xy`` on ``body`` is, in the tree coordinates."""
        drawn = sp.Matrix(sketch_xy)
        if body == GROUND:
            return drawn
        return self.centre[body] + rotation(self.angle[body]) * (drawn - self.drawn_centres[body])


def sliding_coordinate(poses: TreePoses, joint: Prismatic) -> tuple[sp.Expr, sp.Matrix, sp.Matrix]:
    """A slider's sliding coordinate in the tree coordinates (the distance of its sliding point from the guide's
    through point, along the guide), the guide's unit direction and the sliding point, both in the world."""
    mechanism = poses.mechanism
    u = np.array(joint.direction, dtype=float) / np.hypot(*joint.direction)
    along = rotation(poses.angle[joint.on]) * sp.Matrix([float(u[0]), float(u[1])])
    sliding = poses.world(joint.body, mechanism.point_of(f"{joint.body}.{joint.point}", joint.name))
    through = poses.world(joint.on, mechanism.point_of(f"{joint.on}.{joint.through}", joint.name))
    return (along.T * (sliding - through))[0], along, sliding


def tree_poses(mechanism: Mechanism) -> TreePoses:
    topology = analyse(mechanism)
    joints = {joint.name: joint for joint in mechanism.joints}
    order = bfs_order(topology.parent)
    size = len(order)
    poses = TreePoses(
        mechanism=mechanism, topology=topology, order=order,
        coordinates=tuple(topology.parent[body][0] for body in order),
        s=sp.Matrix(sp.symbols(f"s0:{size}", real=True)), sd=sp.Matrix(sp.symbols(f"sd0:{size}", real=True)),
        sdd=sp.Matrix(sp.symbols(f"sdd0:{size}", real=True)), t=sp.Symbol("t", real=True),
        drawn_centres={body.name: sp.Matrix(body.centre) for body in mechanism.bodies},
        angle={GROUND: sp.Integer(0)}, centre={GROUND: sp.zeros(2, 1)},
    )
    for index, body in enumerate(order):
        joint_name, parent = topology.parent[body]
        joint = joints[joint_name]
        if isinstance(joint, Revolute):
            child_side, parent_side = (joint.a, joint.b) if joint.a.split(".")[0] == body else (joint.b, joint.a)
            poses.angle[body] = poses.angle[parent] + poses.s[index]
            pivot = poses.world(parent, mechanism.point_of(parent_side, joint_name))
            drawn = sp.Matrix(mechanism.point_of(child_side, joint_name))
            poses.centre[body] = pivot - rotation(poses.angle[body]) * (drawn - poses.drawn_centres[body])
        else:
            _place_slider(poses, joint, body, parent, poses.s[index])
    return poses


def closure_rows(poses: TreePoses) -> tuple[list[sp.Expr], list[str], list[float], list[str]]:
    """Constraint rows of the joints left out of the tree and of the speed motors: ``(rows, joint of each row,
    motor speed of each row, kind of each row: "pin", "slide" or "motor")``."""
    mechanism = poses.mechanism
    tree = set(poses.topology.tree_joints)
    rows: list[sp.Expr] = []
    row_joints: list[str] = []
    speeds: list[float] = []
    kinds: list[str] = []
    for joint in mechanism.joints:
        if joint.name not in tree:
            for expression in _cut_rows(poses, joint):
                rows.append(expression)
                row_joints.append(joint.name)
                speeds.append(0.0)
                kinds.append("pin" if isinstance(joint, Revolute) else "slide")
    joints = {joint.name: joint for joint in mechanism.joints}
    for driver in mechanism.drivers:
        if driver.speed is None:
            continue
        joint = joints[driver.joint]
        assert isinstance(joint, Revolute)
        relative = poses.angle[joint.b.split(".")[0]] - poses.angle[joint.a.split(".")[0]]
        rows.append(relative - driver.speed * poses.t)
        row_joints.append(joint.name)
        speeds.append(float(driver.speed))
        kinds.append("motor")
    return rows, row_joints, speeds, kinds


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


def _place_slider(poses: TreePoses, joint: Prismatic, body: str, parent: str, travel) -> None:
    """A slider's child pose: the same rotation as its parent, the sliding point ``travel`` further along the
    guide line (through the guide's point ``through``, direction ``u``) than in the sketch."""
    mechanism = poses.mechanism
    u = np.array(joint.direction, dtype=float) / np.hypot(*joint.direction)
    point = np.array(mechanism.point_of(f"{joint.body}.{joint.point}", joint.name))
    through = np.array(mechanism.point_of(f"{joint.on}.{joint.through}", joint.name))
    drawn_offset = float(u @ (point - through))  # where the sketch puts the sliding point along the guide
    poses.angle[body] = poses.angle[parent]
    turn = rotation(poses.angle[body])
    guide = turn * sp.Matrix(u) * (drawn_offset + travel)
    if body == joint.body:  # the slider rides on its parent's guide
        sliding_point = poses.world(parent, through) + guide
        poses.centre[body] = sliding_point - turn * (sp.Matrix(point) - poses.drawn_centres[body])
    else:  # the guide's carrier hangs from the slider
        guide_point = poses.world(parent, point) - guide
        poses.centre[body] = guide_point - turn * (sp.Matrix(through) - poses.drawn_centres[body])


def _cut_rows(poses: TreePoses, joint) -> list[sp.Expr]:
    """The constraint rows a joint left out of the tree adds (same form as the DAE's, independently written)."""
    mechanism = poses.mechanism
    if isinstance(joint, Revolute):
        a_body, b_body = joint.a.split(".")[0], joint.b.split(".")[0]
        at_a = poses.world(a_body, mechanism.point_of(joint.a, joint.name))
        gap = at_a - poses.world(b_body, mechanism.point_of(joint.b, joint.name))
        return [gap[0], gap[1]]
    u = np.array(joint.direction, dtype=float) / np.hypot(*joint.direction)
    normal = rotation(poses.angle[joint.on]) * sp.Matrix([-u[1], u[0]])
    gap = poses.world(joint.body, mechanism.point_of(f"{joint.body}.{joint.point}", joint.name)) - poses.world(
        joint.on, mechanism.point_of(f"{joint.on}.{joint.through}", joint.name))
    return [(normal.T * gap)[0], poses.angle[joint.body] - poses.angle[joint.on]]


def vector_call(function: Callable, arrays: int, time: bool = False) -> Callable:
    """Call a lambdified function of lists of symbols with plain arrays: ``f(s)``, ``f(s, sd)``, ``f(s, t)``."""
    if time:
        return lambda s, t: np.array(function(list(s), t), dtype=float)
    if arrays == 1:
        return lambda s: np.array(function(list(s)), dtype=float)
    return lambda s, sd: np.array(function(list(s), list(sd)), dtype=float)


def flat(function: Callable) -> Callable:
    return lambda *args: np.ravel(function(*args))


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


def reactions_from_motion(tree_reactions, motion: np.ndarray, multipliers: np.ndarray) -> np.ndarray:
    """Every reaction row from a formulation's ``motion`` (``(B, 9)``: x, y, phi, their rates, their
    accelerations per body) and its multipliers (:class:`physics.mechanism.reactions.TreeReactions`)."""
    motion = np.asarray(motion, dtype=float).reshape(-1, 9)
    return tree_reactions.solve(motion[:, 0:2], motion[:, 2], motion[:, 5], motion[:, 6:8], motion[:, 8],
                                np.asarray(multipliers, dtype=float), velocities=motion[:, 3:5])


BAUMGARTE_GAINS = sp.symbols("baumgarte_alpha baumgarte_beta", real=True)


def baumgarte_terms(phi: sp.Matrix, jacobian: sp.Matrix, sd: sp.Matrix, speeds: list[float]) -> sp.Matrix:
    """What Baumgarte stabilisation takes from the closures' acceleration rows: ``2 alpha Phi' + beta^2 Phi``
    (``Phi' = C sd - nu``, ``nu`` the motors' speeds), in the gain symbols :data:`BAUMGARTE_GAINS`."""
    alpha, beta = BAUMGARTE_GAINS
    return 2 * alpha * (jacobian * sd - sp.Matrix(speeds)) + beta**2 * phi


def native_builder(s: sp.Matrix, sd: sp.Matrix, t: sp.Symbol, matrix: sp.Matrix, vector: sp.Matrix) -> Callable:
    """A function that compiles (once, when first called) ``matrix x = vector`` in ``(s, sd)`` and the
    parameters ``(t, alpha, beta)`` to machine code (:class:`physics.mechanism.native_system.NativeSystem`)."""
    built: list = []

    def build():
        if not built:
            from .native_system import NativeSystem  # noqa: PLC0415  (llvmlite only when a run integrates)

            built.append(NativeSystem(list(s), list(sd), [t, *BAUMGARTE_GAINS], matrix, vector))
        return built[0]

    return build
