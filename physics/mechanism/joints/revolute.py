"""A revolute joint (a pin): a point of one body held on a point of another body or of the ground."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from .base import GROUND, JointKind

REFERENCE = r"^[A-Za-z][A-Za-z0-9_-]*\.[A-Za-z0-9_-]+$"


class Revolute(BaseModel):
    """A pin between a point of one body and a point of another body or of the ground (``"ground.O"``)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    kind: Literal["revolute"] = "revolute"
    name: str = Field(min_length=1, max_length=40)
    a: str = Field(pattern=REFERENCE, description="body.point")
    b: str = Field(pattern=REFERENCE, description="body.point")
    damping: float = Field(0.0, ge=0.0, le=1e4, strict=True, allow_inf_nan=False,
                           description="viscous torque per unit relative angular speed")


def arm(mechanism: Any, reference: str, where: str) -> list[float]:
    """``body.point`` from its body's sketch centre of mass (a ground point: its coordinates)."""
    body, _, _ = reference.partition(".")
    x, y = mechanism.point_of(reference, where)
    if body == GROUND:
        return [float(x), float(y)]
    cx, cy = mechanism.body(body).centre
    return [float(x) - cx, float(y) - cy]


class RevoluteKind(JointKind):
    name = "revolute"
    label = "pin"
    model = Revolute
    meanings = ("x gap", "y gap")  # the force ON body a BY body b, x and y
    removed = 2
    fields = ("arm_a.x", "arm_a.y", "arm_b.x", "arm_b.y", "damping")
    symbols = ("ax", "ay", "bx", "by", "c")
    drawing = "pin"

    def bodies(self, joint: Revolute) -> tuple[str, str]:
        return joint.a.split(".")[0], joint.b.split(".")[0]

    def check(self, joint: Revolute, mechanism: Any) -> None:
        for side in (joint.a, joint.b):
            mechanism.point_of(side, f"joint {joint.name!r}")
        if joint.a.split(".")[0] == joint.b.split(".")[0]:
            raise ValueError(f"joint {joint.name!r}: joins body {joint.a.split('.')[0]!r} to itself")

    def values(self, joint: Revolute, mechanism: Any) -> list[float]:
        return [*arm(mechanism, joint.a, joint.name), *arm(mechanism, joint.b, joint.name), joint.damping]


KIND = RevoluteKind()
