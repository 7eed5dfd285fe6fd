"""Tree coordinates of a maximal-coordinate state: the numbers the tree formulations integrate.

A tree joint's coordinate is the one its kind carries (:meth:`~physics.mechanism.joints.JointKind.freedom`), read
off the state as every joint coordinate is (:mod:`physics.mechanism.joint_coordinates`): a rotation (a pin's: the
child's rotation relative to its parent, zero in the sketch; or, with absolute rotations, the child's own
rotation from the sketch: see :data:`physics.mechanism.parameters.ROTATIONS`) or a travel (a slider's: along the guide from where
the sketch draws it). The spanning tree is :func:`physics.mechanism.topology.
analyse`'s, its bodies parents first (in the order it finds them): the order of the generated tree formulations'
coordinates (:mod:`physics.mechanism.symbolic_tree`). Numbers only (no sympy): a run on a warm cache needs it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .description import Mechanism
from .parameters import ROTATIONS
from .topology import analyse

if TYPE_CHECKING:
    from .prepared import Prepared

def check_rotations(rotations: str) -> None:
    """Refuse, in one line, a ``rotations`` that is not one of :data:`~physics.mechanism.parameters.ROTATIONS`
    (the boundary's check: the derivations only assert it)."""
    if rotations not in ROTATIONS:
        from ..errors import LinkageError  # noqa: PLC0415

        raise LinkageError(f"rotations = {rotations!r}: allowed values {', '.join(ROTATIONS)}")


def tree_state(mechanism: Mechanism, q: np.ndarray, qdot: np.ndarray, pieces: Prepared | None = None,
               rotations: str = "relative") -> tuple[np.ndarray, np.ndarray]:
    """Tree coordinates and rates ``(s, sd)`` of a maximal-coordinate state ``(q, qdot)`` (3 per body, centres
    of mass and rotations from the sketch): each tree joint's own coordinate
    (:class:`~physics.mechanism.joint_coordinates.JointCoordinates`), a rotation taken as the child's relative
    to its parent (``rotations="absolute"``: the child's own rotation, its ``q`` and ``qdot`` entries), a travel
    as body ``a``'s along ``b``'s guide. ``pieces``: the mechanism's prepared pieces when the caller holds them
    (a run does: looking them up writes the description as JSON, about 60 us)."""
    from .prepared import prepared  # noqa: PLC0415  (built once per mechanism)

    check_rotations(rotations)
    pieces = prepared(mechanism) if pieces is None else pieces
    coordinates = pieces.joint_coordinates
    topology = pieces.topology if pieces.topology is not None else analyse(mechanism)
    index = pieces.constraints.body_index
    values, rates = [], []
    for body in topology.parent:  # found breadth-first: every parent before its children
        joint_name, _ = topology.parent[body]
        which = coordinates.index(joint_name)
        if rotations == "absolute" and coordinates.forms[which] == "angle":
            slot = 3 * index[body] + 2
            values.append(float(q[slot]))
            rates.append(float(qdot[slot]))
            continue
        # a joint's angle is b's relative to a: the child's relative to its parent when the child is b
        sign = -1.0 if coordinates.forms[which] == "angle" and body == coordinates.ends[which][0] else 1.0
        values.append(sign * coordinates.value(q, which))
        rates.append(sign * coordinates.rate(q, qdot, which))
    return np.array(values), np.array(rates)
