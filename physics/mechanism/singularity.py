"""Singular poses of a mechanism: how close the constraints are to losing their independence, and which joints.

At a change point (a parallelogram four-bar with every link in line) or at a dead centre its motor cannot
drive through, the rows of the constraint Jacobian ``Phi_q`` become dependent: its smallest singular value
falls to zero, two branches of motion meet, and the maximal-coordinate equations of motion (and the tree
formulations' closures) are singular. The four-bar's closed-form classification (``physics/loop_closure.py``) has
no counterpart for a general mechanism; this measure does the same job for any of them, at every sample (a
run's ``condition``, computed when first read: physics/mechanism/engine.py ``_on_request``).
"""

from __future__ import annotations

import numpy as np

from .constraints import Constraints

# The condition of Phi_q above which a pose is reported as near a singular one (the app's status line, the
# command's summary); at the singular pose itself it is infinite (or about 1e16, rounding).
NEAR_SINGULAR_CONDITION = 1e6


def jacobian_condition(constraints: Constraints, q: np.ndarray) -> float:
    """Largest over smallest singular value of ``Phi_q`` at ``q`` (1 for no constraint rows): how near the
    constraints are to becoming dependent (infinite at a change point or a driven dead centre)."""
    jacobian = constraints.jacobian(q)
    if jacobian.shape[0] == 0:
        return 1.0
    singular = np.linalg.svd(jacobian, compute_uv=False)
    smallest = float(singular[min(jacobian.shape) - 1]) if jacobian.shape[0] <= jacobian.shape[1] else 0.0
    return float(singular[0] / smallest) if smallest > 0 else float("inf")


def dependent_joints(constraints: Constraints, q: np.ndarray, count: int = 4) -> list[str]:
    """The joints whose constraints take part in the (near) dependence at ``q``: the rows weighed most by
    the left singular vector of the smallest singular value, strongest first, at most ``count``."""
    jacobian = constraints.jacobian(q)
    if jacobian.shape[0] == 0:
        return []
    left, _, _ = np.linalg.svd(jacobian)
    weights = np.abs(left[:, -1])
    names: list[str] = []
    for row in np.argsort(-weights):
        if weights[row] < 0.1 * weights.max():
            break
        joint = constraints.rows[int(row)].joint
        if joint not in names:
            names.append(joint)
        if len(names) == count:
            break
    return names


def singular_message(constraints: Constraints, q: np.ndarray, t: float) -> str:
    """One line for a run stopped at a singular pose: when, how singular, and which joints' constraints."""
    joints = dependent_joints(constraints, q)
    condition = jacobian_condition(constraints, q)
    shown = "infinite" if not np.isfinite(condition) else f"{condition:.2g}"
    return (f"singular pose at t = {t:.6g} s: the constraints of joints {', '.join(joints)} became dependent "
            f"(a change point or a dead centre; Jacobian condition {shown})")
