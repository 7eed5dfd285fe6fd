"""A revolute joint (a pin): a point of one body held on a point of another body or of the ground."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from .base import GROUND, Force, JointKind, Kinematics, Rotation, Row, Torque

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


    def rows(self, bodies, values, k: Kinematics) -> list[Row]:
        """The gap between its two points, x and y: the two points move together. The multiplier is the force ON
        body ``a`` BY body ``b`` at the pin (``b`` feels the opposite)."""
        a, b = bodies
        (p_a, v_a, a_a), (p_b, v_b, a_b) = k.point(a, (values[0], values[1])), k.point(b, (values[2], values[3]))
        gap, gap_rate, gap_acceleration = k.sub(p_a, p_b), k.sub(v_a, v_b), k.sub(a_a, a_b)
        units = ((1, 0), (0, 1))
        return [Row(gap[axis], gap_rate[axis], gap_acceleration[axis],
                    (Force(a, units[axis], p_a), Force(b, k.scale(-1, units[axis]), p_b))) for axis in (0, 1)]

    @staticmethod
    def rows_at_pose(cos, sin, x, y, arm_x, arm_y, sign) -> tuple[tuple[Any, Any], tuple[Any, Any, Any, Any]]:
        """Every pin's two rows at one pose, batched over pins, in numbers: arrays over the pins' ends (every
        pin's ``a``, then every pin's ``b``) of their bodies' ``cos``, ``sin`` and centre ``x``, ``y``, the arms
        ``arm_x``, ``arm_y`` and ``sign`` (+1 on ``a``, -1 on ``b``). Returns the gaps ``(x, y)`` by pin, and each
        end's entries of the rows' gradient: the x row's in the end's x column (``sign``), the y row's in its y
        column (``sign``), then the x and y rows' in its angle column (``-sign rho_y``, ``sign rho_x``, ``rho``
        the turned arm). The numbers :meth:`rows` gives through numeric kinematics, bit for bit (the arm turned,
        the centre added, the gap ``p_a + -p_b``; the gradient its velocity forms at unit rates):
        :class:`physics.mechanism.pin_rows.PinRows` lays them into ``Phi`` and ``Phi_q`` for a run's assembly."""
        pins = len(sign) // 2
        rho_x, rho_y = cos * arm_x - sin * arm_y, sin * arm_x + cos * arm_y
        point_x, point_y = x + rho_x, y + rho_y
        gaps = (point_x[:pins] + -point_x[pins:], point_y[:pins] + -point_y[pins:])
        return gaps, (sign, sign, -(sign * rho_y), sign * rho_x)

    def damper(self, bodies, values, k: Kinematics) -> Row:
        """Its relative rotation: a damping torque on ``b`` against ``b``'s spin relative to ``a`` (the opposite
        on ``a``)."""
        return relative_rotation(bodies, k)

    def freedom(self, values) -> Rotation:
        return Rotation((values[0], values[1]), (values[2], values[3]))


def relative_rotation(bodies, k: Kinematics) -> Row:
    """Body ``b``'s rotation relative to body ``a`` of a pin ``(a, b)``, with a unit torque on ``b`` (minus on
    ``a``): what a pin's damper and a motor act on."""
    a, b = bodies
    return Row(k.plus(k.angle(b), k.negative(k.angle(a))), k.plus(k.spin(b), k.negative(k.spin(a))),
               k.plus(k.alpha(b), k.negative(k.alpha(a))), (Torque(b, 1), Torque(a, -1)))


KIND = RevoluteKind()
