"""Fixed-step implicit midpoint rule in ``(theta, omega)``, and the helpers every fixed-step kernel shares."""

import numpy as np
from numba import njit

from . import disk_cache  # noqa: F401  (numba's cache locator, before any kernel here is defined)
from .arrays import copy_row
from .common import (
    check_arguments,
    fixed_steps,
    hermite_sample,
    initial_samples,
    ode_rhs,
    sample_condition,
    start_rhs,
    step_status,
)
from .constants import (
    FD_RELATIVE_STEP,
    MIDPOINT_MAX_HALVINGS,
    NEWTON_MAX_ITERATIONS,
    NEWTON_TOLERANCE,
    STATUS_INTEGRATOR_FAILED,
    STATUS_NOT_FINITE,
    STATUS_OK,
)
from .linear import lu_factor, lu_factor_solve
from .projection import project_state
from .system import has_constraints, make_system


@njit(cache=True, error_model="numpy", nogil=True)
def hermite_samples(
    system,
    i_sample,
    t,
    t_new,
    y,
    f,
    y_next,
    f_next,
    t_eval,
    params,
    alpha,
    beta,
    project,
    y_sample,
    theta,
    omega,
    theta_ddot,
    y_out,
    cond_out,
):
    """Fill the samples in ``(t, t_new]`` from the cubic Hermite interpolant of a fixed step (projected onto the
    loop when ``project``); returns the next sample's index."""
    while i_sample < t_eval.shape[0] and t_eval[i_sample] <= t_new:
        s = (t_eval[i_sample] - t) / (t_new - t)
        hermite_sample(s, t_new - t, y, f, y_next, f_next, y_sample)
        if project:
            project_state(system, t_eval[i_sample], y_sample, params, theta, omega)
        copy_row(y_sample, y_out, i_sample)
        if cond_out.shape[0]:
            cond_out[i_sample] = sample_condition(system, t_eval[i_sample], y_sample, params, alpha, beta, theta,
                                                  omega, theta_ddot)
        i_sample += 1
    return i_sample


@njit(cache=True, error_model="numpy", nogil=True)
def _midpoint_step(system, t, t_new, step, y, f, y_next, f_next, y_mid, f_mid, y_probe, f_probe, correction, newton_matrix,
                   pivots, params, alpha, beta, projecting, theta, omega, theta_ddot, n, n_state):
    """One implicit midpoint step from ``(t, y)`` (``f = f(t, y)``) to ``t_new``: ``y_next`` and ``f_next``.

    Returns ``(status, right-hand-side evaluations, converged)``: STATUS_INTEGRATOR_FAILED when the Newton matrix
    is singular, STATUS_NOT_FINITE when a correction overflows, the right-hand side's status when it fails."""
    n_rhs = 0
    # Newton matrix I - (step/2) df/dy; df/dy = [[0, I], [d theta_ddot / d theta, d theta_ddot / d omega]].
    for i in range(n_state):
        for j in range(n_state):
            newton_matrix[i, j] = 0.0
        newton_matrix[i, i] = 1.0
    for i in range(n):
        newton_matrix[i, n + i] = -0.5 * step
    for j in range(n_state):
        for i in range(n_state):
            y_probe[i] = y[i]
        y_probe[j] = y[j] + FD_RELATIVE_STEP * max(1.0, abs(y[j]))
        delta = y_probe[j] - y[j]
        status, _ = ode_rhs(system, t, y_probe, params, alpha, beta, theta, omega, theta_ddot, f_probe)
        n_rhs += 1
        if status != STATUS_OK:
            return status, n_rhs, False
        for i in range(n):
            newton_matrix[n + i, j] -= 0.5 * step * (f_probe[n + i] - f[n + i]) / delta
    if not lu_factor(newton_matrix, pivots):
        return STATUS_INTEGRATOR_FAILED, n_rhs, False
    # Explicit Euler predictor, then y1 <- y1 - M^-1 (y1 - y0 - step f((y0 + y1)/2)).
    for i in range(n_state):
        y_next[i] = y[i] + step * f[i]
    converged = False
    status = STATUS_OK
    for iteration in range(NEWTON_MAX_ITERATIONS):
        for i in range(n_state):
            y_mid[i] = 0.5 * (y[i] + y_next[i])
        status, _ = ode_rhs(system, 0.5 * (t + t_new), y_mid, params, alpha, beta, theta, omega, theta_ddot, f_mid)
        n_rhs += 1
        if status != STATUS_OK:
            return status, n_rhs, False
        for i in range(n_state):
            correction[i] = -(y_next[i] - y[i] - step * f_mid[i])
        lu_factor_solve(newton_matrix, pivots, correction)
        largest = 0.0
        for i in range(n_state):
            y_next[i] += correction[i]
            relative = abs(correction[i]) / (1.0 + abs(y_next[i]))
            if not relative <= largest:
                largest = relative
        if not np.isfinite(largest):
            return STATUS_NOT_FINITE, n_rhs, False
        if largest <= NEWTON_TOLERANCE:
            converged = True
            break
    if not converged:
        return STATUS_OK, n_rhs, False
    if projecting and not project_state(system, t_new, y_next, params, theta, omega):
        return STATUS_NOT_FINITE, n_rhs, False
    status, _ = ode_rhs(system, t_new, y_next, params, alpha, beta, theta, omega, theta_ddot, f_next)
    n_rhs += 1
    if status == STATUS_OK:  # the constraints' geometric test, once per step (not at Newton's evaluations)
        status, _ = step_status(system, t_new, y_next, params, theta, omega)
    return status, n_rhs, True


