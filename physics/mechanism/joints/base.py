"""What a joint kind provides, in one place: the interface every module of this package implements.

A kind is one module (``revolute.py``, ``prismatic.py``, ``gear.py``; the motors of ``motor.py`` ride on a
revolute joint) holding one :class:`JointKind`. Everything else in :mod:`physics.mechanism` asks the kind rather
than switching on a tag:

* its file fields: ``model``, a pydantic class with ``kind`` as its tag, and :meth:`JointKind.check`, the
  references to bodies, points or other joints (one-line errors naming the joint and the field);
* its place in the graph: :meth:`JointKind.bodies` (the two bodies it joins, or None for a coupler that joins
  none) and ``removed``, the degrees of freedom it takes away in the Grübler–Kutzbach count;
* its numbers: ``fields`` (the parameter vector's entries, ``"<label> <name>.<field>"``) and
  :meth:`JointKind.values`;
* its constraint rows: ``meanings`` (the reaction rows' names, ``lambda[JOINT: meaning]`` in a run's CSV: a
  contract) and, for rows that hold a sum of body angles, :meth:`JointKind.angle_rows`, written once against
  whatever numbers it is given: sympy symbols for the three derivations (each differentiates the sum its own
  way) and floats for the numeric constraints of assembly and reactions;
* its sketch: :meth:`JointKind.at_pose`, the joint redrawn for a sketch whose bodies have turned;
* how it is drawn: ``drawing``, a word the app's scene reads (``"pin"``, ``"guide"``, ``"mesh"``);
* its equations, written once: :meth:`JointKind.rows` (its constraint rows: each row's value, its first and second
  time derivatives and the loads its multiplier applies), :meth:`JointKind.damper` (the relative motion its
  damper resists) and :meth:`JointKind.freedom` (the tree coordinate it carries: a rotation about a point or a
  travel along a guide). They are written against a :class:`Kinematics`, which each formulation supplies with its
  own rigid-body kinematics and its own numbers: unevaluated sympy sums for the three derivations, numpy arrays
  (every joint of a kind at once) for the numeric constraints of assembly and reactions.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from pydantic import BaseModel

GROUND = "ground"

Point = tuple[float, float]


def finite_point(value: object, what: str) -> Point:
    """``[x, y]`` of two finite numbers, else ValueError naming ``what``."""
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise ValueError(f"{what}: expected [x, y], got {value!r}")
    out = []
    for number in value:
        if isinstance(number, bool) or not isinstance(number, (int, float)) or not math.isfinite(float(number)):
            raise ValueError(f"{what}: coordinates must be finite numbers, got {value!r}")
        out.append(float(number))
    return (out[0], out[1])


class Kinematics(ABC):
    """What a joint's equations may ask of a formulation: bodies' angles, spins and angular accelerations, a
    point's position, velocity and acceleration, a vector turned with a body, the time, and the arithmetic of its
    numbers (``plus``, ``times``, ``negative``: sympy's unevaluated sums in the derivations, numpy's in the
    numeric constraints). Body ``-1`` (or whatever the formulation gives for it) is the ground, at rest."""

    time: Any

    @abstractmethod
    def angle(self, body: Any) -> Any: ...

    @abstractmethod
    def spin(self, body: Any) -> Any: ...

    @abstractmethod
    def alpha(self, body: Any) -> Any: ...

    @abstractmethod
    def point(self, body: Any, arm: Any) -> tuple[Any, Any, Any]:
        """Position, velocity and acceleration of the point at ``arm`` from ``body``'s sketch centre of mass (for
        the ground: the point at ``arm``)."""

    @abstractmethod
    def turned(self, body: Any, vector: Any) -> Any:
        """``R(angle(body)) vector``."""

    @abstractmethod
    def plus(self, *terms: Any) -> Any: ...

    @abstractmethod
    def times(self, *factors: Any) -> Any: ...

    @abstractmethod
    def negative(self, x: Any) -> Any: ...

    # planar vectors as ``(x, y)`` pairs, built from the three operations above
    def add(self, *vectors: Any) -> tuple[Any, Any]:
        return (self.plus(*(v[0] for v in vectors)), self.plus(*(v[1] for v in vectors)))

    def sub(self, a: Any, b: Any) -> tuple[Any, Any]:
        return (self.plus(a[0], self.negative(b[0])), self.plus(a[1], self.negative(b[1])))

    def scale(self, k: Any, v: Any) -> tuple[Any, Any]:
        return (self.times(k, v[0]), self.times(k, v[1]))

    def perp(self, v: Any) -> tuple[Any, Any]:
        """``v`` turned by +90 degrees."""
        return (self.negative(v[1]), v[0])

    def dot(self, a: Any, b: Any) -> Any:
        return self.plus(self.times(a[0], b[0]), self.times(a[1], b[1]))


@dataclass(frozen=True)
class Force:
    """A multiplier's load per unit: ``force`` on ``body`` at ``point`` (a world point)."""

    body: Any
    force: tuple[Any, Any]
    point: tuple[Any, Any]


@dataclass(frozen=True)
class Torque:
    """A multiplier's load per unit: a torque ``torque`` on ``body``."""

    body: Any
    torque: Any


@dataclass(frozen=True)
class Row:
    """One scalar equation of a joint in a formulation's numbers: ``position`` (``Phi``, zero when it holds),
    ``velocity`` (its first time derivative, linear in the rates) and ``acceleration`` (its second, linear in the
    accelerations), and ``loads``, what its multiplier applies per unit (the reaction's meaning: the same
    generalised force as the row's gradient, written as forces at points and torques so that Newton–Euler can take
    their moments)."""

    position: Any
    velocity: Any
    acceleration: Any
    loads: tuple[Force | Torque, ...] = ()


