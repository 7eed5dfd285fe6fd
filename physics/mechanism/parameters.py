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
* per driver: ``speed`` (rad/s) or ``torque`` (N m);
* ``g`` and ``t`` (the time, :data:`TIME`, a slot the integrator writes: speed motors turn with it).

Damping is always a number (zero allowed), never structure: switching a damper on compiles nothing. The symbols
the derivations write (:class:`ParameterSymbols`) are named by structure (``m0``, ``ax3``), never by the names
of bodies or joints, so two mechanisms of one structure share one derivation (:func:`structure_key`).
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np

from .model import GROUND, Mechanism, Revolute

if TYPE_CHECKING:  # sympy is imported where symbols are made: a run from cached code never needs it
    import sympy as sp

TIME = "t"
GRAVITY = "g"


@dataclass(frozen=True)
class JointShape:
    """A joint's kind and bodies by index (-1: the ground): a pin's ``a`` and ``b`` sides in the description's
    order; a slider's ``a`` is its ``body`` (the sliding point's), ``b`` its ``on`` (the guide's carrier)."""

    kind: Literal["revolute", "prismatic"]
    a: int
    b: int


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
        if isinstance(joint, Revolute):
            joints.append(JointShape("revolute", body(joint.a.split(".")[0]), body(joint.b.split(".")[0])))
        else:
            joints.append(JointShape("prismatic", body(joint.body), body(joint.on)))
    joint_index = {joint.name: k for k, joint in enumerate(mechanism.joints)}
    drivers = tuple(DriverShape("speed" if d.speed is not None else "torque", joint_index[d.joint])
                    for d in mechanism.drivers)
    return Structure(bodies=len(mechanism.bodies), joints=tuple(joints), drivers=drivers)


def structure_key(mechanism: Mechanism) -> str:
    """A short digest of the topology and the joint kinds only (no names, numbers, damping or g)."""
    shape = structure(mechanism)
    text = ";".join([f"B{shape.bodies}",
                     *(f"{j.kind[0]}{j.a},{j.b}" for j in shape.joints),
                     *(f"{d.kind[0]}@{d.joint}" for d in shape.drivers)])
    return hashlib.sha256(text.encode()).hexdigest()[:16]


# ----------------------------------------------------------------------------------------------- the symbols

def _real(name: str) -> sp.Symbol:
    import sympy  # noqa: PLC0415  (sympy boundary: only a derivation makes symbols)

    return sympy.Symbol(name, real=True)


@dataclass(frozen=True)
class BodySymbols:
    mass: sp.Symbol
    inertia: sp.Symbol
    centre: tuple[sp.Symbol, sp.Symbol]


@dataclass(frozen=True)
class JointSymbols:
    """A pin: ``arm_a``, ``arm_b`` (``direction`` None). A slider: ``arm_a`` the sliding point's arm on its body,
    ``arm_b`` the through point's arm on ``on``, ``direction`` the guide's unit direction in the sketch."""

    arm_a: tuple[sp.Symbol, sp.Symbol]
    arm_b: tuple[sp.Symbol, sp.Symbol]
    direction: tuple[sp.Symbol, sp.Symbol] | None
    damping: sp.Symbol


@dataclass(frozen=True)
class ParameterSymbols:
    """The parameter symbols of one structure, and ``vector`` of them in :func:`parameter_vector`'s order."""

    bodies: tuple[BodySymbols, ...]
    joints: tuple[JointSymbols, ...]
    drivers: tuple[sp.Symbol, ...]  # a speed (rad/s) or a torque (N m), by driver
    g: sp.Symbol
    t: sp.Symbol
    vector: tuple[sp.Symbol, ...]

    def driver_of(self, shape: Structure, joint: int, kind: str) -> sp.Symbol | None:
        for k, driver in enumerate(shape.drivers):
            if driver.joint == joint and driver.kind == kind:
                return self.drivers[k]
        return None


