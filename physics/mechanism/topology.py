"""Which bodies a mechanism's joints connect: connectedness, loops and the Grübler–Kutzbach mobility count.

Bodies and the ground are the nodes of a graph whose edges are the joints. A spanning tree from the ground
reaches every body of a connected mechanism; each joint left out of the tree (a *cut* joint) closes one
independent loop, made of the cut joint and the tree's path between its two bodies. The formulations that
come later use the same split: the tree carries the coordinates, the cut joints are closed by multipliers.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Hashable, Iterable
from dataclasses import dataclass
from typing import Any

from .description import GROUND, Mechanism
from .joints import MOTOR, kind_of

PIN = "revolute"  # the pin's kind name (physics.mechanism.joints.revolute)


def joint_bodies(joint: Any) -> tuple[str, str] | None:
    """The two bodies (or ``"ground"``) a joint connects; None for a coupler of joints (a gear)."""
    return kind_of(joint).bodies(joint)


@dataclass(frozen=True)
class Loop:
    """One independent loop: the cut joint that closes it and every joint around it, in order."""

    cut_joint: str
    joints: tuple[str, ...]

    def describe(self) -> str:
        return "loop " + " - ".join(self.joints)


@dataclass(frozen=True)
class Topology:
    """``tree_joints`` reach every body from the ground; ``loops`` are closed by the cut joints;
    ``mobility`` is the Grübler–Kutzbach count 3 B - 2 J - G - D (G: gears, D: speed drivers): each kind
    removes its own count (:mod:`physics.mechanism.joints`)."""

    bodies: tuple[str, ...]
    tree_joints: tuple[str, ...]
    loops: tuple[Loop, ...]
    mobility: int
    parent: dict[str, tuple[str, str]]  # body -> (joint to its parent, parent body)


def open_tree_of_pins(mechanism: Mechanism, topology: Topology | None) -> bool:
    """True when every joint of ``mechanism`` is a pin of its spanning tree (no loop, gear or slider; motors on
    any pin allowed) and the ground reaches every body: the structure whose tree reactions have a closed form
    (:func:`physics.mechanism.tree_reactions.plan`) and whose constraint rows are independent at every pose
    (:attr:`physics.mechanism.prepared.Prepared.full_rank_by_structure`). Here, apart from that closed form, so
    a DAE run's assembly asks it without importing the closed form only the tree formulations use."""
    if topology is None or topology.loops or not mechanism.joints:
        return False
    if any(kind_of(joint).name != PIN for joint in mechanism.joints):
        return False
    return {joint for joint, _ in topology.parent.values()} == {joint.name for joint in mechanism.joints}


def breadth_first(root: Hashable, edges: Iterable[tuple[Any, Hashable, Hashable]]) -> dict:
    """The spanning tree found breadth-first from ``root`` over ``edges``, ``(joint, one end, other end)`` taken
    in their order: ``parent[body] = (joint, parent body)`` for every body reached, in the order found, so every
    parent comes before its children. Written once for :func:`analyse` (by names) and the tree formulations
    (:func:`physics.mechanism.symbolic_tree.spanning_tree`, by index): their coordinates must be in this order."""
    adjacency: dict = {}
    for joint, first, second in edges:
        adjacency.setdefault(first, []).append((joint, second))
        adjacency.setdefault(second, []).append((joint, first))
    parent: dict = {}
    seen = {root}
    queue = deque([root])
    while queue:
        node = queue.popleft()
        for joint, other in adjacency.get(node, ()):
            if other not in seen:
                seen.add(other)
                parent[other] = (joint, node)
                queue.append(other)
    return parent


def analyse(mechanism: Mechanism) -> Topology:
    """The mechanism's spanning tree, loops and mobility count; raises ValueError naming the body that the
    ground cannot reach (a disconnected mechanism)."""
    edges = [(joint.name, *ends) for joint in mechanism.joints if (ends := joint_bodies(joint)) is not None]
    parent: dict[str, tuple[str, str]] = breadth_first(GROUND, edges)
    tree = [joint_name for joint_name, _ in parent.values()]
    seen = {GROUND, *parent}
    unreached = [body.name for body in mechanism.bodies if body.name not in seen]
    if unreached:
        raise ValueError(
            f"body {unreached[0]!r}: not connected to the ground by any chain of joints "
            f"(unconnected: {', '.join(unreached)})"
        )
    loops = tuple(_loop(joint, parent) for joint in mechanism.joints
                  if joint.name not in tree and joint_bodies(joint) is not None)
    removed = (sum(kind_of(joint).removed for joint in mechanism.joints)
               + sum(MOTOR.removed(driver) for driver in mechanism.drivers))
    mobility = 3 * len(mechanism.bodies) - removed
    return Topology(
        bodies=tuple(body.name for body in mechanism.bodies),
        tree_joints=tuple(tree),
        loops=loops,
        mobility=mobility,
        parent=parent,
    )


def _path_to_ground(body: str, parent: dict[str, tuple[str, str]]) -> list[tuple[str, str]]:
    """``[(joint, body), ...]`` from ``body`` up to the ground."""
    path = []
    while body != GROUND:
        joint, up = parent[body]
        path.append((joint, body))
        body = up
    return path


def _loop(joint: Any, parent: dict[str, tuple[str, str]]) -> Loop:
    ends = joint_bodies(joint)
    assert ends is not None
    first, second = ends
    up_first = _path_to_ground(first, parent)
    up_second = _path_to_ground(second, parent)
    bodies_first = [GROUND] + [body for _, body in reversed(up_first)]
    bodies_second = [GROUND] + [body for _, body in reversed(up_second)]
    common = 0
    while common < min(len(bodies_first), len(bodies_second)) and bodies_first[common] == bodies_second[common]:
        common += 1
    # from the first body up to the common ancestor, down to the second body, and the cut joint back
    down_first = [j for j, _ in reversed(up_first)][common - 1 :]
    down_second = [j for j, _ in reversed(up_second)][common - 1 :]
    return Loop(cut_joint=joint.name, joints=tuple(list(reversed(down_first)) + down_second + [joint.name]))
