"""``simulate``: one entry point from a validated chain, start state and settings to a Trajectory.

Two back ends share the generated right-hand side. ``compiled`` runs the whole integration loop in the
once-compiled kernels of :mod:`physics.kernels` (RK45 and DOP853 matching scipy step for step, the fixed-step
implicit midpoint rule and the variational integrator); ``scipy`` (imported only for this back end) drives ``scipy.integrate``'s solvers (RK45, DOP853, Radau, LSODA) one step
at a time with the same right-hand side, so the two can be compared and any scipy method used.
Failures midway come back as ``status``/``message`` with the samples computed so far; only bad input raises.
"""

from __future__ import annotations

import math

import numpy as np

from ..codegen import load_compiled
from ..errors import LinkageError
from ..kernels.observables import chain_observables
from ..kinematics import joint_positions
from ..model import Chain, Settings, TracePoint, check_state
from ..reactions import reactions_from_motion
from .trajectory import (
    STATUS_INTEGRATOR_FAILED,
    STATUS_MAX_STEPS,
    STATUS_NONFINITE,
    STATUS_OK,
    STATUS_SINGULAR,
    STATUS_STEP_TOO_SMALL,
    Trajectory,
)

# A system whose condition estimate (the equilibrated LU pivot ratio, raised for a closed chain to the loop
# Jacobian's singular-value ratio) exceeds this is treated as singular. Near a loop singularity at distance
# delta that estimate grows like 1/delta while the unscaled condition number grows like 1/delta^2, so 1e6 here
# means about 12 of the 16 significant digits lost. The kernels use the same value.
SINGULAR_PIVOT_RATIO = 1e6
# The start of a closed chain must close the loop to this distance (a user typing angles by hand will not;
# presets and the app assemble them with physics.assembly).
ASSEMBLY_TOLERANCE = 1e-8

_STATUS_TEXT = {
    STATUS_SINGULAR: "the system became singular (pivot ratio above {limit:.0e}, condition number near its square) at t = {t:.6g} s: the "
    "linkage reached a singular position (links lined up) or its parameters give a bar no inertia",
    STATUS_NONFINITE: "the state became non-finite at t = {t:.6g} s",
    STATUS_STEP_TOO_SMALL: "the step size fell below the smallest allowed at t = {t:.6g} s (the problem is too "
    "stiff or singular for this integrator; try Radau or a looser tolerance)",
    STATUS_MAX_STEPS: "the integrator reached max_steps at t = {t:.6g} s; raise max_steps or loosen the tolerance",
    STATUS_INTEGRATOR_FAILED: "the integrator failed at t = {t:.6g} s: {detail}",
}


def status_message(status: int, t: float, detail: str = "") -> str:
    if status == STATUS_OK:
        return "ok"
    return _STATUS_TEXT.get(status, "failed at t = {t:.6g} s: {detail}").format(
        t=t, limit=SINGULAR_PIVOT_RATIO, detail=detail
    )


def _stabilization_gains(chain: Chain, settings: Settings) -> tuple[float, float, bool]:
    if not chain.pinned or settings.stabilization == "none":
        return 0.0, 0.0, False
    if settings.stabilization == "baumgarte":
        return settings.baumgarte_alpha, settings.baumgarte_beta, False
    return 0.0, 0.0, True


def check_assembled(chain: Chain, theta: np.ndarray) -> None:
    """A closed chain must start on its loop; say by how much it misses."""
    if not chain.pinned:
        return
    tip = joint_positions(chain.array("L"), theta)[-1]
    gap = float(np.hypot(tip[0] - chain.pin[0], tip[1] - chain.pin[1]))
    if not gap <= ASSEMBLY_TOLERANCE:
        raise LinkageError(
            f"the start does not close the loop: the tip is {gap:.3g} from the pin {tuple(chain.pin)} "
            f"(allowed {ASSEMBLY_TOLERANCE:g}); assemble it with physics.assembly.assemble or set the pin to the tip"
        )


# A trajectory holds about 8n + 14 float64 columns per sample (angles, velocities, joints, energies, the
# DAE's reactions, every method's joint reactions, pin reaction and constraint residuals): past this many values (400 MB) a request does not fit a run of this tool, and is refused up front.
MAX_OUTPUT_VALUES = 50_000_000


def check_output_size(n: int, samples: int) -> None:
    """Refuse, before any allocation, a trajectory too large to hold: one line with the estimate and the limit."""
    values = samples * (8 * n + 14)
    if values > MAX_OUTPUT_VALUES:
        raise LinkageError(
            f"samples = {samples}: a {n}-bar trajectory of that many samples holds about {values * 8 / 1e9:.2g} GB "
            f"(limit {MAX_OUTPUT_VALUES * 8 / 1e9:.2g} GB); allowed samples <= {MAX_OUTPUT_VALUES // (8 * n + 14)}"
        )


