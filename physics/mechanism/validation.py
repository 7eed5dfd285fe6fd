"""Whether a mechanism can run at all, checked before anything accepts it (the command line, a file, an
upload, an edit in the app): one check for every door.

Why a check of its own: the pydantic models check each field alone (a mass within 0..1e6 kg, a motor within
±1000 rad/s); a mechanism can pass all of them and still not run: a sketch whose joints cannot close, a body
whose mass is 5e-324 kg (``1/m`` overflows and the solver's SVD fails), every body massless, a fully driven
linkage that assembles at the start and locks a quarter turn later (``mechanism --file`` printed "mobility 0"
and exit 0), or a motor turning so fast that the pose cannot be followed from one sample to the next.
:func:`check_runnable` finds those up front and raises one LinkageError naming the body, joint or motor, the
field and the allowed range.
"""

from __future__ import annotations

import functools
import json
import math

import numpy as np

from ..errors import LinkageError
from ..model import MIN_JOINT_INERTIA
from .assembly import ASSEMBLY_TOLERANCE, NEWTON_STEPS, RANK_TOLERANCE, Assembled, assemble, sketch_size
from .constraints import Constraints
from .description import Mechanism

MIN_MASS = 1e-6  # kg: a milligram; every body needs mass for the equations of motion (the DAE divides by it)
MIN_INERTIA = MIN_JOINT_INERTIA  # kg m^2: a milligram at a millimetre's radius of gyration (1e-12; with margin)
# m: a sketch spans at most kilometres (a chain of the app: 12 bars of at most 1000 m); far beyond, squares of
# distances overflow (a point at 1e300 m made the framing and the sliders' ranges infinite)
MAX_COORDINATE = 1e4
MAX_MASS = 1e6  # kg, as the model
MAX_INERTIA = 1e6  # kg m^2, as the model
# The augmented matrix [[M, J^T], [J, 0]] at the start pose, scaled to unit diagonal where possible: beyond
# this condition number its solve loses every digit (a body whose motion nothing determines).
MAX_CONDITION = 1e13
# A motor may turn at most this angle between two samples of a run: assembly follows the pose from one
# sample to the next by Newton's method and loses it beyond (measured: the crank-rocker followed 1.7 rad per
# sample and lost 5 rad).
MAX_TURN_PER_SAMPLE = 0.5  # rad
MAX_MOTOR_SPEED = 100.0  # rad/s, about 16 turns a second, whatever the sampling (a file may write up to 1e3)
MIN_MASS_RATIO = 1e-12  # smallest mass (or inertia / size^2) allowed beside the largest: a nonsingular matrix
SWEEP_POSES_PER_TURN = 72  # poses per turn of the fastest motor when a fully driven mechanism is swept
MAX_SWEEP_POSES = 2000


def check_extent(mechanism: Mechanism) -> None:
    """Every point of the sketch within MAX_COORDINATE of the origin; LinkageError naming the first beyond."""
    named = [(f"ground point {name!r}", xy) for name, xy in mechanism.ground.items()]
    for body in mechanism.bodies:
        named += [(f"body {body.name!r}: point {name!r}", xy) for name, xy in body.points.items()]
        if body.com is not None:
            named.append((f"body {body.name!r}: com", body.com))
    for what, (x, y) in named:
        if not (abs(x) <= MAX_COORDINATE and abs(y) <= MAX_COORDINATE):
            raise LinkageError(f"{what} = [{x:g}, {y:g}] m: allowed coordinates -{MAX_COORDINATE:g} <= x, y <= "
                               f"{MAX_COORDINATE:g} m")


def max_motor_speed(sample_interval: float) -> float:
    """The fastest motor (rad/s) a run sampled every ``sample_interval`` seconds can follow."""
    return MAX_TURN_PER_SAMPLE / sample_interval


