"""A mechanism split into its structure (what is compiled) and its numbers (a parameter vector passed at run time).

The structure is what the equations' *form* depends on: how many bodies, each joint's kind and the bodies it
joins (by index, the ground as -1), which body carries a slider's guide, each driver's kind (speed or torque) and
joint. Everything else is a number in :func:`parameter_vector`, in the order of :func:`parameter_names`:

* per body: ``mass``, ``inertia``, ``centre.x``, ``centre.y`` (its sketch centre of mass: the tree coordinates'
  zero reference and the origin of its arms);
* per pin: ``arm_a.x/y`` and ``arm_b.x/y`` (its point on each body, from that body's sketch centre of mass; a
  ground point as its coordinates), ``damping``;
* per slider: ``arm_p.x/y`` (the sliding point on ``body``), ``arm_t.x/y`` (the guide's through point on ``on``),
  ``direction.x/y`` (the guide's *unit* direction in the sketch), ``damping``;
* per gear: ``ratio`` and ``offset``;
* per driver: ``speed`` (rad/s) or ``torque`` (N m);
* ``g`` and ``t`` (the time, :data:`TIME`, a slot the integrator writes: speed motors turn with it).

Damping is always a number (zero allowed), never structure: switching a damper on compiles nothing. The symbols
the derivations write (:mod:`physics.mechanism.symbolic_parameters`, imported only by a derivation) are named by
structure (``m0``, ``ax3``), never by the names of bodies or joints, so two mechanisms of one structure share one
derivation (:func:`structure_key`).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import Literal

import numpy as np

from .description import GROUND, Mechanism
from .joints import MOTOR, kind_of

TIME = "t"
GRAVITY = "g"

# What a pin's tree coordinate is, chosen when a tree formulation is compiled and run (never written in a
# mechanism's file: the same mechanism is the same machine either way, only the integrated state differs):
# "relative", the child's rotation relative to its parent (the default: every mechanism run so far, its bits and
# its cached code); "absolute", the child body's own rotation from the sketch. A chain sketched hanging straight
# down (theta_sketch = 0) then integrates exactly the chain engine's state, its absolute angles theta from the
# downward vertical, so a chain run as a mechanism differs from the chain engine's run by rounding, not by the
# integrator's tolerance (physics/mechanism/chains.py). Part of the generated code's key
# (physics.mechanism.engine.compiled_system), as the structure is: relative and absolute never share generated code.
ROTATIONS = ("relative", "absolute")


@dataclass(frozen=True)
class JointShape:
    """A joint's kind and the bodies its equations reach, by index (-1: the ground): a pin's ``a`` and ``b``
    sides in the description's order; a slider's ``a`` is its ``body`` (the sliding point's), ``b`` its ``on``
    (the guide's carrier); a gear's ``reach`` the bodies of its two joints, ``(a1, b1, a2, b2)``, and its ``a``,
    ``b`` those of its first joint. ``joins``: the joint is an edge of the mechanism's graph (a gear is not)."""

    kind: str
    a: int
    b: int
    reach: tuple[int, ...] = ()
    joins: bool = True

    @property
    def bodies(self) -> tuple[int, ...]:
        return self.reach or (self.a, self.b)


@dataclass(frozen=True)
class DriverShape:
    kind: Literal["speed", "torque"]
    joint: int


@dataclass(frozen=True)
class Structure:
    """Everything the equations' form depends on, hashable: the key of one derivation per structure."""

    bodies: int
    joints: tuple[JointShape, ...]
    drivers: tuple[DriverShape, ...]

    @property
    def speed_driven(self) -> dict[int, int]:
        """Driver number of every speed-driven joint, by joint index."""
        return {d.joint: k for k, d in enumerate(self.drivers) if d.kind == "speed"}


def structure(mechanism: Mechanism) -> Structure:
    index = {body.name: k for k, body in enumerate(mechanism.bodies)}

    def body(name: str) -> int:
        return -1 if name == GROUND else index[name]

    joints = []
    for joint in mechanism.joints:
        kind = kind_of(joint)
        reach = kind.structure_bodies(joint, body, mechanism)
        joins = kind.bodies(joint) is not None
        joints.append(JointShape(joint.kind, reach[0], reach[1], () if joins else reach, joins))
    joint_index = {joint.name: k for k, joint in enumerate(mechanism.joints)}
    drivers = tuple(DriverShape(MOTOR.kind(d), joint_index[d.joint]) for d in mechanism.drivers)  # type: ignore[arg-type]
    return Structure(bodies=len(mechanism.bodies), joints=tuple(joints), drivers=drivers)


def structure_key(mechanism: Mechanism) -> str:
    """A short digest of the topology and the joint kinds only (no names, numbers, damping or g)."""
    shape = structure(mechanism)
    text = ";".join([f"B{shape.bodies}",
                     *(f"{j.kind}{','.join(map(str, j.bodies))}" for j in shape.joints),
                     *(f"{d.kind[0]}@{d.joint}" for d in shape.drivers)])
    return hashlib.sha256(text.encode()).hexdigest()[:16]


# ----------------------------------------------------------------------------------------- names and numbers

def parameter_names(mechanism: Mechanism) -> tuple[str, ...]:
    """Readable names of the parameter vector's entries, e.g. ``"crank.mass"``, ``"pin A.arm_a.x"``, ``"g"``."""
    names: list[str] = []
    for body in mechanism.bodies:
        names += [f"{body.name}.{field}" for field in ("mass", "inertia", "centre.x", "centre.y")]
    for joint in mechanism.joints:
        kind = kind_of(joint)
        names += [f"{kind.label} {joint.name}.{field}" for field in kind.fields]
    for driver in mechanism.drivers:
        names.append(f"{MOTOR.label} {driver.joint}.{MOTOR.kind(driver)}")
    return (*names, GRAVITY, TIME)


def parameter_vector(mechanism: Mechanism, t: float = 0.0) -> np.ndarray:
    """Every number the equations use, float64, in :func:`parameter_names`' order (``t`` set to ``t``)."""
    values: list[float] = []
    for body in mechanism.bodies:
        values += [body.mass, body.inertia, *map(float, body.centre)]
    for joint in mechanism.joints:
        values += kind_of(joint).values(joint, mechanism)
    values += [MOTOR.value(driver) for driver in mechanism.drivers]
    values += [mechanism.g, t]
    return np.array(values, dtype=np.float64)
