"""What Design mode computes from a design: its live topology and mobility, a drag re-assembled on its branch,
the traced point's coupler curve over a motor's full turn, and the design saved and opened as a mechanism file.

Everything here goes through the mechanism's own machinery (:mod:`.topology`, :mod:`.assembly`, :mod:`.writer`,
:mod:`.files`), so what a designer sees is what a run of the saved file does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import LinkageError
from .assembly import ASSEMBLY_TOLERANCE, NEWTON_STEPS, analyse_or_refuse, assemble, mobility_text
from .constraints import Constraints
from .description import GROUND, Mechanism
from .design import Design, DesignBody, design_from_mechanism
from .files import mechanism_from_text
from .joints import kind_of
from .prepared import prepared
from .topology import analyse
from .writer import to_json, to_toml

CURVE_SAMPLES = 120  # poses over a motor's turn: 3 degrees apart
STEP_DONE = 1e3  # a Newton step below this many assembly tolerances ends the iteration (its square is negligible)


@dataclass(frozen=True)
class DesignTopology:
    """The live topology a designer reads: counts, loops, the Grübler–Kutzbach number and the rank mobility
    (``None`` with ``notice`` saying why when the design does not assemble yet), free and driven apart."""

    bodies: int
    joints: int
    loops: tuple[str, ...]
    grubler: int | None
    mobility: int | None
    speed_motors: int
    torque_motors: int
    notice: str

    def text(self) -> str:
        """``mobility 1 (Grübler count 1); driven by 1 motor; 0 free`` or the notice."""
        if self.mobility is None or self.grubler is None:
            return self.notice
        return mobility_text(self.mobility, self.grubler, self.speed_motors, self.torque_motors,
                             self.mobility - self.speed_motors)


def topology_of(design: Design) -> DesignTopology:
    """Counts always; the mobility when the design is a connected mechanism that assembles, else a notice
    (the body the ground does not reach, the joint that cannot close, or the over-constrained loop)."""
    speed = sum(1 for d in design.drivers if d.speed is not None)
    torque = len(design.drivers) - speed
    counts = dict(bodies=len(design.bodies), joints=len(design.joints), speed_motors=speed, torque_motors=torque)
    try:
        mechanism = design.to_mechanism()
        topology = analyse_or_refuse(mechanism)
        loops = tuple(loop.describe() for loop in topology.loops)
        assembled = assemble(mechanism)
    except LinkageError as error:
        return DesignTopology(loops=(), grubler=None, mobility=None, notice=str(error), **counts)
    return DesignTopology(loops=loops, grubler=assembled.grubler_mechanism_mobility,
                          mobility=assembled.mechanism_mobility, notice="", **counts)


def check_assembles(design: Design) -> Design:
    """``design`` when it is incomplete or assembles; else the one LinkageError naming the joint that cannot
    close or the over-constrained loop (an edit that would break the mechanism is refused with it)."""
    if not design.is_complete():
        return design
    mechanism = design.to_mechanism()
    analyse_or_refuse(mechanism)
    assemble(mechanism)
    return design


def posed_design(design: Design, mechanism: Mechanism, q: np.ndarray) -> Design:
    """The design redrawn at pose ``q`` of its mechanism: every body's points (and own centre of mass) where the
    pose puts them, a slider's guide turned with its body; masses and inertias unchanged."""
    constraints = Constraints(mechanism)
    turn = {body.name: float(q[3 * k + 2]) for k, body in enumerate(mechanism.bodies)}
    bodies = []
    for k, body in enumerate(design.bodies):
        def moved(xy, k=k):
            at = constraints.body_point(q, k, xy)
            return (float(at[0]), float(at[1]))
        bodies.append(DesignBody(name=body.name, points=tuple((n, moved(xy)) for n, xy in body.points),
                                 mass=body.mass, com=None if body.com is None else moved(body.com),
                                 inertia=body.inertia))
    joints = tuple(kind_of(joint).at_pose(joint, turn) for joint in design.joints)
    return Design(name=design.name, description=design.description, g=design.g, ground=design.ground,
                  bodies=tuple(bodies), joints=joints, drivers=design.drivers, trace=design.trace)


def drag(design: Design, reference: str, xy: tuple[float, float], grid: float | None = None) -> Design:
    """Move point ``reference`` to ``xy`` and re-assemble: Newton from the current pose with minimum-norm steps
    (:func:`.assembly.assemble`), so the mechanism stays on the branch it is on; the result is redrawn at the
    assembled pose. Refused with the LinkageError naming the joint that cannot close (the caller keeps
    ``design``). A ground pivot moves alone (the bodies keep their shapes and follow it); a body's point reshapes
    its body, and a point pinned on it and drawn at the same place (a ground pivot included) moves with it."""
    start = design.point(reference)
    moved = design.move_point(reference, xy, grid)
    target = moved.point(reference)
    for joint in design.joints:  # a body point drags its pin's other point when it was drawn on it
        if reference.partition(".")[0] != GROUND and joint.kind == "revolute" and reference in (joint.a, joint.b):
            other = joint.b if joint.a == reference else joint.a
            if math.dist(design.point(other), start) <= 1e-9 * max(1.0, math.hypot(*start)):
                moved = moved.move_point(other, target)
    if not moved.is_complete():
        return moved
    mechanism = moved.to_mechanism()
    try:
        analyse(mechanism)
    except ValueError:  # a body not yet joined to the ground: nothing to assemble, the point just moves
        return moved
    # without its motors: the pins' written-out rows (a tenth of the generic rows' time), and a motor's angle is
    # not the designer's to keep while a pivot moves (the run starts from whatever pose is drawn)
    assembled = assemble(_without_motors(mechanism))
    return posed_design(moved, mechanism, assembled.q)


