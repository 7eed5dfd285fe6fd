"""A prismatic joint (a slider): a body's point runs along a guide line of another body, the two keeping their
relative angle."""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator

from .base import GROUND, Force, JointKind, Kinematics, Point, Row, Torque, Translation, finite_point
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


    def at_pose(self, joint: Prismatic, turn: dict[str, float]) -> Prismatic:
        """Its guide's direction turned with the body that carries it."""
        if joint.on not in turn:
            return joint
        c, s = np.cos(turn[joint.on]), np.sin(turn[joint.on])  # as numpy turns the bodies' points
        dx, dy = joint.direction
        return joint.model_copy(update={"direction": (float(c * dx - s * dy), float(s * dx + c * dy))})

    def rows(self, bodies, values, k: Kinematics) -> list[Row]:
        """Its sliding point's offset across the guide, ``n . (p - t)`` with ``n = R(phi_on) perp(u)`` turning
        with the guide (``n' = w perp(n)``, ``n'' = alpha perp(n) - w^2 n``), its multiplier the force across the
        guide on ``body`` at the sliding point (the opposite on ``on``); and the relative rotation, its multiplier
        the torque on ``body`` (the opposite on ``on``)."""
        a, b = bodies
        normal = k.turned(b, k.perp((values[4], values[5])))
        return [_along_guide(normal, bodies, values, k),
                Row(k.plus(k.angle(a), k.negative(k.angle(b))), k.plus(k.spin(a), k.negative(k.spin(b))),
                    k.plus(k.alpha(a), k.negative(k.alpha(b))), (Torque(a, 1), Torque(b, -1)))]

    def damper(self, bodies, values, k: Kinematics) -> Row:
        """Its sliding: the travel of the sliding point along the turning guide; a damping force along the guide
        on ``body`` at the sliding point, the opposite on ``on``."""
        return _along_guide(k.turned(bodies[1], (values[4], values[5])), bodies, values, k)

    def freedom(self, values) -> Translation:
        return Translation((values[0], values[1]), (values[2], values[3]), (values[4], values[5]))


def _along_guide(axis, bodies, values, k: Kinematics) -> Row:
    """``axis . (p - t)``, ``axis`` a direction fixed in the guide's body ``on`` (turned with it), ``p`` the
    sliding point and ``t`` the through point, with its derivatives and a unit force along ``axis`` on ``body`` at
    the sliding point (the opposite on ``on``)."""
    a, b = bodies
    (p_a, v_a, a_a), (p_b, v_b, a_b) = k.point(a, (values[0], values[1])), k.point(b, (values[2], values[3]))
    gap, gap_rate, gap_acceleration = k.sub(p_a, p_b), k.sub(v_a, v_b), k.sub(a_a, a_b)
    spin, alpha = k.spin(b), k.alpha(b)
    swing = k.dot(k.perp(axis), gap)
    return Row(
        k.dot(axis, gap),
        k.plus(k.times(spin, swing), k.dot(axis, gap_rate)),
        k.plus(k.times(alpha, swing), k.negative(k.times(spin, spin, k.dot(axis, gap))),
               k.times(2, spin, k.dot(k.perp(axis), gap_rate)), k.dot(axis, gap_acceleration)),
        (Force(a, axis, p_a), Force(b, k.scale(-1, axis), p_a)),
    )


KIND = PrismaticKind()
