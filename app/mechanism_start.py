"""A general mechanism's start: which of its coordinates are set by hand, and the pose and velocities they give.

A mechanism of mobility m >= 1 (what its speed motors leave free) is started by m coordinates, as a chain is by
its bars' angles: the chain panel's angle and speed sliders, for any mechanism. Which m: of the maximal
coordinates (a body's angle from its sketch, then its centre's x and y), the ones that move fastest along the
free motions at the assembled sketch, a rotation counted as a length (times the mechanism's size), as the
reduced model chooses its joint coordinate (physics/mechanism/reduced.py, the fastest joint); a body's angle is
preferred while one moves at least ANGLE_PREFERENCE as fast, since that is what a person turns. Each is chosen
in the motions the ones before leave free, so the m together fix the pose (a square, invertible system).

A value is reached by Newton's method on the constraints with the chosen coordinates held (minimum-norm steps,
from the start in force, in sub-steps of at most MAX_TURN or MAX_SHIFT times the size, so the branch the
mechanism is on is kept); the velocities solve ``[Phi_q; E] qdot = [nu; rates]`` (``nu``: a speed motor's share).
Plain numpy; no viser.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from physics import LinkageError
from physics.mechanism import Constraints, Mechanism
from physics.mechanism.assembly import sketch_size

ANGLE_PREFERENCE = 0.1
MAX_TURN = math.radians(10.0)  # rad per sub-step of a new start angle
MAX_SHIFT = 0.1  # of the size, per sub-step of a new start position
NEWTON_STEPS = 40
CLOSED = 1e-12  # residual, relative to the size, at which a pose closes (physics' assembly tolerance)
AXES = ("x", "y", "angle")  # q[3 k + axis]


@dataclass(frozen=True)
class FreeCoordinate:
    """One coordinate a start is set by: ``body``'s ``axis`` (``"angle"``, ``"x"`` or ``"y"``), ``index`` into q."""

    body: str
    axis: str
    index: int

    @property
    def angular(self) -> bool:
        return self.axis == "angle"


def free_coordinates(mechanism: Mechanism, q: np.ndarray, mobility: int) -> tuple[FreeCoordinate, ...]:
    """The ``mobility`` coordinates that set a start of ``mechanism`` at the assembled pose ``q`` (see the
    module's docstring); none for a mechanism its motors fix."""
    if mobility <= 0:
        return ()
    constraints = Constraints(mechanism)
    jacobian = constraints.jacobian(q)
    size = sketch_size(mechanism)
    basis = np.linalg.svd(jacobian)[2][-mobility:].T if jacobian.size else np.eye(q.size)[:, :mobility]
    scale = np.tile([1.0, 1.0, size], len(mechanism.bodies))  # a turn as the speed of a point `size` away
    angles = np.arange(q.size) % 3 == 2
    chosen: list[int] = []
    for _ in range(mobility):
        shares = np.linalg.norm(basis, axis=1) * scale
        shares[chosen] = -1.0
        best = float(np.max(shares))
        turning = np.where(angles & (shares >= ANGLE_PREFERENCE * best), shares, -1.0)
        pick = int(np.argmax(turning)) if np.max(turning) > 0 else int(np.argmax(shares))
        chosen.append(pick)
        # the motions left free with this coordinate held
        row = basis[pick][None, :]
        basis = basis @ np.linalg.svd(row)[2][1:].T
    names = [body.name for body in mechanism.bodies]
    return tuple(FreeCoordinate(names[k // 3], AXES[k % 3], k) for k in sorted(chosen))


def _held(constraints: Constraints, q: np.ndarray, indices: list[int], values: np.ndarray) -> np.ndarray:
    """The constraints and the held coordinates' gaps at ``q``."""
    return np.concatenate([constraints.residual(q, 0.0), q[indices] - values])


def pose_with(mechanism: Mechanism, q_from: np.ndarray, free: tuple[FreeCoordinate, ...],
              values: np.ndarray) -> np.ndarray:
    """The pose with the ``free`` coordinates at ``values`` (SI: rad, m), reached from ``q_from`` in sub-steps;
    LinkageError naming the joint that stays open when none closes."""
    constraints = Constraints(mechanism)
    size = sketch_size(mechanism)
    indices = [c.index for c in free]
    target = np.asarray(values, dtype=float)
    start = np.asarray(q_from, dtype=float)[indices]
    limits = np.array([MAX_TURN if c.angular else MAX_SHIFT * size for c in free])
    parts = max(1, int(math.ceil(float(np.max(np.abs(target - start) / limits, initial=0.0)) - 1e-12)))
    weights = np.tile([1.0, 1.0, 1.0 / size], len(mechanism.bodies))  # minimum-norm steps, rotations as lengths
    held = np.zeros((len(indices), q_from.size))
    held[np.arange(len(indices)), indices] = 1.0
    q = np.array(q_from, dtype=float)
    for part in range(1, parts + 1):
        goal = start + (target - start) * part / parts
        q[indices] = goal
        for _ in range(NEWTON_STEPS):
            gap = _held(constraints, q, indices, goal)
            if np.max(np.abs(gap)) <= CLOSED * size:
                break
            jacobian = np.vstack([constraints.jacobian(q), held]) * weights
            step, *_ = np.linalg.lstsq(jacobian, -gap, rcond=None)
            q = q + weights * step
            if not np.all(np.isfinite(q)):
                break
        residual = constraints.residual(q, 0.0) if np.all(np.isfinite(q)) else np.full(len(constraints.rows), np.inf)
        if residual.size and not np.max(np.abs(residual)) <= CLOSED * size:
            worst = constraints.rows[int(np.argmax(np.where(np.isfinite(residual), np.abs(residual), np.inf)))]
            raise LinkageError(f"joint {worst.joint!r} cannot close there ({worst.meaning} stays open)")
    q[indices] = target  # as set, not within rounding of it (the box shows 60, not 59.99999999999999)
    return q


def velocities_with(mechanism: Mechanism, q: np.ndarray, free: tuple[FreeCoordinate, ...],
                    rates: np.ndarray) -> np.ndarray:
    """The velocities at ``q`` with the ``free`` coordinates moving at ``rates`` (rad/s, m/s) and every speed
    motor at its speed: ``[Phi_q; E] qdot = [nu; rates]``."""
    constraints = Constraints(mechanism)
    held = np.zeros((len(free), q.size))
    held[np.arange(len(free)), [c.index for c in free]] = 1.0
    matrix = np.vstack([constraints.jacobian(q), held])
    right = np.concatenate([constraints.velocity_rhs(), np.asarray(rates, dtype=float)])
    solution, *_ = np.linalg.lstsq(matrix, right, rcond=None)
    solution[[c.index for c in free]] = rates  # as set, not within rounding of it (a 0 stays 0)
    return solution
