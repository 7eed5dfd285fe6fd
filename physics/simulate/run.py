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

from ..codegen import load_compiled, native_run
from ..errors import LinkageError
from ..kernels.constants import SINGULAR_PIVOT_RATIO
from ..kinematics import joint_positions
from ..model import MAX_ANGLE, MAX_ANGULAR_SPEED, Chain, Settings, check_state
from ..registry import INTEGRATORS, METHODS, SCIPY
from ..status import Status
from . import on_mechanism
from .build import build_trajectory, trace_point, trajectory_from_samples
from .prepared import chain_arrays, sample_times, stabilization_gains
from .trajectory import Trajectory

__all__ = ["SINGULAR_PIVOT_RATIO", "check_assembled", "simulate", "status_message"]
# The start of a closed chain must close the loop to this distance (a user typing angles by hand will not;
# presets and the app assemble them with physics.assembly).
ASSEMBLY_TOLERANCE = 1e-8

def status_message(status: int, t: float, detail: str = "") -> str:
    """The sentence for a run's status at time ``t`` (physics.status.Status)."""
    return Status.describe(status, t, detail)


_OK_MESSAGE = status_message(Status.OK, 0.0)  # a run that succeeded says so the same way at every t


def _start_state(n: int, theta0, omega0) -> np.ndarray:
    """``y0 = [theta0, omega0]`` of a valid start. Arrays of the right shape and every entry within range (so
    finite) pass with one comparison; anything else goes through :func:`physics.model.check_state`, which
    converts lists and names the first bad entry."""
    if (type(theta0) is np.ndarray and type(omega0) is np.ndarray and theta0.shape == (n,)
            and omega0.shape == (n,) and theta0.dtype == np.float64 and omega0.dtype == np.float64):
        y0 = np.concatenate([theta0, omega0])
        if n <= FEW_LINKS:  # a few floats compare faster in Python than through three numpy calls
            values = y0.tolist()
            if (all(-MAX_ANGLE <= value <= MAX_ANGLE for value in values[:n])  # False for NaN and infinities
                    and all(-MAX_ANGULAR_SPEED <= value <= MAX_ANGULAR_SPEED for value in values[n:])):
                return y0
        elif (np.abs(y0) <= _state_limits(n)).all():  # False for NaN and infinities too
            return y0
    theta0, omega0 = check_state(n, theta0, omega0)
    return np.concatenate([theta0, omega0])


_limits: dict[int, np.ndarray] = {}
FEW_LINKS = 8


def _state_limits(n: int) -> np.ndarray:
    """``[MAX_ANGLE] * n + [MAX_ANGULAR_SPEED] * n``: check_state's ranges for ``y0``."""
    if n not in _limits:
        _limits[n] = np.array([MAX_ANGLE] * n + [MAX_ANGULAR_SPEED] * n)
    return _limits[n]


def check_assembled(chain: Chain, theta: np.ndarray) -> None:
    """A closed chain must start on its loop; say by how much it misses."""
    if chain.pin is None:
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
    n = chain.n
    y0 = _start_state(n, theta0, omega0)
    theta0, omega0 = y0[:n], y0[n:]
    check_output_size(n, settings.samples)
    if not math.isfinite(t_start):
        raise LinkageError(f"t_start = {t_start}: must be a finite number")
    if not continuing:
        check_assembled(chain, theta0)
    if on_mechanism.ENABLED:  # the chain written as a mechanism, on the general engine (issue 24)
        return on_mechanism.simulate_on_mechanism(chain, theta0, omega0, settings, t_start)
    if METHODS[settings.method].reduced:
        # scipy boundary: the reduced model integrates with scipy, imported only when asked for.
        from .reduced_adapter import simulate_reduced_trajectory  # noqa: PLC0415

        return simulate_reduced_trajectory(chain, theta0.copy(), omega0.copy(), settings, t_start)
    compiled = load_compiled(settings.method, n, chain.pinned)
    bars = chain_arrays(chain)
    params = bars.params_with(settings.damping)
    alpha, beta, project = stabilization_gains(chain, settings)
    t_eval = sample_times(t_start, settings.t_end, settings.samples)
    if settings.backend != SCIPY and settings.integrator in ONE_BUFFER_METHODS and ONE_BUFFER:
        trajectory = _run_in_one_buffer(chain, bars, settings, compiled, y0, t_eval, params, alpha, beta, project)
        return trajectory
    if settings.backend == SCIPY:
        # scipy boundary: scipy's integrators are imported only for this back end.
        from .scipy_backend import integrate_scipy  # noqa: PLC0415

        y_out, cond, status, n_steps, n_rhs, t_reached, detail = integrate_scipy(
            compiled, y0, t_eval, params, settings, alpha, beta, project
        )
    else:
        y_out, cond, status, n_steps, n_rhs, t_reached = _integrate_compiled(
            compiled, y0, t_eval, params, settings, alpha, beta, project
        )
        detail = _compiled_detail(settings, status)
    filled = _finite_rows(y_out)
    if status == Status.OK and filled < len(t_eval):
        status = Status.NOT_FINITE
    trajectory = build_trajectory(
        chain, settings, compiled, params, t_eval[:filled], y_out[:filled], cond[:filled] if cond.size else None,
        alpha, beta,
    )
    trajectory.status = status
    trajectory.message = _OK_MESSAGE if status == Status.OK and not detail else status_message(status, t_reached, detail)
    trajectory.n_steps = int(n_steps)
    trajectory.n_rhs = int(n_rhs)
    trajectory.stats["t_reached"] = t_reached  # where the integrator stopped (the CLI's estimate of a long run)
    return trajectory


