"""One entry to a mechanism's three symbolic formulations, derived once per structure.

``derive_system(mechanism, method)`` returns the :class:`~physics.derive.formulation.LinearSystem` of ``method``
(``"dae"``, ``"lagrange"`` or ``"newton_euler"``) written in the structure's symbols: coordinates, rates and the
parameter vector of :mod:`physics.mechanism.parameters`. Every number is a parameter, so the derivation is cached
by structure (:func:`~physics.mechanism.parameters.structure_key`) and method: editing a mass, a point, a speed,
a damper or g derives nothing. Only the equations' readable names are the mechanism's own (its bodies and joints).
"""

from __future__ import annotations

import dataclasses
import functools

from ..derive.formulation import LinearSystem
from .description import Mechanism
from .parameters import ROTATIONS, Structure, structure
from .symbolic_parameters import parameter_symbols

METHODS = ("dae", "lagrange", "newton_euler")


def derive_system(mechanism: Mechanism, method: str, rotations: str = "relative") -> LinearSystem:
    """``method``'s linear system for ``mechanism``'s structure, with its equations named after its parts;
    ``rotations`` (a tree formulation's: :data:`~physics.mechanism.parameters.ROTATIONS`) what a pin's
    coordinate is."""
    if method not in METHODS:
        raise ValueError(f"method = {method!r}: allowed {', '.join(METHODS)}")
    system = derive_structure(structure(mechanism), method, rotations)
    names = {f"b{k}": body.name for k, body in enumerate(mechanism.bodies)}
    names.update({f"j{k}": joint.name for k, joint in enumerate(mechanism.joints)})
    return dataclasses.replace(system, equation_names=[name.format(**names) for name in system.equation_names])


@functools.lru_cache(maxsize=64)
def derive_structure(shape: Structure, method: str, rotations: str = "relative") -> LinearSystem:
    """The derivation itself, once per (structure, method, rotations) in a process; names keep ``{bK}``/``{jK}``
    fields (callers pass all three arguments, so one entry serves each). ``rotations`` is a tree formulation's (what a pin's coordinate is, :mod:`.symbolic_tree`); the DAE
    integrates every body's own rotation whatever it says, so it derives one system for both."""
    if rotations not in ROTATIONS:
        raise ValueError(f"rotations = {rotations!r}: allowed values {', '.join(ROTATIONS)}")
    if method == "dae" and rotations != "relative":
        return derive_structure(shape, method, "relative")
    params = parameter_symbols(shape)
    if method == "dae":
        from .symbolic_dae import derive_dae  # noqa: PLC0415  (each formulation's module only when asked for)

        system = derive_dae(shape, params)
    elif method == "lagrange":
        from .symbolic_lagrange import derive_lagrange  # noqa: PLC0415

        system = derive_lagrange(shape, params, rotations)
    else:
        from .symbolic_newton_euler import derive_newton_euler  # noqa: PLC0415

        system = derive_newton_euler(shape, params, rotations)
    # Only masses and inertias are known not to vanish (a body must have mass to run); a point, a centre of
    # mass or a guide's direction component is zero in many valid mechanisms, so no pivot may rely on one.
    positive = {symbol for body in params.bodies for symbol in (body.mass, body.inertia)}
    return dataclasses.replace(system, vanishing_parameters=frozenset(set(params.vector) - positive))
