"""A prismatic joint (a slider): a body's point runs along a guide line of another body, the two keeping their
relative angle."""

from __future__ import annotations

import math
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

from .base import GROUND, JointKind, Point, finite_point
from .revolute import arm


class Prismatic(BaseModel):
    """A slider: ``body`` keeps its angle relative to ``on`` and its point ``point`` moves along the line
    through ``on``'s point ``through`` in direction ``direction`` (both in the sketch)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    kind: Literal["prismatic"] = "prismatic"
    name: str = Field(min_length=1, max_length=40)
    body: str = Field(min_length=1)
    point: str = Field(min_length=1, description="the sliding point, a point of body")
    on: str = Field(GROUND, description="the body (or ground) that carries the guide")
    through: str = Field(min_length=1, description="a point of `on` on the guide line")
    direction: Point = Field(description="direction of the guide in the sketch")
    damping: float = Field(0.0, ge=0.0, le=1e4, strict=True, allow_inf_nan=False,
                           description="viscous force per unit sliding speed")

    @field_validator("direction", mode="before")
    @classmethod
    def _direction(cls, value: object) -> Point:
        x, y = finite_point(value, "direction")
        if math.hypot(x, y) < 1e-12:
            raise ValueError("must not be the zero vector")
        return (x, y)


class PrismaticKind(JointKind):
    name = "prismatic"
    label = "slider"
    model = Prismatic
    # the force across the guide on ``body`` at its sliding point, and the torque that keeps the relative angle
    meanings = ("offset across the guide", "relative rotation")
    removed = 2
    fields = ("arm_p.x", "arm_p.y", "arm_t.x", "arm_t.y", "direction.x", "direction.y", "damping")
    symbols = ("px", "py", "tx", "ty", "ux", "uy", "c")
    drawing = "guide"

    def bodies(self, joint: Prismatic) -> tuple[str, str]:
        return joint.body, joint.on

    def check(self, joint: Prismatic, mechanism: Any) -> None:
        mechanism.point_of(f"{joint.body}.{joint.point}", f"joint {joint.name!r}")
        mechanism.point_of(f"{joint.on}.{joint.through}", f"joint {joint.name!r}")
        if joint.body == joint.on:
            raise ValueError(f"joint {joint.name!r}: slides body {joint.body!r} on itself")

    def values(self, joint: Prismatic, mechanism: Any) -> list[float]:
        length = math.hypot(*joint.direction)
        return [*arm(mechanism, f"{joint.body}.{joint.point}", joint.name),
                *arm(mechanism, f"{joint.on}.{joint.through}", joint.name),
                joint.direction[0] / length, joint.direction[1] / length, joint.damping]


KIND = PrismaticKind()
