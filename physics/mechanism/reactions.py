"""The names of a mechanism's reaction rows, in the DAE's layout (:mod:`physics.mechanism.constraints`): a pin's
force ON body ``a`` BY body ``b`` (x, y), a slider's force across the guide and the torque that keeps the relative
angle, a speed motor's torque on ``b``, a gear's contact torque. Every formulation reports its reactions in these rows
(:mod:`physics.mechanism.engine`: the DAE its multipliers, a tree formulation Newton's second law on its own
accelerations).
"""

from __future__ import annotations

import numpy as np

from .description import Mechanism
from .joints import MOTOR, kind_of


def _cross(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def _turn(phi: float, vector: np.ndarray) -> np.ndarray:
    c, s = np.cos(phi), np.sin(phi)
    return np.array([c * vector[0] - s * vector[1], s * vector[0] + c * vector[1]])


def _side(reference: str) -> str:
    return reference.split(".")[0]


def reaction_row_names(mechanism: Mechanism) -> tuple[str, ...]:
    """``"joint: meaning"`` of every reaction row, in the layout of the DAE's multipliers: each joint's rows as
    its kind names them (a pin's x and y gap, and its motor's driven angle when speed-driven; a slider's force
    across the guide and its relative-rotation torque; a gear's contact torque)."""
    speeds = {driver.joint for driver in mechanism.drivers if driver.speed is not None}
    names: list[str] = []
    for joint in mechanism.joints:
        names += [f"{joint.name}: {meaning}" for meaning in kind_of(joint).meanings]
        if joint.name in speeds:
            names += [f"{joint.name}: {meaning}" for meaning in MOTOR.meanings]
    return tuple(names)