def parameter_symbols(shape: Structure) -> ParameterSymbols:
    bodies = tuple(BodySymbols(_real(f"m{k}"), _real(f"I{k}"), (_real(f"cx{k}"), _real(f"cy{k}")))
                   for k in range(shape.bodies))
    joints = []
    for k, joint in enumerate(shape.joints):
        if joint.kind == "revolute":
            joints.append(JointSymbols((_real(f"ax{k}"), _real(f"ay{k}")), (_real(f"bx{k}"), _real(f"by{k}")), None,
                                       _real(f"c{k}")))
        else:
            joints.append(JointSymbols((_real(f"px{k}"), _real(f"py{k}")), (_real(f"tx{k}"), _real(f"ty{k}")),
                                       (_real(f"ux{k}"), _real(f"uy{k}")), _real(f"c{k}")))
    drivers = tuple(_real(f"{'w' if d.kind == 'speed' else 'tau'}{d.joint}") for d in shape.drivers)
    g, t = _real("g"), _real("t")
    vector: list[sp.Symbol] = []
    for body in bodies:
        vector += [body.mass, body.inertia, *body.centre]
    for joint_symbols in joints:
        vector += [*joint_symbols.arm_a, *joint_symbols.arm_b]
        if joint_symbols.direction is not None:
            vector += list(joint_symbols.direction)
        vector.append(joint_symbols.damping)
    vector += [*drivers, g, t]
    return ParameterSymbols(bodies=bodies, joints=tuple(joints), drivers=drivers, g=g, t=t, vector=tuple(vector))


# ----------------------------------------------------------------------------------------- names and numbers

def parameter_names(mechanism: Mechanism) -> tuple[str, ...]:
    """Readable names of the parameter vector's entries, e.g. ``"crank.mass"``, ``"pin A.arm_a.x"``, ``"g"``."""
    names: list[str] = []
    for body in mechanism.bodies:
        names += [f"{body.name}.{field}" for field in ("mass", "inertia", "centre.x", "centre.y")]
    for joint in mechanism.joints:
        fields: tuple[str, ...]
        if isinstance(joint, Revolute):
            fields = ("arm_a.x", "arm_a.y", "arm_b.x", "arm_b.y", "damping")
            names += [f"pin {joint.name}.{field}" for field in fields]
        else:
            fields = ("arm_p.x", "arm_p.y", "arm_t.x", "arm_t.y", "direction.x", "direction.y", "damping")
            names += [f"slider {joint.name}.{field}" for field in fields]
    for driver in mechanism.drivers:
        names.append(f"motor {driver.joint}.{'speed' if driver.speed is not None else 'torque'}")
    return (*names, GRAVITY, TIME)


def parameter_vector(mechanism: Mechanism, t: float = 0.0) -> np.ndarray:
    """Every number the equations use, float64, in :func:`parameter_names`' order (``t`` set to ``t``)."""
    centres = {body.name: body.centre for body in mechanism.bodies}

    def arm(body: str, sketch_xy) -> list[float]:
        if body == GROUND:
            return [float(sketch_xy[0]), float(sketch_xy[1])]
        return [float(sketch_xy[0]) - centres[body][0], float(sketch_xy[1]) - centres[body][1]]

    values: list[float] = []
    for body in mechanism.bodies:
        values += [body.mass, body.inertia, *map(float, body.centre)]
    for joint in mechanism.joints:
        if isinstance(joint, Revolute):
            for side in (joint.a, joint.b):
                values += arm(side.split(".")[0], mechanism.point_of(side, joint.name))
        else:
            values += arm(joint.body, mechanism.point_of(f"{joint.body}.{joint.point}", joint.name))
            values += arm(joint.on, mechanism.point_of(f"{joint.on}.{joint.through}", joint.name))
            length = math.hypot(*joint.direction)
            values += [joint.direction[0] / length, joint.direction[1] / length]
        values.append(joint.damping)
    for driver in mechanism.drivers:
        value = driver.speed if driver.speed is not None else driver.torque
        assert value is not None  # the model gives every driver exactly one of them
        values.append(value)
    values += [mechanism.g, t]
    return np.array(values, dtype=np.float64)
