"""What Design mode computes from a design: its live topology and mobility, a drag re-assembled on its branch,
the traced point's coupler curve over a motor's full turn, and the design saved and opened as a mechanism file.

Everything here goes through the mechanism's own machinery (:mod:`.topology`, :mod:`.assembly`, :mod:`.writer`,
:mod:`.files`), so what a designer sees is what a run of the saved file does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import LinkageError
from .assembly import ASSEMBLY_TOLERANCE, NEWTON_STEPS, analyse_or_refuse, assemble, mobility_text
from .constraints import Constraints
from .description import GROUND, Mechanism
from .design import Design, DesignBody, design_from_mechanism
from .files import mechanism_from_text
from .joints import kind_of
from .prepared import Prepared, prepared
from .topology import analyse
from .writer import to_json, to_toml

if TYPE_CHECKING:
    from .pin_rows import PinRows

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
    assembled from the ones before (continuation: the branch is kept); a row of NaN where the mechanism cannot
    assemble (the curve breaks there, and the next pose starts again from the last one that did). LinkageError
    when there is no traced point or no speed motor.

    A drag redraws this curve on every move (issue 27: within 50 ms with the drag), so the sweep's Newton
    iteration is :class:`_SweepNewton`, its constant pieces built once, and each guess is
    :func:`_predicted` from the poses before."""
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
    start = assemble(free).q
    newton = _SweepNewton(mechanism, pieces, start)
    period = 2 * math.pi / abs(motor.speed or 1.0)
    poses = np.full((samples + 1, start.size), np.nan)  # a row of NaN where the mechanism cannot assemble
    base = newton.motor_rows @ start  # each motor's angle at the start; its target at t is this plus speed t
    run = 0  # how many samples just before this one assembled
    for k, t in enumerate(np.linspace(0.0, period, samples + 1)):
        found = newton.closed(base + newton.speeds * t, _predicted(poses, k, run, start))
        run = 0 if found is None else run + 1
        if found is not None:
            poses[k] = found
    owner, _, point = design.trace.partition(".")
    index = [body.name for body in mechanism.bodies].index(owner)
    arm = np.asarray(mechanism.body(owner).points[point], dtype=float) - pieces.constraints.centres[index]
    angle = poses[:, 3 * index + 2]
    cos, sin = np.cos(angle), np.sin(angle)  # the traced point at every pose at once (NaN rows stay NaN)
    return np.column_stack([poses[:, 3 * index] + cos * arm[0] - sin * arm[1],
                            poses[:, 3 * index + 1] + sin * arm[0] + cos * arm[1]])


def _predicted(poses: np.ndarray, k: int, run: int, start: np.ndarray) -> np.ndarray:
    """The guess for sample ``k`` after ``run`` samples in a row assembled: the parabola through the last three
    poses (its error is third order in the 3-degree step, the straight line's second order: fewer Newton steps,
    BENCHMARKS.md), the straight line through the last two when only two assembled, else the last pose
    that assembled (the start before any): after a break the guess is where the mechanism last was, so the
    curve resumes on its branch."""
    if run >= 3:
        return 3.0 * (poses[k - 1] - poses[k - 2]) + poses[k - 3]
    if run == 2:
        return 2.0 * poses[k - 1] - poses[k - 2]
    done = np.flatnonzero(~np.isnan(poses[:k, 0]))
    return poses[done[-1]].copy() if done.size else start.copy()


