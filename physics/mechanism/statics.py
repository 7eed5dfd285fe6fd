"""One instant of any mechanism: its accelerations and reactions in each formulation, the forces on one body
(a free-body diagram), and its rest poses with their stability.

Why a module of its own: the ``accelerations``, ``fbd`` and ``equilibrium`` commands ask the same questions of
a general mechanism that :mod:`physics.evaluate`, :mod:`physics.fbd` and :mod:`physics.rest_positions` answer
for a chain, and the answers must come from the mechanism's own equations (:mod:`.dae`, :mod:`.lagrange`,
:mod:`.newton_euler`) so that the three formulations can be compared at one state.

Every load on a body is written as a force at a point and a moment about the body's centre of mass G, from the
equations the integrator uses: body ``k``'s share of ``Phi_q^T lambda`` for each joint's rows (a pin's force
``(lambda_x, lambda_y)`` at its point; a slider's force across the guide and its torque; a speed motor's
torque), gravity ``(0, -m g)`` at G, a torque motor's ``+tau`` on its joint's body ``b`` (``-tau`` on ``a``),
a damped pin's ``-c (omega_b - omega_a)`` on ``b``, and a viscous slider's force along its guide. They sum to
``m a_G`` and ``I alpha`` (Newton's and Euler's laws), which the command prints beside them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import LinkageError
from .assembly import assemble, sketch_size
from .constraints import Constraints
from .description import GROUND, Mechanism, Prismatic, Revolute
from .joints import MOTOR, kind_of
from .numeric_dae import MechanismDAE
from .reactions import reaction_row_names

STATE_METHODS = ("dae", "lagrange", "newton_euler")  # the formulations that give accelerations at one state
STATE_TOLERANCE = 1e-8  # a given state's largest constraint gap, relative to the sketch's size (and speeds)


@dataclass(frozen=True)
class Instant:
    """Accelerations ``qddot`` (x, y, phi per body's centre of mass) and every reaction row of one formulation at
    the state ``(q, qdot)`` and time ``t``."""

    method: str
    t: float
    q: np.ndarray
    qdot: np.ndarray
    qddot: np.ndarray
    reactions: np.ndarray
    row_names: tuple[str, ...]


def evaluate(mechanism: Mechanism, q: np.ndarray, qdot: np.ndarray, method: str = "dae", t: float = 0.0,
             dae: MechanismDAE | None = None) -> Instant:
    """The accelerations and reactions of ``method`` (one of :data:`STATE_METHODS`) at ``(q, qdot)``: the DAE's
    augmented system, or the tree formulation's own solve, its body motions and its reactions (Newton's second
    law on its own accelerations), in the DAE's row layout and signs, on the compiled engine
    (:func:`physics.mechanism.engine.instant`)."""
    q, qdot = np.asarray(q, dtype=float), np.asarray(qdot, dtype=float)
    dae = MechanismDAE(mechanism) if dae is None else dae
    names = reaction_row_names(mechanism)
    if method == "dae":
        solution = dae.solve(q, qdot)
        return Instant(method, t, q, qdot, solution.qddot, solution.reactions, names)
    if method not in STATE_METHODS:
        raise LinkageError(f"method = {method!r}: allowed {', '.join(STATE_METHODS)} (accelerations at one state; "
                           "the reduced model's runs are `simulate --method reduced`)")
    from .engine import instant  # noqa: PLC0415  (the compiled engine only when asked for)

    qddot, reactions = instant(mechanism, method, q, qdot, t)
    return Instant(method, t, q, qdot, qddot, reactions, names)


def start_state(mechanism: Mechanism, t: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The state a run starts from: the pose assembled nearest the sketch at time ``t``, at rest apart from what
    the motors impose (the velocity nearest rest in kinetic energy that satisfies the constraints)."""
    from .simulate import project_velocity  # noqa: PLC0415

    dae = MechanismDAE(mechanism)
    q = assemble(mechanism, None, t).q
    return q, project_velocity(dae, q, np.zeros_like(q))