@dataclass(frozen=True)
class Rotation:
    """The tree coordinate of a pin: the rotation of one body relative to the other about the point at
    ``arm_a`` on body ``a`` and ``arm_b`` on body ``b`` (the same point in the sketch)."""

    arm_a: Any
    arm_b: Any


@dataclass(frozen=True)
class Translation:
    """The tree coordinate of a slider: the travel of body ``a``'s point at ``arm_a`` along body ``b``'s guide
    through its point at ``arm_b``, unit direction ``direction`` (in the sketch), the two keeping their angle."""

    arm_a: Any
    arm_b: Any
    direction: Any


def angle_row(row: AngleRow, k: Kinematics) -> Row:
    """A row ``sum c angle(body) - constant - rate t``: its derivatives are the same sum of spins minus ``rate``
    and of angular accelerations; its multiplier is a torque ``c`` on every body of the sum."""
    return Row(
        k.plus(*(k.times(c, k.angle(body)) for c, body in row.terms), k.negative(row.constant),
               k.negative(k.times(row.rate, k.time))),
        k.plus(*(k.times(c, k.spin(body)) for c, body in row.terms), k.negative(row.rate)),
        k.plus(*(k.times(c, k.alpha(body)) for c, body in row.terms)),
        tuple(Torque(body, c) for c, body in row.terms),
    )


@dataclass(frozen=True)
class AngleRow:
    """One constraint row ``sum(c * angle(body)) - constant - rate * t = 0``: ``terms`` are ``(c, body)`` (body
    by index, -1 the ground, whose angle is zero), ``constant`` and ``rate`` numbers or symbols. Its derivatives
    are the same sum of spins minus ``rate`` and of angular accelerations; its multiplier is a torque ``c * lam``
    on every body of its terms."""

    terms: tuple[tuple[Any, int], ...]
    constant: Any = 0
    rate: Any = 0


# A mechanism's body of a name, by index (-1: the ground), and the model of a joint by its name.
BodyIndex = Callable[[str], int]


class JointKind(ABC):
    """One kind of joint; see the module's docstring for what each member means to the rest of the package."""

    name: str  # the file's ``kind``
    label: str  # the prefix of its parameter names (``pin``, ``slider``, ``gear``)
    model: type[BaseModel]
    meanings: tuple[str, ...]  # its reaction rows' names, in row order
    removed: int  # degrees of freedom it removes (Grübler-Kutzbach)
    fields: tuple[str, ...]  # its entries of the parameter vector
    symbols: tuple[str, ...]  # their symbols' stems in the derivations (joint k's: stem + k), as ``fields``
    drawing: str

    @abstractmethod
    def bodies(self, joint: Any) -> tuple[str, str] | None:
        """The two bodies (or ``"ground"``) it joins: an edge of the mechanism's graph; None for a coupler."""

    @abstractmethod
    def check(self, joint: Any, mechanism: Any) -> None:
        """Its references resolve (ValueError naming the joint and the field otherwise)."""

    @abstractmethod
    def values(self, joint: Any, mechanism: Any) -> list[float]:
        """Its entries of the parameter vector, in the order of ``fields``."""

    def drawn_between(self, joint: Any, mechanism: Any) -> tuple[str, ...]:
        """The ``body.point`` references its drawing joins (a ground point as ``ground.NAME``)."""
        return ()

    def angle_rows(self, bodies: Sequence[int], values: Sequence[Any]) -> list[AngleRow]:
        """Its rows that hold a sum of body angles, from ``bodies`` (see :meth:`structure_bodies`) and its
        parameter ``values`` (symbols or numbers, the order of ``fields``). None for a kind of point rows."""
        return []

    def rows(self, bodies: Sequence[Any], values: Sequence[Any], k: Kinematics) -> list[Row]:
        """Its constraint rows, in the order of ``meanings``, on ``bodies`` (:meth:`structure_bodies`, or the
        formulation's handles of them) with its parameter ``values``. By default its :meth:`angle_rows`."""
        return [angle_row(row, k) for row in self.angle_rows(bodies, values)]

    def damper(self, bodies: Sequence[Any], values: Sequence[Any], k: Kinematics) -> Row | None:
        """The relative motion its viscous damper resists (``velocity``: its speed; ``loads``: per unit of the
        damping force), the damper's coefficient being its ``damping`` field; None for a kind without one. A
        damper applies ``-damping * velocity`` times the loads (a Rayleigh function ``damping velocity^2 / 2``)."""
        return None

    def freedom(self, values: Sequence[Any]) -> Rotation | Translation | None:
        """The tree coordinate it carries when it is a joint of the spanning tree; None for a coupler (a kind
        whose :meth:`bodies` is None is never in the tree)."""
        return None

    def at_pose(self, joint: Any, turn: dict[str, float]) -> Any:
        """The joint redrawn for a sketch in which every body ``name`` has turned by ``turn[name]`` (rad) from
        this one (:func:`physics.mechanism.posed.at_assembled_pose`): whatever it holds in the sketch's frame.
        By default the joint itself (its points move with their bodies)."""
        return joint

    def structure_bodies(self, joint: Any, body: BodyIndex, mechanism: Any) -> tuple[int, ...]:
        """The body indices its equations reach (``a`` then ``b`` for a joint of two bodies)."""
        ends = self.bodies(joint)
        assert ends is not None
        return (body(ends[0]), body(ends[1]))