def check_masses(mechanism: Mechanism) -> None:
    """Every body's mass and inertia within the physically meaningful range; LinkageError naming the first
    that is not."""
    for body in mechanism.bodies:
        for field, value, low, high, unit in (("mass", body.mass, MIN_MASS, MAX_MASS, "kg"),
                                              ("inertia", body.inertia, MIN_INERTIA, MAX_INERTIA, "kg m^2")):
            if not (math.isfinite(value) and low <= value <= high):
                raise LinkageError(f"body {body.name!r}: {field} = {value:g} {unit}: allowed range "
                                   f"{low:g} <= {field} <= {high:g} {unit} (every body needs mass and inertia "
                                   "for the equations of motion)")
    size = sketch_size(mechanism)
    scaled = np.array([[body.mass, body.inertia / size**2] for body in mechanism.bodies])
    smallest = np.unravel_index(int(np.argmin(scaled)), scaled.shape)
    if scaled[smallest] < MIN_MASS_RATIO * float(np.max(scaled)):
        body = mechanism.bodies[int(smallest[0])]
        field, value, unit = ("mass", body.mass, "kg") if smallest[1] == 0 else ("inertia", body.inertia, "kg m^2")
        raise LinkageError(
            f"body {body.name!r}: {field} = {value:g} {unit} is negligible beside the heaviest body (below "
            f"{MIN_MASS_RATIO:g} of it): the mass matrix is singular in double precision; give it at least "
            f"{MIN_MASS_RATIO * float(np.max(scaled)) * (1.0 if smallest[1] == 0 else size**2):.3g} {unit}"
        )


def check_motors(mechanism: Mechanism, sample_interval: float | None) -> None:
    """Every speed motor within :data:`MAX_MOTOR_SPEED` and slow enough for a run sampled every
    ``sample_interval`` seconds (None: a run's own sampling, checked as it goes)."""
    if sample_interval is None:
        for driver in mechanism.drivers:
            if driver.speed is not None and abs(driver.speed) > MAX_MOTOR_SPEED:
                raise LinkageError(f"motor {driver.joint!r}: speed = {driver.speed:g} rad/s: allowed range "
                                   f"-{MAX_MOTOR_SPEED:g} <= speed <= {MAX_MOTOR_SPEED:g} rad/s")
        return
    fastest = min(MAX_MOTOR_SPEED, max_motor_speed(sample_interval))
    for driver in mechanism.drivers:
        if driver.speed is not None and abs(driver.speed) > fastest:
            raise LinkageError(
                f"motor {driver.joint!r}: speed = {driver.speed:g} rad/s: allowed range -{fastest:g} <= speed <= "
                f"{fastest:g} rad/s (it turns {abs(driver.speed) * sample_interval:.3g} rad between samples "
                f"{sample_interval:.3g} s apart; the pose cannot be followed beyond {MAX_TURN_PER_SAMPLE} rad)")


def check_solvable(mechanism: Mechanism, q: np.ndarray) -> None:
    """The equations of motion at pose ``q`` have one solution: the augmented matrix is well conditioned."""
    constraints = Constraints(mechanism)
    mass = np.array([v for body in mechanism.bodies for v in (body.mass, body.mass, body.inertia)], dtype=float)
    jacobian = constraints.jacobian(q)
    size, rows = len(mass), jacobian.shape[0]
    matrix = np.zeros((size + rows, size + rows))
    matrix[:size, :size] = np.diag(mass)
    matrix[:size, size:] = jacobian.T
    matrix[size:, :size] = jacobian
    scale = np.ones(size + rows)
    scale[:size] = 1.0 / np.sqrt(mass)  # each body's coordinates in units of its own mass: a fair condition
    scaled = scale[:, None] * matrix * scale[None, :]
    with np.errstate(all="ignore"):
        try:
            condition = float(np.linalg.cond(scaled)) if np.all(np.isfinite(scaled)) else math.inf
        except np.linalg.LinAlgError:
            condition = math.inf
    if not condition <= MAX_CONDITION:
        raise LinkageError(f"{mechanism.name}: its equations of motion have no unique solution at the start "
                           f"(condition {condition:.3g} > {MAX_CONDITION:g}); check the bodies' masses and "
                           "inertias and that every body is held by joints or has mass")


def check_runnable(mechanism: Mechanism, sample_interval: float | None = None) -> Assembled:
    """The assembled start of ``mechanism`` once it is known to run: points within reach, masses and inertias
    in range, motors that can be followed at ``sample_interval``, joints that close, equations of motion that
    can be solved. LinkageError (one line naming the body, joint or motor) otherwise."""
    check_extent(mechanism)
    check_masses(mechanism)
    check_motors(mechanism, sample_interval)
    assembled = assemble(mechanism)
    check_solvable(mechanism, assembled.q)
    if assembled.mobility == 0:
        check_sweep(mechanism, assembled)
    return assembled