def check_state(mechanism: Mechanism, q: np.ndarray, qdot: np.ndarray, t: float, field_name: str) -> None:
    """Refuse a state off the constraints (``Phi(q, t) = 0``) or off their rate (``Phi_q qdot = nu``) by more
    than :data:`STATE_TOLERANCE`, naming the row and the gap: accelerations of a pose that does not close are
    numbers for a mechanism that does not exist."""
    constraints = Constraints(mechanism)
    size = sketch_size(mechanism)
    gap = constraints.residual(q, t)
    if gap.size:
        worst = int(np.argmax(np.abs(gap)))
        if abs(gap[worst]) > STATE_TOLERANCE * size:
            row = constraints.rows[worst]
            raise LinkageError(
                f"{field_name}: the pose is off the constraints: joint {row.joint!r} ({row.meaning}) is "
                f"{abs(gap[worst]):.3g} from closing at t = {t:g} s (at most {STATE_TOLERANCE * size:.2g} allowed); "
                "give an assembled pose (the q printed without --state, or a run's)")
        rate = constraints.jacobian(q) @ qdot - constraints.velocity_rhs()
        worst = int(np.argmax(np.abs(rate)))
        allowed = STATE_TOLERANCE * (1.0 + float(np.max(np.abs(qdot), initial=0.0)) * max(1.0, size))
        if abs(rate[worst]) > allowed:
            row = constraints.rows[worst]
            raise LinkageError(
                f"{field_name}: the velocities break the constraints: joint {row.joint!r} ({row.meaning}) opens at "
                f"{abs(rate[worst]):.3g} per second (at most {allowed:.2g} allowed); give velocities with "
                "Phi_q qdot = nu (the qdot printed without --state, or a run's)")


@dataclass(frozen=True)
class Load:
    """One load on a body: ``force`` (N) applied at ``at`` (world, m; None for a pure couple) and its
    ``moment`` about the body's centre of mass (N m; for a force, the moment of the force)."""

    name: str
    kind: str  # gravity, pin, slider, motor, gear, torque motor, damping
    force: tuple[float, float]
    moment: float
    at: tuple[float, float] | None

    def as_dict(self) -> dict:
        return {"name": self.name, "kind": self.kind, "force": list(self.force), "moment": self.moment,
                "at": None if self.at is None else list(self.at),
                "magnitude": float(np.hypot(*self.force)) if self.at is not None else abs(self.moment)}


@dataclass(frozen=True)
class FreeBody:
    """Every load on one body at one instant, and what they must balance: ``m a_G`` and ``I alpha``."""

    body: str
    method: str
    time: float
    mass: float
    inertia: float
    centre: tuple[float, float]
    angle: float
    com_acceleration: tuple[float, float]
    alpha: float
    loads: list[Load] = field(default_factory=list)

    def net_force(self) -> np.ndarray:
        return np.sum([load.force for load in self.loads], axis=0) if self.loads else np.zeros(2)

    def net_moment(self) -> float:
        return float(sum(load.moment for load in self.loads))

    def as_dict(self) -> dict:
        net, m_a = self.net_force(), self.mass * np.asarray(self.com_acceleration)
        return {
            "body": self.body, "method": self.method, "time": self.time, "mass": self.mass, "inertia": self.inertia,
            "centre": list(self.centre), "angle": self.angle, "com_acceleration": list(self.com_acceleration),
            "alpha": self.alpha, "loads": [load.as_dict() for load in self.loads],
            "balance": {"net_force": net.tolist(), "m_a": m_a.tolist(), "net_moment_about_com": self.net_moment(),
                        "I_alpha": self.inertia * self.alpha,
                        "force_gap": float(np.max(np.abs(net - m_a))),
                        "moment_gap": abs(self.net_moment() - self.inertia * self.alpha)},
        }