# The compiled RK45 and DOP853 runs take the one-buffer path (physics.codegen.native_run): the driver and the
# samples' pass in one array, the same functions and bits as the path through build_trajectory, which every other
# run takes (ONE_BUFFER = False sends these there too: tests compare the two).
ONE_BUFFER_METHODS = {"RK45": "RK45", "DOP853": "DOP853"}
ONE_BUFFER = True


def _run_in_one_buffer(chain, bars, settings, compiled, y0, t_eval, params, alpha, beta, project) -> Trajectory:
    """A compiled RK45/DOP853 run of a chain by :func:`physics.codegen.native_run.integrate_and_sample`: the
    system's specialised driver and samples' pass when it has them (``CompiledSystem``'s rules), else the
    generic ones; the Trajectory from the buffer's views."""
    method = ONE_BUFFER_METHODS[settings.integrator]
    trace = trace_point(chain, settings, bars)
    layout = compiled.integration_layout
    driver, samples_pass = compiled.run_functions(method)
    status, n_steps, n_rhs, t_reached, t, _, arrays = native_run.integrate_and_sample(
        driver, samples_pass, compiled.assemble_function, layout, compiled.layout, y0, t_eval, params,
        settings.rtol, settings.atol, alpha, beta, project, settings.max_steps, bars.bars, bars.g, trace.bar - 1,
        float(trace.along), float(trace.across), compiled.theta_ddot_index,
        compiled.tip_reaction_index if chain.pinned else (), method)
    if status == Status.OK and len(t) < len(t_eval):
        status = Status.NOT_FINITE
    trajectory = trajectory_from_samples(chain, settings, compiled, params, t, arrays)
    trajectory.status = status
    trajectory.message = _OK_MESSAGE if status == Status.OK else status_message(status, t_reached)
    trajectory.n_steps = n_steps
    trajectory.n_rhs = n_rhs
    trajectory.stats["t_reached"] = t_reached
    return trajectory


def _finite_rows(y_out: np.ndarray) -> int:
    """How many rows of ``y_out`` are finite throughout: all of them when their sum is finite (one pass), else
    counted row by row."""
    if math.isfinite(float(y_out.sum())):
        return len(y_out)
    return int(np.count_nonzero(np.all(np.isfinite(y_out), axis=1)))


def _integrate_compiled(compiled, y0, t_eval, params, settings, alpha, beta, project):
    y_out = np.empty((len(t_eval), y0.size))  # every kernel and IR driver fills it with NaN first
    cond = np.empty(0)  # computed with the reactions in build_trajectory, once per sample
    t0, t1 = float(t_eval[0]), float(t_eval[-1])
    spec = INTEGRATORS[settings.integrator]
    assert spec.kernel is not None, spec.name  # Settings sends only compiled-capable integrators here
    integrate = getattr(compiled, spec.kernel)
    if spec.needs_lagrangian:
        result = integrate(y0, t0, t1, settings.step, t_eval, params, y_out, cond)
    elif spec.fixed_step:
        result = integrate(y0, t0, t1, settings.step, t_eval, params, alpha, beta, project, y_out, cond)
    else:
        result = integrate(
            y0, t0, t1, t_eval, params, settings.rtol, settings.atol, alpha, beta, project,
            settings.max_steps, y_out, cond,
        )
    status, n_steps, n_rhs, t_reached = result[:4]
    return y_out, cond, int(status), n_steps, n_rhs, float(t_reached)


def _compiled_detail(settings, status: int) -> str:
    if status == Status.INTEGRATOR_FAILED and INTEGRATORS[settings.integrator].fixed_step:
        return f"the {settings.integrator} integrator's Newton iteration did not converge; reduce the step (--step)"
    return ""
