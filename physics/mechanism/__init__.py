"""Any planar mechanism: rigid bodies, pins, sliders, gear pairs and motors, described by the user or by a preset.

This package describes a mechanism (:mod:`.model`, :mod:`.files`), checks its topology and counts its degrees
of freedom (:mod:`.topology`), writes its constraint equations in maximal coordinates (:mod:`.constraints`) and
assembles it from a rough sketch (:mod:`.assembly`). The chain and four-bar of the rest of Linkage Lab are its
special cases. Each joint kind is one module of :mod:`.joints` behind one interface (docs/mechanisms.md, "The
joint interface").
"""

from .assembly import Assembled, assemble
from .constraints import Constraints
from .description import Body, Driver, Gear, Mechanism, Prismatic, Revolute
from .presets import MECHANISM_PRESETS
from .topology import Loop, Topology, analyse

__all__ = [
    "Assembled",
    "Body",
    "Constraints",
    "Driver",
    "Gear",
    "Loop",
    "MECHANISM_PRESETS",
    "Mechanism",
    "Prismatic",
    "Revolute",
    "Topology",
    "analyse",
    "assemble",
]


def derived_system(mechanism: Mechanism, method: str, rotations: str = "relative"):
    """``method``'s (``dae``, ``lagrange``, ``newton_euler``) symbolic system of ``mechanism``: the linear
    equations ``A x = b`` its runs integrate, in the structure's symbols (``q``, ``qd``, ``qdd`` per body's x, y,
    phi; the parameter vector), with rows named after its bodies and joints; ``rotations``: a tree formulation's
    pin coordinates (:data:`physics.mechanism.parameters.ROTATIONS`). sympy loads only when called (the
    app's Equations folder)."""
    from .symbolic import derive_system  # noqa: PLC0415 - sympy: only when asked for

    return derive_system(mechanism, method, rotations)


def structure_key(mechanism: Mechanism) -> str:
    """What compiled code of ``mechanism`` is keyed by: a short digest of its topology and joint kinds, never its
    numbers (masses, sizes, motor speeds, g are the compiled code's parameters). Two mechanisms with the same
    key run on the same compiled code (the app compiles once per key, docs/architecture.md)."""
    from .parameters import structure_key as key  # noqa: PLC0415 - the structure's pieces load only when asked for

    return key(mechanism)