def check_sweep(mechanism: Mechanism, assembled: Assembled) -> None:
    """Follow a fully driven mechanism through one turn of its slowest motor, each pose assembled from the one
    before (as its run does); the first pose that does not close is refused with its time.

    A sweep costs a few tenths of a second and depends on the geometry and the ratios of the motors' speeds
    only, so it is kept per geometry: an edit of a mass, an inertia, g or a motor's speed (a slider dragged in
    the app) sweeps nothing."""
    speeds = [abs(driver.speed) for driver in mechanism.drivers if driver.speed]
    if not speeds:
        return
    slowest = min(speeds)
    document = mechanism.model_dump(mode="json", include={"ground": True, "joints": True, "drivers": True,
                                                           "bodies": {"__all__": {"name", "points"}}})
    for driver in document["drivers"]:  # the poses of a turn depend on the speeds' ratios, not on the speeds
        if driver["speed"] is None:
            driver["torque"] = 0.0
        else:
            driver["speed"] /= slowest
    failure = _sweep_failure(json.dumps(document, sort_keys=True), tuple(float(x) for x in assembled.q))
    if failure is not None:
        fraction, reason = failure
        period = 2.0 * math.pi / slowest
        raise LinkageError(f"{mechanism.name}: the motors cannot drive it through a turn (it locks at t = "
                           f"{fraction * period:.3g} s of {period:.3g} s): {reason}")


@functools.lru_cache(maxsize=64)
def _sweep_failure(geometry: str, q0: tuple[float, ...]) -> tuple[float, str] | None:
    """Where in a turn of the slowest motor (a fraction) ``geometry`` (its slowest motor at 1 rad/s) fails to
    assemble from ``q0``, and why; None when it turns through."""
    document = json.loads(geometry)
    for body in document["bodies"]:  # the sweep is kinematics: unit masses make a valid description
        body["mass"], body["inertia"] = 1.0, 1.0
    mechanism = Mechanism.model_validate(document)
    speeds = [abs(driver.speed) for driver in mechanism.drivers if driver.speed]
    period = 2.0 * math.pi / min(speeds)
    poses = min(MAX_SWEEP_POSES, SWEEP_POSES_PER_TURN * math.ceil(max(speeds) / min(speeds)))
    follow = _Follower(mechanism)
    q = np.array(q0)
    for t in np.linspace(0.0, period, poses + 1)[1:]:
        followed = follow(q, float(t))
        if followed is None:  # not closed, or closed where a constraint is redundant: assembly's own words
            try:
                followed = assemble(mechanism, q, float(t)).q
            except LinkageError as error:
                return float(t) / period, str(error)
        q = followed
    return None


class _Follower:
    """:func:`~physics.mechanism.assembly.assemble` from the previous pose, its Newton steps and rank test the
    same operations on the same numbers, without building the constraints again at every pose (a sweep's
    72 poses built them 72 times: a fifth of its time). None where assembly would refuse the pose; the caller
    asks assembly itself then, for its message."""

    def __init__(self, mechanism: Mechanism) -> None:
        self.constraints = Constraints(mechanism)
        self.size = sketch_size(mechanism)
        self.weights = np.tile([1.0, 1.0, 1.0 / self.size], len(mechanism.bodies))
        # the last pose returned and its Phi_q (Phi_q depends on q alone): the next pose's first Newton step
        # starts from that pose, so its Jacobian is the one the rank test has just made (a fifth of a sweep's
        # Jacobians made once instead of twice)
        self._held: tuple[np.ndarray, np.ndarray] | None = None

    def _jacobian(self, q: np.ndarray) -> np.ndarray:
        held = self._held
        if held is not None and np.array_equal(held[0], q):
            return held[1]
        return self.constraints.jacobian(q)

    def __call__(self, q: np.ndarray, t: float) -> np.ndarray | None:
        constraints, weights, tolerance = self.constraints, self.weights, ASSEMBLY_TOLERANCE * self.size
        q = np.array(q, dtype=float)
        residual = constraints.residual(q, t)
        steps = 0
        while np.max(np.abs(residual), initial=0.0) > tolerance and steps < NEWTON_STEPS:
            step, *_ = np.linalg.lstsq(self._jacobian(q) * weights, -residual, rcond=None)
            q = q + weights * step
            residual = constraints.residual(q, t)
            steps += 1
        if residual.size and np.max(np.abs(residual)) > tolerance:
            return None
        jacobian = self._jacobian(q)
        if jacobian.size:
            values = np.linalg.svd(jacobian, compute_uv=False)
            if int(np.sum(values > RANK_TOLERANCE * max(values[0], 1e-300))) < jacobian.shape[0]:
                return None
        self._held = (q, jacobian)
        return q
