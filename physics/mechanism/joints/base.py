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
* how it is drawn: ``drawing``, a word the app's scene reads (``"pin"``, ``"guide"``, ``"mesh"``).

A pin's rows (the gap between its two points) and a slider's (its offset across the turning guide and its relative
rotation), with the tree coordinate each carries, are written by each formulation with its own rigid-body
kinematics (docs/mechanisms.md, "The joint interface").
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

    def structure_bodies(self, joint: Any, body: BodyIndex, mechanism: Any) -> tuple[int, ...]:
        """The body indices its equations reach (``a`` then ``b`` for a joint of two bodies)."""
        ends = self.bodies(joint)
        assert ends is not None
        return (body(ends[0]), body(ends[1]))
