"""Any planar mechanism: rigid bodies, pins, sliders and motors, described by the user or by a preset.

This package describes a mechanism (:mod:`.model`, :mod:`.files`), checks its topology and counts its degrees
of freedom (:mod:`.topology`), writes its constraint equations in maximal coordinates (:mod:`.constraints`) and
assembles it from a rough sketch (:mod:`.assembly`). The chain and four-bar of the rest of Linkage Lab are its
special cases.
"""

from .assembly import Assembled, assemble
from .constraints import Constraints
from .model import Body, Driver, Mechanism, Prismatic, Revolute
from .presets import MECHANISM_PRESETS
from .topology import Loop, Topology, analyse

__all__ = [
    "Assembled",
    "Body",
    "Constraints",
    "Driver",
    "Loop",
    "MECHANISM_PRESETS",
    "Mechanism",
    "Prismatic",
    "Revolute",
    "Topology",
    "analyse",
    "assemble",
]
