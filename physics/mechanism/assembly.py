"""Position analysis of a mechanism: from a rough sketch to a pose where every joint closes, and the count of
its degrees of freedom that the assembled pose actually has.

Newton's method on ``Phi(q) = 0`` with minimum-norm steps (the system is underdetermined by the mobility):
each step moves the bodies as little as possible, rotations weighed by the sketch's size, so the result is the
assembled pose nearest the sketch, on the branch the sketch shows. The Grübler–Kutzbach count of
:mod:`physics.mechanism.topology` can be wrong for special geometry (a parallelogram); the rank of the
constraint Jacobian at the assembled pose cannot, and a constraint it shows to be redundant is refused, naming
its loop, because the maximal-coordinate equations of motion would be singular there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import LinkageError
from .constraints import Constraints
from .description import Mechanism
from .topology import Loop, Topology, analyse

if TYPE_CHECKING:
    from .prepared import Prepared

NEWTON_STEPS = 60
ASSEMBLY_TOLERANCE = 1e-12  # relative to the sketch's size
RANK_TOLERANCE = 1e-9  # singular values below this (relative to the largest) are treated as zero
# A mechanism of pins assembled through its rows written out for pins (Prepared.pin_rows: the generic rows'
# numbers); False: through the generic rows, for the tests that compare the two bit for bit.
PIN_ROWS = True


# eq=False, repr=False: its arrays compare elementwise and print whole; generating __eq__ and __repr__ cost
# every process about 0.5 ms a class (benchmarks/small_cuts.py)
@dataclass(frozen=True, eq=False, repr=False)
class Assembled:
    """An assembled pose ``q`` (3 per body) with its residual, and the mechanism's degrees of freedom."""

    q: np.ndarray
    residual: float
    newton_steps: int
    grubler_mobility: int
    mobility: int  # 3 B minus the rank of the constraint Jacobian at q
    topology: Topology
    speed_motors: int = 0  # motors that prescribe their joint's speed: each fixes one coordinate
    torque_motors: int = 0  # motors that apply a torque: they fix no coordinate

    # ``mobility`` and ``grubler_mobility`` count what the motors leave free (the scripts' contract); the
    # mechanism's own mobility, the textbook's Grübler-Kutzbach number, counts before the motors.
    @property
    def mechanism_mobility(self) -> int:
        """Degrees of freedom of the linkage itself (rank count), before its speed motors fix any."""
        return self.mobility + self.speed_motors

    @property
    def grubler_mechanism_mobility(self) -> int:
        """The textbook Grübler-Kutzbach count 3 B - 2 J (a four-bar: 1, Jansen's leg: 1)."""
        return self.grubler_mobility + self.speed_motors

    def mobility_text(self) -> str:
        """``mobility 1 (Grübler count 1); driven by 1 motor; 0 free``: the mechanism, then its motors."""
        return mobility_text(self.mechanism_mobility, self.grubler_mechanism_mobility, self.speed_motors,
                             self.torque_motors, self.mobility)


def mobility_text_for(mechanism: Mechanism, free: int) -> str:
    """``Assembled.mobility_text`` from the mechanism and the rank count ``free`` a caller already holds (the app)."""
    speed = sum(1 for driver in mechanism.drivers if driver.speed is not None)
    torque = len(mechanism.drivers) - speed
    grubler = analyse_or_refuse(mechanism).mobility
    return mobility_text(free + speed, grubler + speed, speed, torque, free)


def _count(number: int, noun: str) -> str:
    return f"{number} {noun}" + ("" if number == 1 else "s")


def mobility_text(mechanism_mobility: int, grubler: int, speed_motors: int, torque_motors: int, free: int) -> str:
    """The mobility stated both ways: the mechanism's (rank count, with the Grübler-Kutzbach count), then the
    motors and the degrees of freedom they leave free. A torque motor drives without fixing a coordinate."""
    if speed_motors and torque_motors:
        motors = (f"driven by {_count(speed_motors, 'speed motor')} and {_count(torque_motors, 'torque motor')} "
                  "(a torque fixes no coordinate)")
    elif speed_motors:
        motors = f"driven by {_count(speed_motors, 'motor')}"
    elif torque_motors:
        motors = f"driven by {_count(torque_motors, 'torque motor')} (a torque fixes no coordinate)"
    else:
        motors = "no motor"
    return f"mobility {mechanism_mobility} (Grübler count {grubler}); {motors}; {free} free"