class _SweepNewton:
    """Newton's method for a sweep's poses, its constant pieces built once. A sweep is a few hundred steps on a
    few tens of numbers, where numpy's and LAPACK's per-call overhead, not arithmetic, is the cost; so:

    * ``matrix``: ``[Phi_q; motor rows]`` with the assembly weights applied to its columns (rotations in
      lengths), preallocated in Fortran order (LAPACK's, so the solve copies nothing more). The motor rows
      (``+1`` and ``-1`` on the two angles a speed motor turns, weighted) are constant and written once; so
      are a mechanism of pins' translation entries (:meth:`_pin_layout`), each step rewriting only the pins'
      angle entries in place. Another mechanism (a slider) takes its generic rows from :class:`Constraints`.
    * every motor's angle error is one product, ``motor_rows @ q - target``;
    * a square matrix is solved by LAPACK's ``dgesv`` (a quarter of ``np.linalg.solve``'s time at this size);
      a singular or non-square one (a dead point; more freedoms than motors) by least squares, the
      minimum-norm step."""

    def __init__(self, mechanism: Mechanism, pieces: Prepared, start: np.ndarray) -> None:
        # imported here: physics keeps scipy.linalg off its import path (physics/kernels/numba_start.py), and a
        # sweep's assembly has loaded it already
        from scipy.linalg import lapack  # noqa: PLC0415

        self.dgesv = lapack.dgesv
        bodies = [body.name for body in mechanism.bodies]
        joints = {joint.name: joint for joint in mechanism.joints}
        rows, speeds = [], []
        for driver in mechanism.drivers:
            if driver.speed is None:
                continue
            pin: Any = joints[driver.joint]  # a motor's joint is a pin (the description checks it)
            row = np.zeros(start.size)
            for end, sign in ((pin.b, 1.0), (pin.a, -1.0)):  # b's angle minus a's (the ground's is none)
                name = end.partition(".")[0]
                if name in bodies:
                    row[3 * bodies.index(name) + 2] += sign
            rows.append(row)
            speeds.append(float(driver.speed))
        self.motor_rows = np.array(rows).reshape(len(rows), start.size)
        self.speeds = np.array(speeds)
        self.constraints = pieces.constraints
        self.weights = pieces.assembly_weights
        self.tolerance = ASSEMBLY_TOLERANCE * pieces.sketch_size
        self.joint_rows = self.constraints.residual(start, 0.0).size
        self.matrix = np.zeros((self.joint_rows + len(rows), start.size), order="F")
        self.matrix[self.joint_rows:] = self.motor_rows * self.weights
        self.residual = np.empty(self.matrix.shape[0])
        self.square = self.matrix.shape[0] == self.matrix.shape[1]
        self.pins = pieces.pin_rows
        if self.pins is not None:
            self._pin_layout(self.pins, len(bodies))

    def _pin_layout(self, pins: PinRows, body_count: int) -> None:
        """A mechanism of pins in complex numbers, ``x + i y``: a pin end's point is its body's centre plus its
        arm turned, ``z + e^{i phi} s``, and the point's derivative by the body's angle is ``i e^{i phi} s``,
        whose real and imaginary parts are the x and y rows' entries in the angle column. Viewed as floats a
        complex array is its (x, y) pairs: the residual's order (each pin's x gap, then its y gap) and, written
        at ``angle_at``, the Jacobian's angle entries. The translation entries (``sign``: +1 on a pin's ``a``,
        -1 on its ``b``) are constant and written once; the ground's entries have no column and are dropped."""
        height = self.matrix.shape[0]
        row_x = np.tile(2 * np.arange(pins.pins), 2)[pins.ends != body_count]  # the ground: PinRows' body B
        ends = pins.ends[pins.ends != body_count]
        sign = pins.sign[pins.ends != body_count]
        by_column = self.matrix.T.reshape(-1)  # a view (Fortran order): entry (row, column) at column * height + row
        by_column[3 * ends * height + row_x] = sign * self.weights[3 * ends]
        by_column[(3 * ends + 1) * height + row_x + 1] = sign * self.weights[3 * ends + 1]
        angle_x = (3 * ends + 2) * height + row_x
        self.by_column = by_column
        self.angle_at = np.stack([angle_x, angle_x + 1], axis=1).reshape(-1)  # each end's x row, then its y row
        self.angle_factor = 1j * sign * self.weights[3 * ends + 2]
        self.on_body = np.flatnonzero(pins.ends != body_count)
        self.ends = pins.ends
        self.arm = pins.arm[0] + 1j * pins.arm[1]
        self.count = pins.pins
        self.pose = np.zeros((body_count + 1, 3))  # each body's x, y, angle; the ground's (a last row): zeros
        self.to_complex = np.array([1.0, 1j])

    def _evaluate(self, q: np.ndarray, target: np.ndarray) -> None:
        """``residual`` and ``matrix`` at ``q`` (in place): the joints' gaps and the motors' angle errors, and
        the weighted Jacobian."""
        joint_rows = self.joint_rows
        self.residual[joint_rows:] = self.motor_rows @ q - target
        if self.pins is None:
            self.residual[:joint_rows] = self.constraints.residual(q, 0.0)
            self.matrix[:joint_rows] = self.constraints.jacobian(q) * self.weights
            return
        pose = self.pose
        pose[:-1] = q.reshape(-1, 3)
        turned = np.exp(1j * pose[:, 2]).take(self.ends) * self.arm
        point = (pose[:, :2] @ self.to_complex).take(self.ends) + turned
        count = self.count
        self.residual[:joint_rows] = (point[:count] - point[count:]).view(float)
        self.by_column[self.angle_at] = (turned.take(self.on_body) * self.angle_factor).view(float)

    def _step(self) -> np.ndarray:
        """The Newton step ``matrix^-1 residual`` (weighted back to ``q``'s units); minimum-norm by least
        squares when the matrix is not square or is singular."""
        if self.square:
            step, info = self.dgesv(self.matrix, self.residual)[2:]
            if info == 0:
                return self.weights * step
        return self.weights * np.linalg.lstsq(self.matrix, self.residual, rcond=None)[0]

    def closed(self, target: np.ndarray, guess: np.ndarray) -> np.ndarray | None:
        """The pose near ``guess`` where every joint closes and each speed motor's angle is at ``target``, or
        None when Newton does not converge (the curve breaks there).

        Converged when the residual is within the assembly tolerance, or, without evaluating it again, when
        the last step was so small that the next residual is far below it: Newton's error squares each step
        (``e' ~ K e^2``), and a step is about the error it removes, so a step below :data:`STEP_DONE`
        tolerances, or one that the step before shows to be in that quadratic regime (``K`` read off the two:
        ``step / before^2``) with its next error ``K step^2`` a thousandth of the tolerance, ends it."""
        q = guess
        tolerance = self.tolerance
        done = STEP_DONE * tolerance
        before = None  # the step before this one's size (None: this is the first)
        for _ in range(NEWTON_STEPS):
            self._evaluate(q, target)
            if abs(self.residual).max() <= tolerance:
                return q
            moved = self._step()
            q = q - moved
            size = float(abs(moved).max())
            if not math.isfinite(size):
                return None
            if size <= done or (before is not None and size <= 0.1 * before
                                and size**3 <= 1e-3 * tolerance * before**2):
                return q
            before = size
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