def simulate(
    chain: Chain, theta0, omega0, settings: Settings | None = None, t_start: float = 0.0, *, continuing: bool = False
) -> Trajectory:
    """Integrate from ``(theta0, omega0)`` at ``t_start`` over ``settings.t_end`` seconds.

    Returns a :class:`Trajectory` sampled at ``settings.samples`` equally spaced times (both ends included).
    Raises :class:`LinkageError` only for invalid input; a failure midway is reported in ``status``.
    ``continuing=True``: the start is the last sample of an earlier run of the same chain (chunked
    integration, as the app does); its constraint drift belongs to that run and is not re-checked.
    """
    settings = settings or Settings()
    theta0, omega0 = check_state(chain.n, theta0, omega0)
    check_output_size(chain.n, settings.samples)
    if not math.isfinite(t_start):
        raise LinkageError(f"t_start = {t_start}: must be a finite number")
    if not continuing:
        check_assembled(chain, theta0)
    if settings.method in ("reduced", "reduced_fixed"):
        from .reduced_adapter import simulate_reduced_trajectory

        return simulate_reduced_trajectory(chain, theta0, omega0, settings, t_start)
    compiled = load_compiled(settings.method, chain.n, chain.pinned)
    params = chain.params(damping=settings.damping)
    alpha, beta, project = _stabilization_gains(chain, settings)
    t_eval = np.linspace(t_start, t_start + settings.t_end, settings.samples)
    y0 = np.concatenate([theta0, omega0])
    if settings.backend == "compiled":
        y_out, cond, status, n_steps, n_rhs, t_reached = _integrate_compiled(
            compiled, y0, t_eval, params, settings, alpha, beta, project
        )
        detail = _compiled_detail(settings, status)
    else:
        y_out, cond, status, n_steps, n_rhs, t_reached, detail = _integrate_scipy(
            compiled, y0, t_eval, params, settings, alpha, beta, project
        )
    filled = int(np.count_nonzero(np.all(np.isfinite(y_out), axis=1)))
    if status == STATUS_OK and filled < len(t_eval):
        status = STATUS_NONFINITE
    trajectory = build_trajectory(
        chain, settings, compiled, params, t_eval[:filled], y_out[:filled], cond[:filled] if cond.size else None,
        alpha, beta,
    )
    trajectory.status = status
    trajectory.message = status_message(status, t_reached, detail)
    trajectory.n_steps = int(n_steps)
    trajectory.n_rhs = int(n_rhs)
    return trajectory


def _integrate_compiled(compiled, y0, t_eval, params, settings, alpha, beta, project):
    y_out = np.full((len(t_eval), y0.size), np.nan)
    cond = np.empty(0)  # computed with the reactions in build_trajectory, once per sample
    t0, t1 = float(t_eval[0]), float(t_eval[-1])
    if settings.integrator == "midpoint":
        result = compiled.integrate_midpoint(
            y0, t0, t1, settings.step, t_eval, params, alpha, beta, project, y_out, cond
        )
    elif settings.integrator == "variational":
        result = compiled.integrate_variational(y0, t0, t1, settings.step, t_eval, params, y_out, cond)
    else:
        integrate = compiled.integrate_rk45 if settings.integrator == "RK45" else compiled.integrate_dop853
        result = integrate(
            y0, t0, t1, t_eval, params, settings.rtol, settings.atol, alpha, beta, project,
            settings.max_steps, y_out, cond,
        )
    status, n_steps, n_rhs, t_reached = result[:4]
    return y_out, cond, int(status), n_steps, n_rhs, float(t_reached)


def _compiled_detail(settings, status: int) -> str:
    if status == STATUS_INTEGRATOR_FAILED and settings.integrator in ("midpoint", "variational"):
        return f"the {settings.integrator} integrator's Newton iteration did not converge; reduce the step (--step)"
    return ""


class _Singular(Exception):
    pass


