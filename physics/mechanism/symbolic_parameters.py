"""The parameter symbols a mechanism's derivations write, one per entry of the parameter vector
(:func:`physics.mechanism.parameters.parameter_vector`, in its order), named by structure (``m0``, ``ax3``).

Apart from :mod:`physics.mechanism.parameters` because only a symbolic derivation needs them: a run from cached
code imports the structure and the numbers alone and never pays for these classes (tests/physics/test_lean_start.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from .joints import KINDS, MOTOR

if TYPE_CHECKING:  # sympy is imported where symbols are made
    import sympy as sp

    from .parameters import Structure


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
    """A joint's parameter symbols, ``values`` in its kind's ``fields`` order. A pin: ``arm_a``, ``arm_b``
    (``direction`` None). A slider: ``arm_a`` the sliding point's arm on its body, ``arm_b`` the through point's
    arm on ``on``, ``direction`` the guide's unit direction in the sketch. A gear: ``ratio`` and ``offset``."""

    values: tuple[sp.Symbol, ...]
    fields: tuple[str, ...]

    def _pair(self, at: int) -> tuple[sp.Symbol, sp.Symbol]:
        return (self.values[at], self.values[at + 1])

    @property
    def arm_a(self) -> tuple[sp.Symbol, sp.Symbol]:
        assert self.fields[0].startswith("arm_"), self.fields
        return self._pair(0)

    @property
    def arm_b(self) -> tuple[sp.Symbol, sp.Symbol]:
        assert self.fields[2].startswith("arm_"), self.fields
        return self._pair(2)

    @property
    def direction(self) -> tuple[sp.Symbol, sp.Symbol] | None:
        return self._pair(self.fields.index("direction.x")) if "direction.x" in self.fields else None

    @property
    def damping(self) -> sp.Symbol:
        return self.values[self.fields.index("damping")]


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
        kind = KINDS[joint.kind]
        joints.append(JointSymbols(tuple(_real(f"{stem}{k}") for stem in kind.symbols), kind.fields))
    drivers = tuple(_real(f"{MOTOR.symbols[d.kind]}{d.joint}") for d in shape.drivers)
    g, t = _real("g"), _real("t")
    vector: list[sp.Symbol] = []
    for body in bodies:
        vector += [body.mass, body.inertia, *body.centre]
    for joint_symbols in joints:
        vector += list(joint_symbols.values)
    vector += [*drivers, g, t]
    return ParameterSymbols(bodies=bodies, joints=tuple(joints), drivers=drivers, g=g, t=t, vector=tuple(vector))
