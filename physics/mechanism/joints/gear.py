"""A gear pair: the relative rotations of two revolute joints coupled, as Drake's coupler constraint,

    angle(joint 2) = ratio * angle(joint 1) + offset

each joint's angle its body ``b``'s rotation relative to its body ``a`` from the sketch (so ``offset = 0`` holds in
the sketch). One constraint row; its multiplier is the contact torque: on joint 2's body ``b`` (minus on its
``a``), and ``-ratio`` times it on joint 1's body ``b`` (plus on its ``a``). The two torques do no work together:
``lambda (w_2 - ratio w_1) = 0`` on every motion the gear allows. The gear joins no bodies (it adds no edge to the
mechanism's graph) and removes one degree of freedom. Ratio and offset are parameters, never literals in the code.
"""

from __future__ import annotations

import math
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

from .base import GROUND, AngleRow, JointKind

MAX_RATIO = 1e3
MAX_OFFSET = 1e3  # rad


class Gear(BaseModel):
    """Two revolute joints geared: ``joints = [first, second]``, the second's angle ``ratio`` times the first's
    plus ``offset`` (rad)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    kind: Literal["gear"]
    name: str = Field(min_length=1, max_length=40)
    joints: tuple[str, str] = Field(description="the two revolute joints geared: [first, second]")
    ratio: float = Field(ge=-MAX_RATIO, le=MAX_RATIO, strict=True, allow_inf_nan=False,
                         description="the second joint's angle per unit of the first's")
    offset: float = Field(0.0, ge=-MAX_OFFSET, le=MAX_OFFSET, strict=True, allow_inf_nan=False, description="rad")

    @field_validator("ratio")
    @classmethod
    def _nonzero(cls, value: float) -> float:
        if not math.isfinite(value) or value == 0.0:
            raise ValueError(f"must not be {value:g}: allowed -{MAX_RATIO:g} <= ratio <= {MAX_RATIO:g}, ratio != 0 "
                             "(a zero ratio would lock the second joint)")
        return value


class GearKind(JointKind):
    name = "gear"
    label = "gear"
    model = Gear
    meanings = ("contact torque",)
    removed = 1
    fields = ("ratio", "offset")
    symbols = ("ratio", "offset")
    drawing = "mesh"  # a line between its two pins (app/mechanism_scene.py)

    def bodies(self, joint: Gear) -> None:
        return None

    def check(self, joint: Gear, mechanism: Any) -> None:
        first, second = joint.joints
        if first == second:
            raise ValueError(f"joint {joint.name!r}: joints: gears joint {first!r} to itself")
        by_name = {other.name: other for other in mechanism.joints}
        for name in (first, second):
            other = by_name.get(name)
            if other is None:
                raise ValueError(f"joint {joint.name!r}: joints: no joint named {name!r} (joints: {', '.join(by_name)})")
            if other.kind != "revolute":
                raise ValueError(f"joint {joint.name!r}: joints: {name!r} is a {other.kind} joint; a gear couples "
                                 "two revolute joints")

    def values(self, joint: Gear, mechanism: Any) -> list[float]:
        return [joint.ratio, joint.offset]

    def structure_bodies(self, joint: Gear, body, mechanism: Any) -> tuple[int, ...]:
        """``(a1, b1, a2, b2)``: the bodies of its two joints."""
        by_name = {other.name: other for other in mechanism.joints}
        out: list[int] = []
        for name in joint.joints:
            pin = by_name[name]
            out += [body(pin.a.split(".")[0]), body(pin.b.split(".")[0])]
        return tuple(out)

    def drawn_between(self, joint: Gear, mechanism: Any) -> tuple[str, ...]:
        """A line between its two pins, each at its moving body's point (a pin's ``b`` side unless that is the
        ground)."""
        by_name = {other.name: other for other in mechanism.joints}
        ends = []
        for name in joint.joints:
            pin = by_name[name]
            ends.append(pin.b if pin.b.split(".")[0] != GROUND else pin.a)
        return tuple(ends)

    def at_pose(self, joint: Gear, turn: dict[str, float]) -> Gear:
        """It holds at the new pose, where every relative angle is now zero: offset zero."""
        return joint.model_copy(update={"offset": 0.0})

    def angle_rows(self, bodies, values) -> list[AngleRow]:
        a1, b1, a2, b2 = bodies
        ratio, offset = values
        return [AngleRow(((1, b2), (-1, a2), (-ratio, b1), (ratio, a1)), offset, 0)]


KIND = GearKind()
