"""What a joint row's magnitude does to the bodies: one place for the derivations that need it.

A :class:`~.base.Row` names, per unit, the loads its multiplier applies (forces at points and torques on bodies).
The same rows also carry the loads that are not multipliers: a torque motor's torque on its joint's relative
rotation and a damper's force against its joint's relative motion (:func:`applied_loads`). The maximal-coordinate
DAE and Newton–Euler add them up body by body (:class:`BodyLoads`) and take their own balances of them; Lagrange
turns them into generalised forces through its own partial velocities. Only this bookkeeping is shared: each
formulation still derives its equations its own way.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

from . import KINDS
from .base import Force, Kinematics, Row
from .motor import MOTOR

if TYPE_CHECKING:
    from ..parameters import Structure
    from ..symbolic_parameters import ParameterSymbols


class BodyLoads:
    """The forces (each with its point of application) and torques on each of ``count`` bodies, built as rows'
    loads times their magnitudes in ``k``'s arithmetic; the ground's (body ``-1``) are dropped."""

    def __init__(self, count: int, k: Kinematics) -> None:
        self.k = k
        self.forces: dict[int, list[tuple[Any, Any]]] = {body: [] for body in range(count)}
        self.torques: dict[int, list[Any]] = {body: [] for body in range(count)}

    def apply(self, row: Row, magnitude: Any) -> None:
        """The loads of ``row`` times ``magnitude`` (a multiplier, a motor's torque, a damper's force)."""
        for load in row.loads:
            if load.body < 0:
                continue
            if isinstance(load, Force):
                self.forces[load.body].append((self.k.scale(magnitude, load.force), load.point))
            else:
                self.torques[load.body].append(self.k.times(load.torque, magnitude))


def applied_loads(shape: Structure, params: ParameterSymbols, k: Kinematics) -> Iterator[tuple[Row, Any]]:
    """The loads that are not multipliers, as ``(row, magnitude)``: every torque motor's driven rotation with its
    torque (in driver order), then every damped kind's relative motion with ``-damping * speed`` (in joint
    order: a Rayleigh function ``damping speed^2 / 2``)."""
    speed_driven = shape.speed_driven.values()
    for number, driver in enumerate(shape.drivers):
        if number not in speed_driven:  # a torque motor on its joint's relative rotation
            yield MOTOR.driven(shape.joints[driver.joint].bodies[:2], k), params.drivers[number]
    for number, joint in enumerate(shape.joints):
        symbols = params.joints[number]
        damper = KINDS[joint.kind].damper(joint.bodies, symbols.values, k)
        if damper is not None:
            yield damper, k.negative(k.times(symbols.damping, damper.velocity))
