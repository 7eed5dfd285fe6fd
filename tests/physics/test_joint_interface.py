"""Issue 24, "one pipeline": every joint kind's equations live in its module behind one interface
(physics/mechanism/joints/), so the formulations iterate over joints through the registry and none of them
switches on a joint's kind. Checked by reading their source: no comparison of a ``kind`` to a string (``==``,
``!=``, ``in``), and no ``isinstance`` test against a joint kind's model class."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from physics.mechanism import joints

MECHANISM = Path(joints.__file__).resolve().parent.parent
# the formulations: the numeric constraints and DAE, the three derivations and their shared tree, the joint and
# tree coordinates and the graph
FORMULATIONS = sorted(
    [MECHANISM / name for name in ("numeric_dae.py", "constraints.py", "joint_coordinates.py", "tree_coordinates.py",
                                   "topology.py")]
    + list(MECHANISM.glob("symbolic*.py"))
)
MODELS = {"Revolute", "Prismatic", "Gear", "Driver"}


def _names_kind(node: ast.AST) -> bool:
    """``kind`` or ``<anything>.kind``."""
    return (isinstance(node, ast.Name) and node.id == "kind") or (isinstance(node, ast.Attribute)
                                                                 and node.attr == "kind")


def _is_text(node: ast.AST) -> bool:
    if isinstance(node, ast.Constant):
        return isinstance(node.value, str)
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return any(_is_text(element) for element in node.elts)
    return False


def switches(source: str) -> list[str]:
    """Every place of ``source`` that asks a joint what kind it is by a string or by its model class."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Compare):
            sides = [node.left, *node.comparators]
            if any(_names_kind(side) for side in sides) and any(_is_text(side) for side in sides):
                found.append(f"line {node.lineno}: {ast.unparse(node)}")
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "isinstance":
            classes = node.args[1] if len(node.args) > 1 else None
            named = {n.id for n in ast.walk(classes) if isinstance(n, ast.Name)} if classes is not None else set()
            if named & MODELS:
                found.append(f"line {node.lineno}: {ast.unparse(node)}")
    return found


def test_the_scan_finds_a_switch_on_a_kind():
    """The scan itself: each form of switch it is meant to catch is caught, and the registry's lookup is not."""
    assert switches('if joint.kind == "revolute":\n    pass')
    assert switches('x = driver.kind != "speed"')
    assert switches('y = joint.kind in ("revolute", "prismatic")')
    assert switches("z = isinstance(joint, Prismatic)")
    assert switches("z = isinstance(joint, (Revolute, Gear))")
    assert not switches("kind = KINDS[joint.kind]\nrows = kind.rows(bodies, values, k)")
    assert not switches('label = f"{kind.label} {joint.name}"')


@pytest.mark.parametrize("path", FORMULATIONS, ids=lambda path: path.name)
def test_no_formulation_switches_on_a_joints_kind(path):
    assert switches(path.read_text()) == []


def test_every_formulation_is_scanned():
    names = {path.name for path in FORMULATIONS}
    assert {"numeric_dae.py", "constraints.py", "symbolic_dae.py", "symbolic_tree.py", "symbolic_lagrange.py",
            "symbolic_newton_euler.py", "joint_coordinates.py", "tree_coordinates.py", "topology.py"} <= names


class Still(joints.Kinematics):
    """Plain floats: every body at rest at its own angle, its points shifted by its number."""

    time = 0.0

    def angle(self, body):
        return 0.1 * (body + 1)

    def spin(self, body):
        return 0.0

    def alpha(self, body):
        return 0.0

    def point(self, body, arm):
        return (arm[0] + body, arm[1]), (0.0, 0.0), (0.0, 0.0)

    def turned(self, body, vector):
        return tuple(vector)

    def plus(self, *terms):
        return sum(terms, 0.0)

    def times(self, *factors):
        out = 1.0
        for factor in factors:
            out *= factor
        return out

    def negative(self, x):
        return -x


def test_every_kind_writes_one_row_per_reaction_name():
    """Each kind's rows, evaluated with plain numbers through the interface the formulations use, are one per
    reaction row name, and their loads fall only on bodies the joint reaches: every kind of the presets."""
    from physics.mechanism import MECHANISM_PRESETS  # noqa: PLC0415

    seen = set()
    for make in MECHANISM_PRESETS.values():
        mechanism = make()
        index = {body.name: k for k, body in enumerate(mechanism.bodies)}
        for joint in mechanism.joints:
            kind = joints.kind_of(joint)
            bodies = kind.structure_bodies(joint, lambda name: index.get(name, -1), mechanism)
            rows = kind.rows(bodies, kind.values(joint, mechanism), Still())
            assert len(rows) == len(kind.meanings), joint.name
            for row in rows:
                assert row.loads and {load.body for load in row.loads} <= set(bodies), joint.name
            seen.add(kind.name)
    assert seen == set(joints.KINDS)