@njit(cache=True, error_model="numpy", nogil=True)
def integrate_midpoint(assemble, layout, y0, t0, t_end, h, t_eval, params, alpha, beta, project, y_out, cond_out):
    """Fixed-step implicit midpoint rule ``y1 = y0 + h f((y0 + y1) / 2)``: symmetric, order 2.

    Applied to ``y = (theta, omega)`` it is symplectic only where ``omega`` is a constant multiple of the
    momentum (a single bar); for a chain use integrate_variational, which steps ``(theta, p)``.

    The interval is cut into ``N = ceil((t_end - t0) / h)`` equal steps (so the step is at most ``h``). Each step
    is solved by simplified Newton with a forward-difference Jacobian of the right-hand side refreshed at the start
    of the step, until every correction is below NEWTON_TOLERANCE relative. Samples come from the cubic Hermite
    interpolant between steps. Arguments and return value as integrate_rk45 (STATUS_INTEGRATOR_FAILED if Newton
    fails; n_rhs includes the Jacobian's evaluations).
    """
    check_arguments(layout, y0, t0, t_end, t_eval, params, y_out, cond_out)
    if not (h > 0.0 and h < np.inf):
        raise ValueError("h must be positive and finite")
    system = make_system(assemble, layout)
    params = params.copy()  # the integrator writes t into it
    projecting = has_constraints(system) and project
    n = y0.shape[0] // 2
    n_state = y0.shape[0]
    theta = np.empty(n)
    omega = np.empty(n)
    theta_ddot = np.empty(n)
    y = y0.copy()
    f = np.empty(n_state)
    y_next = np.empty(n_state)
    f_next = np.empty(n_state)
    y_mid = np.empty(n_state)
    f_mid = np.empty(n_state)
    y_probe = np.empty(n_state)
    f_probe = np.empty(n_state)
    correction = np.empty(n_state)
    newton_matrix = np.empty((n_state, n_state))
    pivots = np.empty(n_state, dtype=np.int64)
    y_out[:, :] = np.nan
    cond_out[:] = np.nan

    t = t0
    n_steps = 0
    n_rhs = 0
    if projecting and not project_state(system, t, y, params, theta, omega):
        return STATUS_NOT_FINITE, n_steps, n_rhs, t, 0
    status, condition = start_rhs(system, t, y, params, alpha, beta, theta, omega, theta_ddot, f)
    n_rhs += 1
    if status != STATUS_OK:
        return status, n_steps, n_rhs, t, 0
    i_sample = initial_samples(y, t0, t_eval, condition, y_out, cond_out)
    if t_end == t0:
        return STATUS_OK, n_steps, n_rhs, t, i_sample
    n_total, step = fixed_steps(t0, t_end, h)

    y_start = np.empty(n_state)
    f_start = np.empty(n_state)
    for k in range(n_total):
        t_target = t_end if k == n_total - 1 else t0 + (k + 1) * step
        # The step from t to t_target, cut into 2, 4, ... equal pieces when Newton's iteration fails on it (a stiff
        # step: a bar of almost no inertia), so every step stays at most h. A run that solves each step whole is
        # unchanged; one that still fails at MIDPOINT_MAX_HALVINGS stops as before.
        t_start = t
        i_start = i_sample
        for i in range(n_state):
            y_start[i] = y[i]
            f_start[i] = f[i]
        converged = False
        for halvings in range(MIDPOINT_MAX_HALVINGS + 1):
            pieces = 1 << halvings
            piece_step = step if pieces == 1 else (t_target - t_start) / pieces
            for piece in range(pieces):
                t_new = t_target if piece == pieces - 1 else t_start + (piece + 1) * piece_step
                status, added, converged = _midpoint_step(
                    system, t, t_new, piece_step, y, f, y_next, f_next, y_mid, f_mid, y_probe, f_probe, correction,
                    newton_matrix, pivots, params, alpha, beta, projecting, theta, omega, theta_ddot, n, n_state,
                )
                n_rhs += added
                if status != STATUS_OK or not converged:
                    break
                n_steps += 1
                i_sample = hermite_samples(
                    system,
                    i_sample,
                    t,
                    t_new,
                    y,
                    f,
                    y_next,
                    f_next,
                    t_eval,
                    params,
                    alpha,
                    beta,
                    projecting,
                    y_probe,
                    theta,
                    omega,
                    theta_ddot,
                    y_out,
                    cond_out,
                )
                for i in range(n_state):
                    y[i] = y_next[i]
                    f[i] = f_next[i]
                t = t_new
            newton_failed = status == STATUS_INTEGRATOR_FAILED or status == STATUS_NOT_FINITE or not converged
            if status == STATUS_OK and converged:
                break
            if not newton_failed or halvings == MIDPOINT_MAX_HALVINGS:
                break
            t = t_start  # again from the step's start, in twice as many pieces
            i_sample = i_start
            for i in range(n_state):
                y[i] = y_start[i]
                f[i] = f_start[i]
        if status == STATUS_OK and not converged:
            status = STATUS_INTEGRATOR_FAILED
        if status != STATUS_OK:
            y_out[i_sample:, :] = np.nan  # samples of an abandoned attempt beyond where the run stopped
            if cond_out.shape[0]:
                cond_out[i_sample:] = np.nan
            break

    return status, n_steps, n_rhs, t, i_sample