def sketch_size(mechanism: Mechanism) -> float:
    points = [xy for body in mechanism.bodies for xy in body.points.values()] + list(mechanism.ground.values())
    xs, ys = zip(*points)
    return max(max(xs) - min(xs), max(ys) - min(ys), 1e-9)


def assemble(mechanism: Mechanism, q_guess: np.ndarray | None = None, t: float = 0.0) -> Assembled:
    """The pose nearest ``q_guess`` (default: the sketch) where every joint closes; LinkageError naming the
    joint that stays open, or the loop that is over-constrained."""
    from .prepared import prepared  # noqa: PLC0415  (it reads sketch_size from here)

    return assemble_prepared(mechanism, prepared(mechanism), q_guess, t)


def assemble_prepared(mechanism: Mechanism, pieces: Prepared, q_guess: np.ndarray | None = None,
                      t: float = 0.0) -> Assembled:
    """:func:`assemble` with the mechanism's prepared pieces (:mod:`physics.mechanism.prepared`: its equations,
    spanning tree and weights, built once per mechanism) that the caller already holds."""
    return assembled_with_jacobian(mechanism, pieces, q_guess, t)[0]


def assembled_with_jacobian(mechanism: Mechanism, pieces: Prepared, q_guess: np.ndarray | None = None,
                            t: float = 0.0) -> tuple[Assembled, np.ndarray]:
    """:func:`assemble_prepared`, and ``Phi_q`` at the assembled pose (read-only; a run projects its start
    velocities with it). A pure function of the mechanism and ``(q_guess, t)``, so the last few starts of each
    mechanism are remembered (:meth:`Prepared.remembered`): a run again from the sketch (a changed setting, a
    study's sweep) does not assemble again. A refusal is never remembered."""
    guess = None if q_guess is None else np.asarray(q_guess, dtype=float)
    key = (None if guess is None else (guess.shape, guess.tobytes()), float(t))
    found = pieces.remembered(key)
    if found is None:
        found = _assemble(mechanism, pieces, q_guess, t)
        found[0].q.setflags(write=False)
        found[1].setflags(write=False)
        pieces.remember(key, found)
    assembled, jacobian = found
    return _with_own_pose(assembled), jacobian


def _with_own_pose(assembled: Assembled) -> Assembled:
    """``replace(assembled, q=assembled.q.copy())`` without the dataclass's ``__init__`` (every field is
    already checked; a run from a remembered start spends a tenth of its Python in it): the caller's own pose,
    writable, the rest shared (numbers and a frozen topology)."""
    copied = object.__new__(Assembled)
    copied.__dict__.update(assembled.__dict__)
    copied.__dict__["q"] = assembled.q.copy()
    return copied


def _assemble(mechanism: Mechanism, pieces: Prepared, q_guess: np.ndarray | None,
              t: float) -> tuple[Assembled, np.ndarray]:
    topology = pieces.topology if pieces.topology is not None else analyse_or_refuse(mechanism)
    constraints = pieces.constraints
    size = pieces.sketch_size
    weights = pieces.assembly_weights  # q = weights * z: rotations in lengths
    q = constraints.sketch_pose() if q_guess is None else np.array(q_guess, dtype=float)
    if not np.all(np.isfinite(q)) or not math.isfinite(t):  # NaN compares false: Newton and the check below
        # would both be skipped and a NaN pose returned as assembled
        raise LinkageError(f"q_guess: expected {q.size} finite numbers (x, y, angle of each body) and a finite t")
    # a mechanism of pins: its rows written out (the same numbers, a tenth of the time: physics/mechanism/pin_rows.py)
    rows = pieces.pin_rows if PIN_ROWS else None
    residual, at_q = (constraints.residual(q, t), None) if rows is None else rows.rows_at(q)  # at_q: Phi_q or None
    steps = 0
    while np.max(np.abs(residual), initial=0.0) > ASSEMBLY_TOLERANCE * size and steps < NEWTON_STEPS:
        jacobian = (constraints.jacobian(q) if at_q is None else at_q) * weights
        step, *_ = np.linalg.lstsq(jacobian, -residual, rcond=None)
        q = q + weights * step
        residual, at_q = (constraints.residual(q, t), None) if rows is None else rows.rows_at(q)
        steps += 1
    worst = int(np.argmax(np.abs(residual))) if residual.size else 0
    if residual.size and not abs(residual[worst]) <= ASSEMBLY_TOLERANCE * size:
        row = constraints.rows[worst]
        raise LinkageError(
            f"joint {row.joint!r}: the mechanism cannot be assembled near the sketch ({row.meaning} stays "
            f"{abs(residual[worst]):.3g} after {steps} Newton steps); check the lengths its bodies' points give"
        )
    jacobian = constraints.jacobian(q) if at_q is None else at_q
    # an open tree of pins has every row independent at every pose (Prepared.full_rank_by_structure): no SVD
    rank = jacobian.shape[0] if pieces.full_rank_by_structure else _rank(jacobian)
    if rank < jacobian.shape[0]:
        raise LinkageError(over_constrained_message(constraints, jacobian, topology.loops))
    return Assembled(
        q=q,
        residual=float(np.max(np.abs(residual), initial=0.0)),
        newton_steps=steps,
        grubler_mobility=topology.mobility,
        mobility=constraints.size - rank,
        topology=topology,
        speed_motors=sum(1 for driver in mechanism.drivers if driver.speed is not None),
        torque_motors=sum(1 for driver in mechanism.drivers if driver.speed is None),
    ), jacobian