def _without_motors(mechanism: Mechanism) -> Mechanism:
    return mechanism.model_copy(update={"drivers": []}) if mechanism.drivers else mechanism


def coupler_curve(design: Design, samples: int = CURVE_SAMPLES) -> np.ndarray:
    """The traced point over one full turn of the design's first speed motor, ``(samples + 1, 2)``: each pose
    assembled from the one before (continuation: the branch is kept); a row of NaN where the mechanism cannot
    assemble (the curve breaks there, and the next pose starts again from the last one that did). LinkageError
    when there is no traced point or no speed motor."""
    if design.trace is None:
        raise LinkageError("coupler curve: choose a traced point first (trace = body.point)")
    motor = next((d for d in design.drivers if d.speed is not None and d.speed != 0.0), None)
    if motor is None:
        raise LinkageError("coupler curve: add a speed motor on a pin first (its turn sweeps the curve)")
    if not (isinstance(samples, int) and 8 <= samples <= 3600):
        raise LinkageError(f"samples = {samples!r}: allowed 8 <= samples <= 3600")
    mechanism = design.to_mechanism()
    free = _without_motors(mechanism)  # the motors' angles are this sweep's own rows
    pieces = prepared(free)
    constraints = pieces.constraints
    start = assemble(free).q
    bodies = [body.name for body in mechanism.bodies]
    joints = {joint.name: joint for joint in mechanism.joints}
    driven = []  # (column of body a's angle or None, of body b's, speed)
    for driver in mechanism.drivers:
        if driver.speed is None:
            continue
        pin: Any = joints[driver.joint]  # a motor's joint is a pin (the description checks it)
        ends = [pin.b.partition(".")[0], pin.a.partition(".")[0]]
        columns = [3 * bodies.index(end) + 2 if end in bodies else None for end in ends]
        driven.append((columns[0], columns[1], float(driver.speed)))
    motor_rows = np.zeros((len(driven), start.size))  # each speed motor's angle row: +1 and -1 on two angles
    for row, (a, b, _) in enumerate(driven):
        if a is not None:
            motor_rows[row, a] += 1.0
        if b is not None:
            motor_rows[row, b] -= 1.0
    owner, _, point = design.trace.partition(".")
    index = bodies.index(owner)
    sketch_xy = mechanism.body(owner).points[point]
    period = 2 * math.pi / abs(motor.speed or 1.0)
    curve = np.full((samples + 1, 2), np.nan)
    q = start
    before = start
    tolerance = ASSEMBLY_TOLERANCE * pieces.sketch_size
    for k, t in enumerate(np.linspace(0.0, period, samples + 1)):
        targets = [_relative_angle(start, a, b) + speed * t for a, b, speed in driven]
        guess = q + (q - before) if k > 1 else q  # a straight-line predictor along the curve
        found = _closed(pieces, constraints, driven, motor_rows, targets, guess, tolerance)
        if found is None:
            continue
        before, q = (q if k > 0 else found), found
        curve[k] = constraints.body_point(q, index, sketch_xy)
    return curve


def _relative_angle(q: np.ndarray, a: int | None, b: int | None) -> float:
    return (0.0 if a is None else float(q[a])) - (0.0 if b is None else float(q[b]))


def _closed(pieces, constraints: Constraints, driven, motor_rows: np.ndarray, targets, guess: np.ndarray,
            tolerance: float):
    """The pose near ``guess`` where every joint closes and each speed motor's angle is at its target
    (Newton, minimum-norm steps), or None when it does not converge: the curve breaks there."""
    q = guess.copy()
    rows = pieces.pin_rows
    weights = pieces.assembly_weights
    for _ in range(NEWTON_STEPS):
        residual, jacobian = rows.rows_at(q) if rows is not None else (constraints.residual(q, 0.0), None)
        if jacobian is None:
            jacobian = constraints.jacobian(q)
        motor_residual = np.array([_relative_angle(q, a, b) - target for (a, b, _), target in zip(driven, targets)])
        full = np.concatenate([residual, motor_residual])
        if np.max(np.abs(full), initial=0.0) <= tolerance:
            return q
        matrix = np.vstack([jacobian, motor_rows]) * weights
        try:  # square and regular away from a dead point: one solve, a third of a least-squares step's time
            step = np.linalg.solve(matrix, -full) if matrix.shape[0] == matrix.shape[1] else None
        except np.linalg.LinAlgError:
            step = None
        if step is None:
            step = np.linalg.lstsq(matrix, -full, rcond=None)[0]
        moved = weights * step
        q = q + moved
        if not np.all(np.isfinite(q)):
            return None
        if np.max(np.abs(moved)) <= STEP_DONE * tolerance:  # Newton converges quadratically: the residual after a
            return q  # step this small is far below the tolerance, so it is not evaluated again
    return None


def design_to_text(design: Design, fmt: str = "toml") -> str:
    """The design as a mechanism file (``"toml"`` or ``"json"``), loadable by ``--mechanism``."""
    mechanism = design.to_mechanism()
    if fmt == "toml":
        return to_toml(mechanism)
    if fmt == "json":
        return to_json(mechanism)
    raise LinkageError(f"format = {fmt!r}: allowed toml, json")


def design_from_text(text: str, name: str = "design.toml") -> Design:
    """A mechanism file's text (TOML or JSON, by ``name``'s ending) opened as a design."""
    return design_from_mechanism(mechanism_from_text(text, name))