def _cross(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def free_body(mechanism: Mechanism, instant: Instant, body_name: str) -> FreeBody:
    """The loads on ``body_name`` at ``instant`` (see the module's docstring for where each comes from)."""
    names = [body.name for body in mechanism.bodies]
    if body_name not in names:
        raise LinkageError(f"--body {body_name!r}: no body of that name (bodies: {', '.join(names)})")
    k = names.index(body_name)
    body = mechanism.bodies[k]
    q, qdot = instant.q, instant.qdot
    constraints = Constraints(mechanism)
    jacobian = constraints.jacobian(q)
    centre = q[3 * k : 3 * k + 2]
    columns = slice(3 * k, 3 * k + 3)
    loads = [Load("gravity", "gravity", (0.0, -mechanism.g * body.mass), 0.0, (float(centre[0]), float(centre[1])))]
    joints = {joint.name: joint for joint in mechanism.joints}
    for joint_name in dict.fromkeys(row.joint for row in constraints.rows):
        joint = joints[joint_name]
        # each group of rows as the joint's kind (or its speed motor) names them
        for meanings, kind in ((kind_of(joint).meanings, kind_of(joint).label), (MOTOR.meanings, MOTOR.label)):
            rows = [r for r, row in enumerate(constraints.rows) if row.joint == joint_name and row.meaning in meanings]
            if not rows:
                continue
            generalised = jacobian[rows, columns].T @ instant.reactions[rows]
            if not np.any(jacobian[rows, columns]):
                continue  # this joint does not touch the body
            force, moment = (float(generalised[0]), float(generalised[1])), float(generalised[2])
            if kind == "pin":
                assert isinstance(joint, Revolute)
                other = _other_side(joint, body_name)
                side = joint.a if joint.a.split(".")[0] == body_name else joint.b
                at = constraints.body_point(q, k, mechanism.point_of(side, joint.name))
                loads.append(Load(f"pin {joint_name} (by {other})", kind, force, moment, (float(at[0]), float(at[1]))))
            elif kind == "slider":
                assert isinstance(joint, Prismatic)
                loads.append(Load(f"slider {joint_name} (by {_other_side(joint, body_name)})", kind, force, moment,
                                  (float(centre[0]), float(centre[1]))))
            elif kind == "motor":
                assert isinstance(joint, Revolute)
                loads.append(Load(f"motor {joint_name} (speed, by {_other_side(joint, body_name)})", kind, (0.0, 0.0),
                                  moment, None))
            elif not any(force):  # a coupler's couple (a gear's mesh torque on this body)
                loads.append(Load(f"{kind} {joint_name}", kind, (0.0, 0.0), moment, None))
            else:
                loads.append(Load(f"{kind} {joint_name}", kind, force, moment, (float(centre[0]), float(centre[1]))))
    dae = MechanismDAE(mechanism)
    explicit = np.zeros(3)
    for driver in mechanism.drivers:
        joint = joints[driver.joint]
        if driver.torque is None or not isinstance(joint, Revolute):
            continue
        sign = _side_sign(joint, body_name)
        if sign:
            torque = sign * float(driver.torque)
            explicit[2] += torque
            loads.append(Load(f"motor {joint.name} (torque, by {_other_side(joint, body_name)})", "torque motor",
                              (0.0, 0.0), torque, None))
    for joint in mechanism.joints:
        if not isinstance(joint, Revolute) or not joint.damping:
            continue
        sign = _side_sign(joint, body_name)
        if sign:
            a, b = (_rate(q, qdot, names, side.split(".")[0]) for side in (joint.a, joint.b))
            torque = -sign * joint.damping * (b - a)
            explicit[2] += torque
            loads.append(Load(f"damping {joint.name}", "damping", (0.0, 0.0), torque, None))
    sliding = dae.applied(qdot, q)[columns] - dae.gravity[columns] - explicit  # what is left: viscous sliders
    if np.any(np.abs(sliding) > 0.0):
        loads.append(Load("slider damping", "damping", (float(sliding[0]), float(sliding[1])), float(sliding[2]),
                          (float(centre[0]), float(centre[1]))))
    acceleration = instant.qddot[columns]
    return FreeBody(body=body_name, method=instant.method, time=instant.t, mass=body.mass, inertia=body.inertia,
                    centre=(float(centre[0]), float(centre[1])), angle=float(q[3 * k + 2]),
                    com_acceleration=(float(acceleration[0]), float(acceleration[1])), alpha=float(acceleration[2]),
                    loads=loads)


def _side_sign(joint: Revolute, body_name: str) -> int:
    """+1 if the body is the joint's ``b`` side, -1 if its ``a`` side, 0 if neither."""
    if joint.b.split(".")[0] == body_name:
        return 1
    if joint.a.split(".")[0] == body_name:
        return -1
    return 0


def _other_side(joint: Revolute | Prismatic, body_name: str) -> str:
    if isinstance(joint, Revolute):
        a, b = joint.a.split(".")[0], joint.b.split(".")[0]
    else:
        a, b = joint.body, joint.on
    return b if a == body_name else a


def _rate(q: np.ndarray, qdot: np.ndarray, names: list[str], body: str) -> float:
    return 0.0 if body == GROUND else float(qdot[3 * names.index(body) + 2])


# --- rest poses -------------------------------------------------------------------------------------------

EQUILIBRIUM_STARTS = 40  # random assembled poses the search starts from
NEWTON_ITERATIONS = 60
DIFFERENCE_STEP = 1e-6  # relative to the sketch's size, for the constraints' curvature


@dataclass(frozen=True)
class RestPose:
    """A pose where the mechanism stays at rest: ``q``, its potential energy, the curvature of the potential
    along the motions the joints allow (eigenvalues of the reduced Hessian, smallest first) and whether it is
    stable (every curvature positive: a local minimum of the potential)."""

    q: np.ndarray
    potential: float
    curvatures: np.ndarray
    stable: bool
    neutral: bool = False  # the smallest curvature is zero (to rounding): the potential is flat along a motion

    def as_dict(self, mechanism: Mechanism) -> dict:
        angles = {body.name: float(np.degrees(self.q[3 * k + 2])) for k, body in enumerate(mechanism.bodies)}
        return {"q": self.q.tolist(), "angles_deg": angles, "stable": self.stable, "neutral": self.neutral,
                "potential": self.potential, "curvatures": self.curvatures.tolist()}


def refuse_without_rest(mechanism: Mechanism) -> None:
    """A mechanism with nothing free, or with a turning motor, has no pose that stays at rest: one line why."""
    moving = [driver for driver in mechanism.drivers if driver.speed]
    assembled = assemble(mechanism)
    if assembled.mobility == 0:
        motors = assembled.speed_motors
        plural = "s" if motors != 1 else ""
        raise LinkageError(
            f"{mechanism.name}: its speed motor{plural} fix{'' if plural else 'es'} every body (mobility 0 after "
            f"{motors} speed motor{plural}): nothing is free to come to rest, so there is no equilibrium to find; "
            "its motion and driving torque are simulate's (lambda[JOINT: driven angle])")
    if moving:
        raise LinkageError(
            f"{mechanism.name}: the motor on joint {moving[0].joint!r} turns at {moving[0].speed:g} rad/s, so no "
            f"pose stays at rest; --set {moving[0].joint}.speed=0 holds that joint still")


def rest_poses(mechanism: Mechanism, starts: int = EQUILIBRIUM_STARTS, seed: int = 0) -> list[RestPose]:
    """Every rest pose the search finds, lowest potential first: stationary points of the potential (gravity and
    constant motor torques) on the constraints, ``grad V = Phi_q^T mu`` with ``Phi = 0``, by Newton's method on
    these equations from ``starts`` random assembled poses; stability from the Hessian of ``V - mu . Phi``
    projected on the constraints' tangent space (its signature does not depend on the basis): stable when every
    curvature is positive, neutral when the smallest is zero to rounding (the potential is flat along a motion,
    and the rest poses form a family of which the search lists those it lands on)."""
    refuse_without_rest(mechanism)
    dae = MechanismDAE(mechanism)
    constraints = Constraints(mechanism)
    size = sketch_size(mechanism)
    gradient = -dae.applied(np.zeros(constraints.size), np.zeros(constraints.size))  # V is linear in q
    if not np.any(gradient):
        raise LinkageError(f"{mechanism.name}: no gravity (g = 0) and no torque motor: nothing pulls it, so every "
                           "pose is at rest (a neutral equilibrium) and none is particular; give g > 0 or a torque")
    scale = 1.0 + float(np.max(np.abs(gradient))) * size
    rng = np.random.default_rng(seed)
    sketch = constraints.sketch_pose()
    found: list[RestPose] = []
    for attempt in range(starts):
        guess = sketch.copy()
        if attempt:
            guess[0::3] += rng.normal(scale=0.3 * size, size=len(mechanism.bodies))
            guess[1::3] += rng.normal(scale=0.3 * size, size=len(mechanism.bodies))
            guess[2::3] += rng.uniform(-np.pi, np.pi, size=len(mechanism.bodies))
        try:
            q = assemble(mechanism, guess).q
        except LinkageError:
            continue
        solution = _stationary(constraints, gradient, q, size, scale)
        if solution is None:
            continue
        q, mu = solution
        q[2::3] = np.pi - (np.pi - q[2::3]) % (2 * np.pi)  # rotations in (-pi, pi]: the joints repeat every turn
        if any(_same_pose(q, pose.q, size) for pose in found):
            continue
        curvatures = _curvatures(constraints, q, mu, size)
        tolerance = 1e-7 * scale
        smallest = float(curvatures[0]) if curvatures.size else np.inf
        found.append(RestPose(q=q, potential=_potential(dae, mechanism, q), curvatures=curvatures,
                              stable=smallest > tolerance, neutral=abs(smallest) <= tolerance))
    return sorted(found, key=lambda pose: pose.potential)


def _stationary(constraints: Constraints, gradient: np.ndarray, q: np.ndarray, size: float, scale: float
                ) -> tuple[np.ndarray, np.ndarray] | None:
    """Newton's method on ``grad V - Phi_q^T mu = 0``, ``Phi = 0`` from ``q``; None if it does not converge."""
    jacobian = constraints.jacobian(q)
    mu, *_ = np.linalg.lstsq(jacobian.T, gradient, rcond=None)
    n, rows = constraints.size, jacobian.shape[0]
    for _ in range(NEWTON_ITERATIONS):
        jacobian = constraints.jacobian(q)
        balance = gradient - jacobian.T @ mu
        closure = constraints.residual(q, 0.0)
        if np.max(np.abs(balance)) <= 1e-11 * scale and np.max(np.abs(closure), initial=0.0) <= 1e-12 * size:
            return q, mu
        matrix = np.zeros((n + rows, n + rows))
        matrix[:n, :n] = -_curvature_matrix(constraints, q, mu, size)
        matrix[:n, n:] = -jacobian.T
        matrix[n:, :n] = jacobian
        step, *_ = np.linalg.lstsq(matrix, -np.concatenate([balance, closure]), rcond=None)
        largest = float(np.max(np.abs(step[:n])))
        if largest > size:  # a long jump leaves the basin: shorten it
            step *= size / largest
        q, mu = q + step[:n], mu + step[n:]
    return None


def _curvature_matrix(constraints: Constraints, q: np.ndarray, mu: np.ndarray, size: float) -> np.ndarray:
    """``d(Phi_q^T mu)/dq`` (the Hessian of ``mu . Phi``) by central differences of the analytic Jacobian."""
    n = constraints.size
    out = np.zeros((n, n))
    for i in range(n):
        h = DIFFERENCE_STEP * (size if i % 3 != 2 else 1.0)
        forward, backward = q.copy(), q.copy()
        forward[i] += h
        backward[i] -= h
        out[:, i] = (constraints.jacobian(forward).T @ mu - constraints.jacobian(backward).T @ mu) / (2 * h)
    return 0.5 * (out + out.T)


def _curvatures(constraints: Constraints, q: np.ndarray, mu: np.ndarray, size: float) -> np.ndarray:
    """Eigenvalues of ``N^T (0 - sum mu_i Hess Phi_i) N`` on an orthonormal basis N of the tangent space."""
    jacobian = constraints.jacobian(q)
    _, values, vectors = np.linalg.svd(jacobian) if jacobian.size else (None, np.zeros(0), np.eye(constraints.size))
    rank = int(np.sum(values > 1e-9 * max(float(values[0]) if values.size else 1.0, 1e-300)))
    basis = vectors[rank:].T
    hessian = -_curvature_matrix(constraints, q, mu, size)
    return np.sort(np.linalg.eigvalsh(basis.T @ hessian @ basis))


def _potential(dae: MechanismDAE, mechanism: Mechanism, q: np.ndarray) -> float:
    """Gravity's potential (zero at y = 0) and a constant torque motor's, ``-tau (phi_b - phi_a)``."""
    names = [body.name for body in mechanism.bodies]
    value = dae.energy(q, np.zeros_like(q))[1]
    joints = {joint.name: joint for joint in mechanism.joints}
    for driver in mechanism.drivers:
        joint = joints[driver.joint]
        if driver.torque is not None and isinstance(joint, Revolute):
            a, b = (0.0 if side.split(".")[0] == GROUND else float(q[3 * names.index(side.split(".")[0]) + 2])
                    for side in (joint.a, joint.b))
            value -= float(driver.torque) * (b - a)
    return float(value)


def _same_pose(a: np.ndarray, b: np.ndarray, size: float) -> bool:
    difference = a - b
    difference[2::3] = (difference[2::3] + np.pi) % (2 * np.pi) - np.pi
    difference[2::3] *= size
    return bool(np.max(np.abs(difference)) <= 1e-6 * size)