def analyse_or_refuse(mechanism: Mechanism) -> Topology:
    try:
        return analyse(mechanism)
    except ValueError as error:
        raise LinkageError(str(error)) from None


def _rank(matrix: np.ndarray) -> int:
    if matrix.size == 0:
        return 0
    values = np.linalg.svd(matrix, compute_uv=False)
    return int(np.sum(values > RANK_TOLERANCE * max(values[0], 1e-300)))


def over_constrained_message(constraints: Constraints, jacobian: np.ndarray, loops: tuple[Loop, ...]) -> str:
    """Name a loop whose closing joint adds a constraint the rest already impose: without that joint's rows the
    count of redundant rows drops."""
    rank = _rank(jacobian)
    redundant = jacobian.shape[0] - rank
    for loop in loops:
        keep = [k for k, row in enumerate(constraints.rows) if row.joint != loop.cut_joint]
        if len(keep) - _rank(jacobian[keep]) < redundant:
            return (
                f"{loop.describe()}: over-constrained ({redundant} redundant constraint"
                f"{'s' if redundant > 1 else ''}; the loop's joints fix nothing the others do not); "
                "remove a joint or turn a pin into a slider"
            )
    joints = sorted({row.joint for row in constraints.rows})
    return (
        f"over-constrained: {redundant} redundant constraint{'s' if redundant > 1 else ''} among joints "
        f"{', '.join(joints)}; remove a joint"
    )


def track(mechanism: Mechanism, times: np.ndarray, q_start: np.ndarray | None = None) -> np.ndarray:
    """Poses of a driven mechanism at ``times`` (``(T, 3 B)``), each assembled from the one before: the branch
    of the first pose is followed through the motion (no jump to the mirror branch between close times)."""
    poses = []
    q = q_start
    for t in np.asarray(times, dtype=float):
        q = assemble(mechanism, q, float(t)).q
        poses.append(q)
    return np.array(poses)


def kinematics(mechanism: Mechanism, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Velocities and accelerations of a mechanism the drivers fully determine (mobility 0):
    ``Phi_q qdot = nu`` and ``Phi_q qddot = gamma``. LinkageError if it has a free degree of freedom."""
    from .prepared import prepared  # noqa: PLC0415

    pieces = prepared(mechanism)
    constraints = pieces.constraints
    jacobian = constraints.jacobian(q)
    if jacobian.shape[0] != jacobian.shape[1] or _rank(jacobian) < jacobian.shape[0]:
        raise LinkageError(
            f"{mechanism.name}: its drivers do not fix every body ({constraints.size - _rank(jacobian)} degrees of "
            "freedom left): kinematics alone cannot give its velocities; it needs the equations of motion"
        )
    qdot = np.linalg.solve(jacobian, pieces.velocity_rhs)
    qddot = np.linalg.solve(jacobian, constraints.acceleration_rhs(q, qdot))
    return qdot, qddot
