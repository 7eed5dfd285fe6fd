"""The spanning tree of a mechanism's *structure* in symbols: one coordinate per tree joint, every body's pose.

Shared geometry of the tree formulations (:mod:`.symbolic_lagrange`, :mod:`.symbolic_newton_euler`): positions
only; each formulation finds its velocities and accelerations its own way (Lagrange by differentiating these
positions, Newton–Euler by rigid-body kinematics body after body). Written from a
:class:`~physics.mechanism.parameters.Structure` and its parameter symbols, never from numbers, so one
derivation serves every mechanism of that structure.

Coordinates as in today's tree (the spanning tree of :func:`physics.mechanism.topology.analyse`, the same
breadth-first search over joints in order): a pin's is the child's rotation relative to its parent, zero in the
sketch (``rotations="relative"``, the default), or the child's own rotation from the sketch
(``rotations="absolute"``: :data:`physics.mechanism.parameters.ROTATIONS`, so a chain sketched hanging
straight down integrates its absolute angles, as the chain engine does); a slider's is its travel along the
guide from where the sketch draws it, either way. A body's angle is then the sum of its pins' coordinates up the
tree (relative) or its nearest pin's coordinate (absolute: a slider keeps its parent's angle); every formulation
reads it from ``pins[body]`` and never assumes which. The joints left out of the tree
(in joint order; a gear pair, which joins no bodies, is always one) and the speed motors (in driver order) are the
constraint rows, in the DAE's form, so every formulation's multipliers mean the same (a pin's: the force ON body
``a`` BY body ``b``). Every row comes from its joint kind (:meth:`physics.mechanism.joints.JointKind.rows`),
written against a :class:`~physics.mechanism.joints.Kinematics` that each tree formulation supplies with its own
velocities and accelerations; a tree joint's coordinate is the one its kind's
:meth:`~physics.mechanism.joints.JointKind.freedom` names (a rotation about a point or a travel along a guide).

Planar vectors are plain ``(x, y)`` tuples of sympy expressions: cheaper to build than matrices.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from .joints import KINDS, MOTOR, Kinematics, Rotation, Row, Translation
from .parameters import ROTATIONS, Structure
from .symbolic_parameters import ParameterSymbols
from .topology import breadth_first

ZERO = sp.Integer(0)
MINUS_ONE = sp.Integer(-1)
ORIGIN = (ZERO, ZERO)


def plus(*terms):
    """A sum kept as written (no flattening, sorting or collecting: sympy's costs on long sums); the
    derivations :func:`settle` what they return."""
    kept = [term for term in terms if term != 0]
    if not kept:
        return ZERO
    return kept[0] if len(kept) == 1 else sp.Add(*kept, evaluate=False)


def times(*factors):
    """A product kept as written; zero if a factor is zero."""
    if any(factor == 0 for factor in factors):
        return ZERO
    kept = [factor for factor in factors if factor != 1]
    if not kept:
        return sp.Integer(1)
    return kept[0] if len(kept) == 1 else sp.Mul(*kept, evaluate=False)


def negative(x):
    return ZERO if x == 0 else times(MINUS_ONE, x)


def add(*vectors):
    return (plus(*(v[0] for v in vectors)), plus(*(v[1] for v in vectors)))


def sub(a, b):
    return (plus(a[0], negative(b[0])), plus(a[1], negative(b[1])))


def scale(k, v):
    return (times(k, v[0]), times(k, v[1]))


def perp(v):
    """``v`` turned by +90 degrees (``z x v``)."""
    return (negative(v[1]), v[0])


def cross(a, b):
    """z-component of ``a x b``."""
    return plus(times(a[0], b[1]), negative(times(a[1], b[0])))


def dot(a, b):
    return plus(times(a[0], b[0]), times(a[1], b[1]))


def turn(angle, v):
    """``R(angle) v``."""
    if angle == 0:
        return v
    c, s = sp.cos(angle), sp.sin(angle)
    return (plus(times(c, v[0]), negative(times(s, v[1]))), plus(times(s, v[0]), times(c, v[1])))


class SympyNumbers:
    """The arithmetic of :class:`~physics.mechanism.joints.Kinematics` in the derivations: sums and products kept
    as written (:func:`plus`, :func:`times`)."""

    def plus(self, *terms):
        return plus(*terms)

    def times(self, *factors):
        return times(*factors)

    def negative(self, x):
        return negative(x)


class TreeKinematics(SympyNumbers, Kinematics):
    """A tree formulation's :class:`~physics.mechanism.joints.Kinematics`: angles and turned vectors from the
    tree's positions (:class:`TreeGeometry`), spins and angular accelerations as the formulation found them
    (``spin[body]``, ``alpha[body]``, the ground's zero); each formulation writes its own :meth:`point`."""

    def __init__(self, geometry: TreeGeometry, spin: dict, alpha: dict) -> None:
        self.geometry, self._spin, self._alpha = geometry, spin, alpha
        self.time = geometry.params.t

    def angle(self, body):
        return self.geometry.body_angle(body)

    def spin(self, body):
        return self._spin[body]

    def alpha(self, body):
        return self._alpha[body]

    def turned(self, body, vector):
        return self.geometry.turned(body, tuple(vector))


@dataclass(frozen=True)
class ClosureRow:
    """One constraint row of a tree formulation: its joint (index), which of its joint's (or its speed motor's)
    rows it is and what its reaction means."""

    joint: int
    part: int
    meaning: str = ""


@dataclass(frozen=True)
class SpanningTree:
    """``order``: bodies parents first (tree coordinate ``k`` belongs to ``order[k]``); ``parent[body] = (joint,
    parent body)``; ``cut``: joints left out, in joint order; ``path[body]``: the coordinates that move it."""

    order: tuple[int, ...]
    parent: dict[int, tuple[int, int]]
    cut: tuple[int, ...]
    path: dict[int, tuple[int, ...]]


def spanning_tree(shape: Structure) -> SpanningTree:
    """Breadth-first from the ground over joints in the description's order
    (:func:`physics.mechanism.topology.breadth_first`, as :func:`~physics.mechanism.topology.analyse` finds it)."""
    parent: dict[int, tuple[int, int]] = breadth_first(
        -1, ((k, joint.a, joint.b) for k, joint in enumerate(shape.joints) if joint.joins))
    tree = {number for number, _ in parent.values()}
    if len(parent) != shape.bodies:
        raise ValueError("structure: a body is not connected to the ground")
    order = tuple(parent)  # discovery order: every parent before its children
    coordinate = {body: k for k, body in enumerate(order)}
    path: dict[int, tuple[int, ...]] = {-1: ()}
    for body in order:
        path[body] = (*path[parent[body][1]], coordinate[body])
    return SpanningTree(order=order, parent=parent, cut=tuple(k for k in range(len(shape.joints)) if k not in tree),
                        path=path)


@dataclass(frozen=True)
class Term:
    """One vector of a point's position: ``vector`` (in parameter symbols) turned by the angle of body ``frame``
    (-1: the ground, not turned), and multiplied by tree coordinate ``travel`` (a slider's) when it is set."""

    frame: int
    vector: tuple
    travel: int | None = None


@dataclass(frozen=True)
class Place:
    """A point of the mechanism as a sum of turned vectors: the form that the tree formulations differentiate by
    the rotation rule ``d R(phi) v / d phi = perp(R(phi) v)`` instead of by walking its expression."""

    terms: tuple[Term, ...]

    def __add__(self, other: Place) -> Place:
        return Place(self.terms + other.terms)

    def __neg__(self) -> Place:
        return Place(tuple(Term(term.frame, (negative(term.vector[0]), negative(term.vector[1])), term.travel)
                           for term in self.terms))

    def __sub__(self, other: Place) -> Place:
        return self + (-other)


@dataclass
class TreeGeometry:
    """Every body's angle (from the sketch) and centre of mass in the tree coordinates ``s``: ``angle[body]`` an
    expression, ``place[body]`` its centre as a :class:`Place`, ``pins[body]`` the pin coordinates whose sum is
    its angle (``pins[-1]`` empty: the ground; with absolute rotations at most one)."""

    shape: Structure
    params: ParameterSymbols
    tree: SpanningTree
    s: tuple
    sd: tuple
    sdd: tuple
    angle: dict = field(default_factory=dict)
    place: dict = field(default_factory=dict)
    pins: dict = field(default_factory=dict)
    offsets: dict = field(default_factory=dict)  # a tree slider's sketch offset along its guide, by joint
    rotations: str = "relative"  # a pin's coordinate: the child's rotation relative to its parent, or its own
    _turned: dict = field(default_factory=dict)
    _values: dict = field(default_factory=dict)

    def turned(self, frame: int, vector) -> tuple:
        """``R(angle[frame]) vector``, each (frame, vector) pair built once."""
        key = (frame, vector)
        found = self._turned.get(key)
        if found is None:
            found = self._turned[key] = turn(self.body_angle(frame), vector)
        return found

    def term_value(self, term: Term) -> tuple:
        turned = self.turned(term.frame, term.vector)
        return turned if term.travel is None else scale(self.s[term.travel], turned)

    def value(self, place: Place) -> tuple:
        found = self._values.get(place)
        if found is None:
            found = self._values[place] = add(*(self.term_value(term) for term in place.terms))
        return found

    def point(self, body: int, arm) -> Place:
        """The point at ``arm`` from ``body``'s centre of mass (for the ground: at ``arm``)."""
        return (self.place[body] if body >= 0 else Place(())) + Place((Term(body, tuple(arm)),))

    def world(self, body: int, arm) -> tuple:
        return self.value(self.point(body, arm))

    @property
    def centre(self) -> dict:
        return {body: self.value(place) for body, place in self.place.items()}

    def rho(self, body: int, arm):
        """The vector from ``body``'s centre of mass to its point at ``arm`` (for the ground: ``arm``)."""
        return self.turned(body, tuple(arm))

    def sketch_point(self, body: int, arm):
        """The point's place in the sketch (a ground point's arm is its coordinates)."""
        return tuple(arm) if body < 0 else add(self.params.bodies[body].centre, arm)

    def freedom(self, joint: int) -> Rotation | Translation | None:
        """The tree coordinate joint ``joint`` would carry, in its parameter symbols."""
        return KINDS[self.shape.joints[joint].kind].freedom(self.params.joints[joint].values)

    def guide(self, joint: int):
        """A slider's guide direction, turned with the guide's body (its ``b``)."""
        freedom = self.freedom(joint)
        assert isinstance(freedom, Translation)
        return self.turned(self.shape.joints[joint].b, tuple(freedom.direction))

    def closure_rows(self, k: Kinematics) -> tuple[list[Row], list[ClosureRow]]:
        """The rows of the cut joints (joint order; a gear is always one) then of the speed motors (driver order),
        in ``k``'s kinematics."""
        rows: list[Row] = []
        names: list[ClosureRow] = []
        for number in self.tree.cut:
            joint, symbols = self.shape.joints[number], self.params.joints[number]
            kind = KINDS[joint.kind]
            for part, row in enumerate(kind.rows(joint.bodies, symbols.values, k)):
                rows.append(row)
                names.append(ClosureRow(number, part, kind.meanings[part]))
        for number, joint_number in sorted((n, j) for j, n in self.shape.speed_driven.items()):
            joint = self.shape.joints[joint_number]
            for part, row in enumerate(MOTOR.rows(joint.bodies[:2], self.params.drivers[number], k)):
                rows.append(row)
                names.append(ClosureRow(joint_number, part, MOTOR.meanings[part]))
        return rows, names

    def body_angle(self, body: int):
        return ZERO if body < 0 else self.angle[body]


def tree_geometry(shape: Structure, params: ParameterSymbols, rotations: str = "relative") -> TreeGeometry:
    """The tree's positions; ``rotations`` (:data:`~physics.mechanism.parameters.ROTATIONS`) says what a
    pin's coordinate is (see the module's text)."""
    if rotations not in ROTATIONS:  # the boundary refuses it in its words (tree_coordinates.check_rotations)
        raise ValueError(f"rotations = {rotations!r}: allowed values {', '.join(ROTATIONS)}")
    absolute = rotations == "absolute"
    tree = spanning_tree(shape)
    size = len(tree.order)
    geometry = TreeGeometry(
        shape=shape, params=params, tree=tree, rotations=rotations,
        s=tuple(sp.symbols(f"s0:{size}", real=True)), sd=tuple(sp.symbols(f"sd0:{size}", real=True)),
        sdd=tuple(sp.symbols(f"sdd0:{size}", real=True)),
    )
    geometry.pins[-1] = ()
    for index, body in enumerate(tree.order):
        k, parent = tree.parent[body]
        joint = shape.joints[k]
        start = geometry.place[parent] if parent >= 0 else Place(())
        freedom = geometry.freedom(k)
        if isinstance(freedom, Rotation):
            child_arm, parent_arm = ((freedom.arm_a, freedom.arm_b) if joint.a == body
                                     else (freedom.arm_b, freedom.arm_a))
            if absolute:  # the child's own rotation: the coordinate is its angle
                geometry.pins[body] = (index,)
                geometry.angle[body] = geometry.s[index]
            else:
                geometry.pins[body] = (*geometry.pins[parent], index)
                geometry.angle[body] = plus(geometry.body_angle(parent), geometry.s[index])
            geometry.place[body] = start + Place((Term(parent, tuple(parent_arm)),
                                                  Term(body, (negative(child_arm[0]), negative(child_arm[1])))))
            continue
        # a travel: the child keeps its parent's angle; the sliding point lies ``offset + travel`` along the guide
        # from the through point, ``offset`` where the sketch puts it
        assert isinstance(freedom, Translation), f"joint {k}: a tree joint carries a rotation or a travel"
        direction = freedom.direction
        offset = dot(direction, sub(geometry.sketch_point(joint.a, freedom.arm_a),
                                    geometry.sketch_point(joint.b, freedom.arm_b)))
        geometry.offsets[k] = offset
        geometry.pins[body] = geometry.pins[parent]
        geometry.angle[body] = geometry.body_angle(parent)
        sign = 1 if body == joint.a else -1  # the slider rides on its parent's guide, or the guide hangs from it
        along = scale(sp.Integer(sign), tuple(direction))
        start_arm, end_arm = (freedom.arm_b, freedom.arm_a) if sign > 0 else (freedom.arm_a, freedom.arm_b)
        geometry.place[body] = start + Place((
            Term(parent, tuple(start_arm)), Term(body, scale(offset, along)), Term(body, along, index),
            Term(body, (negative(end_arm[0]), negative(end_arm[1]))),
        ))
    return geometry


def names_template(shape: Structure, rows: list[ClosureRow]) -> list[str]:
    """Readable names of closure rows, with ``{jK}`` for joint K's name (filled per mechanism)."""
    return [f"closure {{j{row.joint}}}: {row.meaning}''" for row in rows]


class LinearReader:
    """``A`` and ``b`` of equations linear in ``unknowns``, ``A x = b``: the coefficients read off the equations'
    sums and products as :func:`physics.derive.formulation.linear_system` does, with every sub-expression's
    free symbols and split remembered. The recursive kinematics share sub-expressions (a parent's acceleration
    is in every child's), which the plain reader walks again at each use: seconds on a 10-body chain."""

    def __init__(self, unknowns) -> None:
        self.unknowns = list(unknowns)
        self._wanted = frozenset(self.unknowns)
        self._free: dict = {}
        self._split: dict = {}

    def holds(self, expr) -> bool:
        found = self._free.get(expr)
        if found is None:
            if expr.is_Symbol:
                found = expr in self._wanted
            else:
                found = any(self.holds(arg) for arg in expr.args)
            self._free[expr] = found
        return found

    def split(self, expr) -> tuple[dict, object]:
        """``(coefficients, rest)`` with ``expr = sum(coefficients[u] u) + rest``."""
        if not self.holds(expr):
            return {}, expr
        found = self._split.get(expr)
        if found is not None:
            return found
        if expr in self._wanted:
            found = ({expr: sp.Integer(1)}, ZERO)
        elif expr.is_Add:
            coefficients: dict = {}
            rest = []
            for term in expr.args:
                term_coefficients, term_rest = self.split(term)
                for u, c in term_coefficients.items():
                    coefficients.setdefault(u, []).append(c)
                rest.append(term_rest)
            found = ({u: plus(*c) for u, c in coefficients.items()}, plus(*rest))
        elif expr.is_Mul:
            holding = [factor for factor in expr.args if self.holds(factor)]
            if len(holding) != 1:
                raise ValueError(f"equation not linear in the unknowns: {expr}")
            others = [factor for factor in expr.args if factor is not holding[0]]
            inner, inner_rest = self.split(holding[0])
            found = ({u: times(*others, c) for u, c in inner.items()}, times(*others, inner_rest))
        else:
            raise ValueError(f"equation not linear in the unknowns: {expr}")
        self._split[expr] = found
        return found

    def system(self, equations) -> tuple[sp.Matrix, sp.Matrix]:
        # Built from flat lists: sympy's item assignment costs about 8 us an entry (a 42 x 42 DAE: 15 ms)
        entries, right = [], []
        for equation in equations:
            coefficients, rest = self.split(sp.sympify(equation))
            entries += [coefficients.get(u, ZERO) for u in self.unknowns]
            right.append(negative(rest))
        return sp.Matrix(len(equations), len(self.unknowns), entries), sp.Matrix(len(equations), 1, right)


def settle(matrix: sp.Matrix, memo: dict | None = None) -> sp.Matrix:
    """``matrix`` with every sum and product evaluated (sympy's canonical forms), each shared sub-expression once.

    The derivations build their sums unevaluated (:func:`plus`, :func:`times`: sympy's flattening and sorting of
    long sums was most of their time); what they hand on is settled, because sympy's ``cse`` (which the code
    generators run) is not reliable on unevaluated trees: it gave wrong numbers for a draft of the Jansen leg's
    Lagrange system and for most random unevaluated sums of products tried, never once settled."""
    memo = {} if memo is None else memo

    def one(expr):
        found = memo.get(expr)
        if found is None:
            found = memo[expr] = expr if not expr.args else expr.func(*(one(arg) for arg in expr.args))
        return found

    return matrix.applyfunc(one)
