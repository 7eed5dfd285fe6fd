"""A planar mechanism as a user writes it: rigid bodies, the joints between them, drivers, gravity.

Geometry is given the way a person sketches a mechanism: every point (joint places, the centre of mass, traced
points) in one drawing's coordinates, metres, at one instant (the *sketch*). Each body's own frame is the
drawing's frame at that instant, so a body's shape is the set of its points and needs no separate description.
A rough sketch is fine: :mod:`physics.mechanism.assembly` moves the bodies (keeping each rigid) until every
joint closes. The chain and the four-bar of the rest of Linkage Lab are special cases of this description.

Every field is validated here, with a message that names the body or joint and the field.
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from .joints import GROUND, Driver, Gear, Joint, Prismatic, Revolute, finite_point, kind_of

MAX_BODIES = 24
MAX_POINTS_PER_BODY = 16
MAX_INERTIA = 1e6  # kg m^2: the largest centroidal inertia a body may have

Point = tuple[float, float]
__all__ = ["GROUND", "Body", "Driver", "Gear", "Mechanism", "Prismatic", "Revolute"]


def _no_drivers() -> list[Driver]:
    """A fresh empty list: pydantic reads a default factory's signature, and ``inspect.signature(list)`` parses
    the builtin's text signature with :mod:`tokenize`, whose first use compiles its large regular expression
    (about 4.5 ms of every process that loads this module, a chain's run on the mechanism engine included)."""
    return []


def _point_table(value: object, table: str, item: str) -> dict[str, Point]:
    """``{name: [x, y]}`` checked point by point; messages name the ``table`` or the ``item`` and its name."""
    if not isinstance(value, dict):
        raise ValueError(f"{table}: expected a table of name = [x, y]")
    return {str(name): finite_point(xy, f"{item} {name!r}") for name, xy in value.items()}


class Body(BaseModel):
    """A rigid body: named points (at least one, at most 16), mass, centre of mass and centroidal inertia."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    name: str = Field(min_length=1, max_length=40, pattern=r"^[A-Za-z][A-Za-z0-9_-]*$")
    points: dict[str, Point] = Field(min_length=1, max_length=MAX_POINTS_PER_BODY)
    mass: float = Field(ge=0.0, le=1e6, strict=True, allow_inf_nan=False, description="kg")
    com: Point | None = Field(None, description="centre of mass in the sketch; default: mean of the points")
    inertia: float = Field(ge=0.0, le=MAX_INERTIA, strict=True, allow_inf_nan=False, description="centroidal moment of inertia, kg m^2")

    @field_validator("points", mode="before")
    @classmethod
    def _points(cls, value: object) -> dict[str, Point]:
        return _point_table(value, "points", "point")

    @field_validator("com", mode="before")
    @classmethod
    def _com(cls, value: object) -> Point | None:
        return None if value is None else finite_point(value, "com")

    @field_validator("name")
    @classmethod
    def _not_ground(cls, value: str) -> str:
        if value == GROUND:
            raise ValueError(f"name {GROUND!r} is reserved for the fixed frame")
        return value

    @property
    def centre(self) -> Point:
        if self.com is not None:
            return self.com
        xs, ys = zip(*self.points.values())
        return (sum(xs) / len(xs), sum(ys) / len(ys))


class Mechanism(BaseModel):
    """Bodies, joints and drivers, with gravity ``g`` along -y and named ground points."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    name: str = Field("mechanism", max_length=80)
    description: str = Field("", max_length=4000)
    g: float = Field(9.81, ge=0.0, le=1e3, strict=True, allow_inf_nan=False, description="gravity, m/s^2, along -y")
    ground: dict[str, Point] = Field(default_factory=dict, description="fixed points, name = [x, y]")
    bodies: list[Body] = Field(min_length=1, max_length=MAX_BODIES)
    joints: list[Joint] = Field(min_length=1, max_length=4 * MAX_BODIES)
    drivers: list[Driver] = Field(default_factory=_no_drivers)
    trace: str | None = Field(None, description="body.point whose path is traced")

    @field_validator("ground", mode="before")
    @classmethod
    def _ground(cls, value: object) -> dict[str, Point]:
        return _point_table(value, "ground", "ground point")

    @model_validator(mode="after")
    def _references(self) -> Mechanism:
        names = [body.name for body in self.bodies]
        duplicate = next((name for name in names if names.count(name) > 1), None)
        if duplicate is not None:
            raise ValueError(f"body {duplicate!r}: two bodies have this name")
        joint_names = [joint.name for joint in self.joints]
        duplicate = next((name for name in joint_names if joint_names.count(name) > 1), None)
        if duplicate is not None:
            raise ValueError(f"joint {duplicate!r}: two joints have this name")
        for joint in self.joints:
            kind_of(joint).check(joint, self)
        by_name = {joint.name: joint for joint in self.joints}
        for driver in self.drivers:
            driven = by_name.get(driver.joint)
            if driven is None:
                raise ValueError(f"driver: no joint named {driver.joint!r} (joints: {', '.join(by_name)})")
            if driven.kind != "revolute":
                raise ValueError(f"driver on {driver.joint!r}: motors drive revolute joints only")
        if len({driver.joint for driver in self.drivers}) != len(self.drivers):
            raise ValueError("drivers: a joint has two drivers")
        if self.trace is not None:
            self.point_of(self.trace, "trace")
        return self

    def body(self, name: str) -> Body:
        for body in self.bodies:
            if body.name == name:
                return body
        raise KeyError(name)

    def point_of(self, reference: str, where: str) -> Point:
        """The sketch position of ``"body.point"`` (or ``"ground.point"``); a clear error if it does not exist."""
        body_name, _, point = reference.partition(".")
        if body_name == GROUND:
            if point not in self.ground:
                known = ", ".join(self.ground) or "none"
                raise ValueError(f"{where}: no ground point {point!r} (ground points: {known})")
            return self.ground[point]
        names = [body.name for body in self.bodies]
        if body_name not in names:
            raise ValueError(f"{where}: no body {body_name!r} (bodies: {', '.join(names)})")
        body = self.body(body_name)
        if point not in body.points:
            raise ValueError(f"{where}: body {body_name!r} has no point {point!r} (points: {', '.join(body.points)})")
        return body.points[point]
