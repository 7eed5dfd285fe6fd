"""A motor on a revolute joint: a constant relative angular speed (one constraint row) or a constant torque
(a generalised force, no row). Body ``b`` of the joint turns relative to body ``a``."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field, model_validator

from .base import AngleRow, Kinematics, Row, angle_row
from .revolute import relative_rotation


class Driver(BaseModel):
    """A motor on a revolute joint: constant relative angular speed (rad/s), or a constant torque (N m)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    joint: str = Field(min_length=1)
    speed: float | None = Field(None, ge=-1e3, le=1e3, strict=True, allow_inf_nan=False, description="rad/s")
    torque: float | None = Field(None, ge=-1e6, le=1e6, strict=True, allow_inf_nan=False, description="N m")

    @model_validator(mode="after")
    def _one_kind(self) -> Driver:
        if (self.speed is None) == (self.torque is None):
            raise ValueError(f"driver on {self.joint!r}: give exactly one of speed (rad/s) or torque (N m)")
        return self


class Motor:
    """The motor's part of the interface: a speed motor's row and its meaning, the degrees of freedom it fixes."""

    label = "motor"
    meanings = ("driven angle",)  # a speed motor's torque on body b (minus on a)
    symbols = {"speed": "w", "torque": "tau"}  # its parameter's symbol stem by kind, the joint's number appended

    @staticmethod
    def kind(driver: Driver) -> str:
        return "speed" if driver.speed is not None else "torque"

    @staticmethod
    def removed(driver: Driver) -> int:
        return 1 if driver.speed is not None else 0

    @staticmethod
    def value(driver: Driver) -> float:
        value = driver.speed if driver.speed is not None else driver.torque
        assert value is not None  # the model gives every driver exactly one of them
        return float(value)

    @staticmethod
    def angle_rows(bodies, speed: Any) -> list[AngleRow]:
        """A speed motor's row ``phi_b - phi_a - speed t = 0`` on its joint's bodies ``(a, b)``."""
        return [AngleRow(((1, bodies[1]), (-1, bodies[0])), 0, speed)]


    @staticmethod
    def rows(bodies, speed: Any, k: Kinematics) -> list[Row]:
        """A speed motor's rows in a formulation's numbers; its multiplier the torque on ``b`` (minus on ``a``)."""
        return [angle_row(row, k) for row in Motor.angle_rows(bodies, speed)]

    @staticmethod
    def driven(bodies, k: Kinematics) -> Row:
        """What a torque motor acts on: its joint's relative rotation, the torque on ``b`` (minus on ``a``)."""
        return relative_rotation(bodies, k)


MOTOR = Motor()
