"""Joint kinds, one module each behind :class:`~.base.JointKind`; this registry is the one list of them.

Adding a kind: write its module (its pydantic model with a ``kind`` tag and a :class:`~.base.JointKind`), add it
to :data:`KINDS` and to :data:`Joint` below, and document its file fields in docs/mechanisms.md.
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import Discriminator, Tag

from . import gear, prismatic, revolute
from .base import GROUND, AngleRow, Force, JointKind, Kinematics, Rotation, Row, Torque, Translation, finite_point
from .gear import Gear
from .motor import MOTOR, Driver
from .prismatic import Prismatic
from .revolute import Revolute

KINDS: dict[str, JointKind] = {module.KIND.name: module.KIND for module in (revolute, prismatic, gear)}


def _tag(value: Any) -> str:
    """A joint's kind: its ``kind`` field (``revolute`` when left out, as files have always written pins)."""
    kind = value.get("kind", "revolute") if isinstance(value, dict) else getattr(value, "kind", None)
    return str(kind)


Joint = Annotated[
    Annotated[Revolute, Tag("revolute")] | Annotated[Prismatic, Tag("prismatic")] | Annotated[Gear, Tag("gear")],
    Discriminator(_tag, custom_error_type="joint_kind",
                  custom_error_message=f"kind: allowed {', '.join(KINDS)}"),
]


def kind_of(joint: Any) -> JointKind:
    return KINDS[joint.kind]


__all__ = ["GROUND", "KINDS", "MOTOR", "AngleRow", "Driver", "Force", "Gear", "Joint", "JointKind", "Kinematics",
           "Prismatic", "Revolute", "Rotation", "Row", "Torque", "Translation",
           "finite_point", "kind_of"]