def _integrate_scipy(compiled, y0, t_eval, params, settings, alpha, beta, project):
    """scipy's solvers stepped by hand, so a failure keeps the samples so far and projection can act.

    With projection, the solver is restarted from the projected state at every output sample (scipy's
    solvers keep internal state that a projection would invalidate)."""
    from scipy.integrate._ivp.ivp import METHODS

    n = compiled.n
    counter = {"rhs": 0}

    def rhs(t, y):
        counter["rhs"] += 1
        theta_ddot, c = compiled.accel(y[:n], y[n:], params, alpha, beta)
        if not c <= SINGULAR_PIVOT_RATIO:
            raise _Singular(t)
        return np.concatenate([y[n:], theta_ddot])

    y_out = np.full((len(t_eval), y0.size), np.nan)
    solver_cls = METHODS[settings.integrator]
    y = y0.copy()
    t_now = float(t_eval[0])
    y_out[0] = y
    next_sample = 1
    n_steps = 0
    status, detail = STATUS_OK, ""
    segments = [(t_eval[i - 1], t_eval[i]) for i in range(1, len(t_eval))] if project else [(t_eval[0], t_eval[-1])]
    try:
        for seg_start, seg_end in segments:
            solver = solver_cls(rhs, float(seg_start), y, float(seg_end), rtol=settings.rtol, atol=settings.atol)
            while solver.status == "running":
                message = solver.step()
                n_steps += 1
                if solver.status == "failed":
                    status, detail = STATUS_INTEGRATOR_FAILED, str(message)
                    break
                if n_steps >= settings.max_steps:
                    status = STATUS_MAX_STEPS
                    break
                if not np.all(np.isfinite(solver.y)):
                    status = STATUS_NONFINITE
                    break
                dense = None
                while next_sample < len(t_eval) and t_eval[next_sample] <= solver.t:
                    if dense is None:
                        dense = solver.dense_output()
                    y_out[next_sample] = dense(t_eval[next_sample])
                    next_sample += 1
            t_now = solver.t
            if status != STATUS_OK:
                break
            if project:
                y = y_out[next_sample - 1].copy()
                theta, omega = np.ascontiguousarray(y[:n]), np.ascontiguousarray(y[n:])
                compiled.project_position(theta, params)
                compiled.project_velocity(theta, omega, params)
                y = np.concatenate([theta, omega])
                y_out[next_sample - 1] = y
    except _Singular as stop:
        status, t_now = STATUS_SINGULAR, float(stop.args[0])
    y_out[next_sample:] = np.nan
    return y_out, np.empty(0), status, n_steps, counter["rhs"], t_now, detail


def system_condition(compiled, theta, omega, params) -> np.ndarray:
    """2-norm condition number of the formulation's matrix A at each sampled state (T,)."""
    A, _ = compiled.matrices(theta, omega, params)
    with np.errstate(all="ignore"):
        return np.linalg.cond(A)


def build_trajectory(chain, settings, compiled, params, t, y, cond=None, alpha=0.0, beta=0.0) -> Trajectory:
    """Everything a trajectory reports, computed from the sampled states in one vectorised pass.

    The generated system is solved once per sample here (one batched call): it gives the reactions and the
    condition estimate together, so the integrator need not evaluate either at the samples.
    """
    n = chain.n
    theta, omega = np.ascontiguousarray(y[:, :n]), np.ascontiguousarray(y[:, n:])
    L, d, m, I = (chain.array(f) for f in "LdmI")
    samples = len(t)
    trace = settings.trace or TracePoint(bar=n, along=float(L[-1]))
    if trace.bar > n:
        raise LinkageError(f"trace bar = {trace.bar}: allowed range 1 <= bar <= {n}")
    joints = np.empty((samples, n + 1, 2))
    trace_xy = np.empty((samples, 2))
    kinetic = np.empty(samples)
    potential = np.empty(samples)
    tip_velocity = np.empty((samples, 2))
    chain_observables(theta, omega, L, d, m, I, float(chain.g), trace.bar - 1, float(trace.along),
                      float(trace.across), joints, trace_xy, kinetic, potential, tip_velocity)
    energy = kinetic + potential

    reactions = np.zeros((samples, len(compiled.reaction_index), 2))
    joint_reactions = np.zeros((samples, n, 2))
    tip_reaction = np.zeros((samples, len(compiled.tip_reaction_index)))
    constraint_xy = np.zeros((samples, 2 if chain.pinned else 0))
    constraint_velocity = np.zeros((samples, 2 if chain.pinned else 0))
    if samples:
        x, batch_cond = compiled.solve_full_batch(theta, omega, params, alpha, beta)
        if cond is None or len(cond) != samples:
            cond = batch_cond
        if compiled.reaction_index.size:
            reactions = x[:, compiled.reaction_index]
        if compiled.tip_reaction_index.size:
            tip_reaction = x[:, compiled.tip_reaction_index]
        joint_reactions = reactions_from_motion(
            L, d, m, float(chain.g), theta, omega, x[:, compiled.theta_ddot_index],
            tip_reaction if chain.pinned else None,
        )
    else:
        cond = np.zeros(0)
    if chain.pinned:
        constraint_xy = joints[:, -1, :] - np.asarray(chain.pin)
        constraint_velocity = tip_velocity
        if samples:
            # Near a singular position the pivot ratio understates the trouble: report the true 2-norm
            # condition number of the system actually solved.
            cond = system_condition(compiled, theta, omega, params)
    return Trajectory(
        method=settings.method,
        integrator=settings.integrator,
        t=t,
        theta=theta,
        omega=omega,
        joints=joints,
        tip_xy=joints[:, -1, :],
        trace_xy=trace_xy,
        kinetic=kinetic,
        potential=potential,
        energy=energy,
        reactions=reactions,
        joint_reactions=joint_reactions,
        tip_reaction=tip_reaction,
        constraint_xy=constraint_xy,
        constraint_velocity=constraint_velocity,
        condition=cond,
        trace_is_explicit=settings.trace is not None,
    )
