"""scipy's ``solve_ivp`` RK45 and DOP853 reproduced step for step, compiled once for every mechanism."""

import math

import numpy as np
from numba import njit

from . import disk_cache  # noqa: F401  (numba's cache locator, before any kernel here is defined)
from .abi import LAYOUT_CONSTRAINTS
from .arrays import copy_row, stage_sum_into
from .common import (
    NOT_FUSED,
    check_arguments,
    fused_rhs,
    initial_samples,
    ode_rhs,
    rhs_into,
    rms_norm,
    sample_condition,
    start_rhs,
    step_status,
)
from .constants import (
    MAX_FACTOR,
    MIN_FACTOR,
    SAFETY,
    STATUS_MAX_STEPS,
    STATUS_NOT_FINITE,
    STATUS_OK,
    STATUS_STEP_TOO_SMALL,
)
from .first_compile import call_announced
from .projection import project_state
from .system import make_system
from .tables import (
    DOP853_A,
    DOP853_B,
    DOP853_C,
    DOP853_D,
    DOP853_E3,
    DOP853_E5,
    DOP853_ERROR_ORDER,
    DOP853_INTERPOLATOR_POWER,
    DOP853_N_STAGES,
    DOP853_N_STAGES_EXTENDED,
    RK45_A,
    RK45_B,
    RK45_C,
    RK45_E,
    RK45_ERROR_ORDER,
    RK45_N_STAGES,
    RK45_P,
)


@njit(cache=True, error_model="numpy", nogil=True)
def _rk_stages(assemble, layout, matrix, vector, unknowns, col_scale, jacobian, constraint_vector, t, y, h, A, C,
               n_stages, K, y_stage, params, alpha, beta, theta, omega, theta_ddot):
    """Stages 1 .. n_stages-1 into rows of ``K`` (row 0 holds f(y)); scipy's ``rk_step`` loop. The system's
    arrays come one by one (:func:`physics.kernels.common.rhs_into`).

    Returns ``(status, rhs_evaluations)``.
    """
    fusing = alpha == 0.0 and beta == 0.0
    for s in range(1, n_stages):
        stage_sum_into(y, h, K, A[s], s, y_stage)
        status = NOT_FUSED
        if fusing:  # the generated rhs inlined here: a call through rhs_into cost as much again
            status, _ = fused_rhs(layout, t + C[s] * h, y_stage, params, K[s])
        if status == NOT_FUSED:
            status, _ = rhs_into(assemble, layout, matrix, vector, unknowns, col_scale, jacobian, constraint_vector,
                                 t + C[s] * h, y_stage, params, alpha, beta, theta, omega, theta_ddot, K[s])
        if status != STATUS_OK:
            return status, s
    return STATUS_OK, n_stages - 1


@njit(cache=True, error_model="numpy", nogil=True)
def _rk45_sample(x, h, y_old, K, y_sample):
    """scipy's RkDenseOutput: ``y_old + h * (K^T P) [x, x^2, x^3, x^4]``."""
    n_state = y_old.shape[0]
    p0 = x
    p1 = p0 * x
    p2 = p1 * x
    p3 = p2 * x
    for j in range(n_state):
        q0 = 0.0
        q1 = 0.0
        q2 = 0.0
        q3 = 0.0
        for r in range(RK45_N_STAGES + 1):
            q0 += K[r, j] * RK45_P[r, 0]
            q1 += K[r, j] * RK45_P[r, 1]
            q2 += K[r, j] * RK45_P[r, 2]
            q3 += K[r, j] * RK45_P[r, 3]
        y_sample[j] = h * (q0 * p0 + q1 * p1 + q2 * p2 + q3 * p3) + y_old[j]


@njit(cache=True, error_model="numpy", nogil=True)
def _dop853_dense_coefficients(
    system, t_old, h, y_old, y_new, K, F, y_stage, params, alpha, beta, theta, omega, theta_ddot
):
    """scipy's DOP853 ``_dense_output_impl``: three extra stages into K[13:16], then the 7 rows of ``F``.

    ``K[12]`` must hold f(y_new) of the step. Returns ``(status, rhs_evaluations)``.
    """
    n_state = y_old.shape[0]
    evaluations = 0
    for s in range(DOP853_N_STAGES + 1, DOP853_N_STAGES_EXTENDED):
        stage_sum_into(y_old, h, K, DOP853_A[s], s, y_stage)
        status, _ = ode_rhs(
            system, t_old + DOP853_C[s] * h, y_stage, params, alpha, beta, theta, omega, theta_ddot, K[s]
        )
        evaluations += 1
        if status != STATUS_OK:
            return status, evaluations
    for j in range(n_state):
        delta_y = y_new[j] - y_old[j]
        f_old = K[0, j]
        f_new = K[DOP853_N_STAGES, j]
        F[0, j] = delta_y
        F[1, j] = h * f_old - delta_y
        F[2, j] = 2 * delta_y - h * (f_new + f_old)
        for row in range(DOP853_INTERPOLATOR_POWER - 3):
            total = 0.0
            for r in range(DOP853_N_STAGES_EXTENDED):
                total += DOP853_D[row, r] * K[r, j]
            F[3 + row, j] = h * total
    return STATUS_OK, evaluations


@njit(cache=True, error_model="numpy", nogil=True)
def _dop853_sample(x, y_old, F, y_sample):
    """scipy's Dop853DenseOutput: Horner-like product alternating factors ``x`` and ``1 - x``."""
    n_state = y_old.shape[0]
    for j in range(n_state):
        value = 0.0
        for i in range(DOP853_INTERPOLATOR_POWER):
            value += F[DOP853_INTERPOLATOR_POWER - 1 - i, j]
            if i % 2 == 0:
                value *= x
            else:
                value *= 1 - x
        y_sample[j] = value + y_old[j]


@njit(cache=True, error_model="numpy", nogil=True)
def _integrate_explicit_rk(
    assemble, layout, A, y0, t0, t_end, t_eval, params, rtol, atol, alpha, beta, projecting, max_steps, y_out,
    cond_out
):
    """Shared driver of integrate_rk45 and integrate_dop853: scipy's ``solve_ivp`` loop with ``t_eval``.

    The method is told by its tableau ``A`` (an argument, not a constant flag, so that numba compiles this
    function once for both methods). ``projecting`` is ``True`` or ``None`` (never ``False``): with ``None``
    numba prunes every ``projecting is not None`` branch before typing, so a run without projection (any open
    chain) compiles none of the projection's code, about a fifth of an empty-cache run.
    """
    system = make_system(assemble, layout)
    check_arguments(system[1], y0, t0, t_end, t_eval, params, y_out, cond_out)
    # The system's arrays one by one for the right-hand sides of the steps (common.rhs_into).
    matrix, vector, unknowns, col_scale = system[2], system[3], system[4], system[5]
    jacobian, constraint_vector = system[6], system[7]
    use_dop853 = A.shape[0] == DOP853_N_STAGES_EXTENDED
    params = params.copy()  # the integrator writes t into it
    n = y0.shape[0] // 2
    n_state = y0.shape[0]
    n_samples = t_eval.shape[0]
    if use_dop853:
        B = DOP853_B
        C = DOP853_C
        n_stages = DOP853_N_STAGES
        n_rows = DOP853_N_STAGES_EXTENDED
        error_exponent = -1.0 / (DOP853_ERROR_ORDER + 1)
        initial_step_exponent = 1.0 / (DOP853_ERROR_ORDER + 1)
    else:
        B = RK45_B
        C = RK45_C
        n_stages = RK45_N_STAGES
        n_rows = RK45_N_STAGES + 1
        error_exponent = -1.0 / (RK45_ERROR_ORDER + 1)
        initial_step_exponent = 1.0 / (RK45_ERROR_ORDER + 1)

    theta = np.empty(n)
    omega = np.empty(n)
    theta_ddot = np.empty(n)
    K = np.empty((n_rows, n_state))
    F = np.empty((DOP853_INTERPOLATOR_POWER, n_state))
    y = y0.copy()
    y_new = np.empty(n_state)
    y_next = np.empty(n_state)
    y_stage = np.empty(n_state)
    f = np.empty(n_state)
    f_next = np.empty(n_state)
    scale = np.empty(n_state)
    work = np.empty(n_state)
    y_out[:, :] = np.nan
    cond_out[:] = np.nan

    t = t0
    n_steps = 0
    n_rhs = 0
    if projecting is not None:
        if not project_state(system, t, y, params, theta, omega):
            return STATUS_NOT_FINITE, n_steps, n_rhs, t, 0
    status, condition = start_rhs(system, t, y, params, alpha, beta, theta, omega, theta_ddot, f)
    n_rhs += 1
    if status != STATUS_OK:
        return status, n_steps, n_rhs, t, 0
    # Samples at t0 are y0 itself: scipy's dense output of the first step returns y_old exactly there.
    i_sample = initial_samples(y, t0, t_eval, condition, y_out, cond_out)
    interval_length = abs(t_end - t0)
    if interval_length == 0.0:
        return STATUS_OK, n_steps, n_rhs, t, i_sample

    # scipy's select_initial_step (Hairer, Norsett & Wanner, Sec. II.4), direction +1, max_step inf.
    for j in range(n_state):
        scale[j] = atol + abs(y[j]) * rtol
    for j in range(n_state):
        work[j] = y[j] / scale[j]
    d0 = rms_norm(work)
    for j in range(n_state):
        work[j] = f[j] / scale[j]
    d1 = rms_norm(work)
    if d0 < 1e-5 or d1 < 1e-5:
        h0 = 1e-6
    else:
        h0 = 0.01 * d0 / d1
    h0 = min(h0, interval_length)
    for j in range(n_state):
        y_stage[j] = y[j] + h0 * f[j]
    status, _ = ode_rhs(system, t + h0, y_stage, params, alpha, beta, theta, omega, theta_ddot, f_next)
    n_rhs += 1
    if status != STATUS_OK:
        return status, n_steps, n_rhs, t, i_sample
    for j in range(n_state):
        work[j] = (f_next[j] - f[j]) / scale[j]
    d2 = rms_norm(work) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** initial_step_exponent
    h_abs = min(100 * h0, h1, interval_length)

    while t < t_end:
        if n_steps >= max_steps:
            status = STATUS_MAX_STEPS
            break
        # scipy's RungeKutta._step_impl
        min_step = 10 * abs(np.nextafter(t, np.inf) - t)
        if h_abs < min_step:
            h_abs = min_step
        step_rejected = False
        t_new = t
        h = 0.0
        while True:
            if h_abs < min_step:
                status = STATUS_STEP_TOO_SMALL
                break
            t_new = t + h_abs
            if t_new - t_end > 0:
                t_new = t_end
            h = t_new - t
            h_abs = abs(h)
            for j in range(n_state):
                K[0, j] = f[j]
            status, evaluations = _rk_stages(
                assemble, layout, matrix, vector, unknowns, col_scale, jacobian, constraint_vector, t, y, h, A, C,
                n_stages, K, y_stage, params, alpha, beta, theta, omega, theta_ddot
            )
            n_rhs += evaluations
            if status != STATUS_OK:
                break
            stage_sum_into(y, h, K, B, n_stages, y_new)
            status = NOT_FUSED
            if alpha == 0.0 and beta == 0.0:
                status, _ = fused_rhs(layout, t_new, y_new, params, K[n_stages])
            if status == NOT_FUSED:
                status, _ = rhs_into(assemble, layout, matrix, vector, unknowns, col_scale, jacobian,
                                     constraint_vector, t_new, y_new, params, alpha, beta, theta, omega, theta_ddot,
                                     K[n_stages])
            n_rhs += 1
            if status != STATUS_OK:
                break
            for j in range(n_state):
                scale[j] = atol + max(abs(y[j]), abs(y_new[j])) * rtol
            if use_dop853:
                err5_norm_2 = 0.0
                err3_norm_2 = 0.0
                for j in range(n_state):
                    err5 = 0.0
                    err3 = 0.0
                    for r in range(n_stages + 1):
                        err5 += K[r, j] * DOP853_E5[r]
                        err3 += K[r, j] * DOP853_E3[r]
                    err5 /= scale[j]
                    err3 /= scale[j]
                    err5_norm_2 += err5 * err5
                    err3_norm_2 += err3 * err3
                if err5_norm_2 == 0 and err3_norm_2 == 0:
                    error_norm = 0.0
                else:
                    denominator = err5_norm_2 + 0.01 * err3_norm_2
                    error_norm = abs(h) * err5_norm_2 / math.sqrt(denominator * n_state)
            else:
                for j in range(n_state):
                    total = 0.0
                    for r in range(n_stages + 1):
                        total += K[r, j] * RK45_E[r]
                    work[j] = total * h / scale[j]
                error_norm = rms_norm(work)
            if not np.isfinite(error_norm):
                status = STATUS_NOT_FINITE
                break
            if error_norm < 1:
                if error_norm == 0:
                    factor = MAX_FACTOR
                else:
                    factor = min(MAX_FACTOR, SAFETY * error_norm**error_exponent)
                if step_rejected:
                    factor = min(1.0, factor)
                h_abs *= factor
                break
            h_abs *= max(MIN_FACTOR, SAFETY * error_norm**error_exponent)
            step_rejected = True
        if status != STATUS_OK:
            break
        # The constraints' geometric test, once per accepted step (not at its stages): a step that ends at a
        # singular pose is not taken, the run stops where it was.
        status, _ = step_status(system, t_new, y_new, params, theta, omega)
        if status != STATUS_OK:
            break

        # The next state: y_new itself (FSAL), or its projection with a fresh derivative.
        for j in range(n_state):
            y_next[j] = y_new[j]
            f_next[j] = K[n_stages, j]
        if projecting is not None:
            if not project_state(system, t_new, y_next, params, theta, omega):
                status = STATUS_NOT_FINITE
                break
            status, _ = ode_rhs(system, t_new, y_next, params, alpha, beta, theta, omega, theta_ddot, f_next)
            n_rhs += 1
            if status != STATUS_OK:
                break

        # Samples in (t, t_new] from the step's dense output, as solve_ivp does with t_eval.
        if i_sample < n_samples and t_eval[i_sample] <= t_new:
            if use_dop853:
                status, evaluations = _dop853_dense_coefficients(
                    system, t, h, y, y_new, K, F, y_stage, params, alpha, beta, theta, omega, theta_ddot
                )
                n_rhs += evaluations
                if status != STATUS_OK:
                    break
            while i_sample < n_samples and t_eval[i_sample] <= t_new:
                x = (t_eval[i_sample] - t) / h
                if use_dop853:
                    _dop853_sample(x, y, F, y_stage)
                else:
                    _rk45_sample(x, h, y, K, y_stage)
                if projecting is not None:
                    project_state(system, t_eval[i_sample], y_stage, params, theta, omega)
                copy_row(y_stage, y_out, i_sample)
                if cond_out.shape[0]:  # (0,) = the caller computes it with the reactions, once
                    cond_out[i_sample] = sample_condition(
                        system, t_eval[i_sample], y_stage, params, alpha, beta, theta, omega, theta_ddot
                    )
                i_sample += 1

        for j in range(n_state):
            y[j] = y_next[j]
            f[j] = f_next[j]
        t = t_new
        n_steps += 1

    # Samples are written only with the state they follow, so n_filled == count(t_eval <= t_reached).
    return status, n_steps, n_rhs, t, i_sample


def _projecting(layout, project):
    """``True`` when the run projects (asked for, and the mechanism holds constraints), else ``None``: the
    argument's type then selects the driver's compiled variant (see :func:`_integrate_explicit_rk`)."""
    return True if project and layout[LAYOUT_CONSTRAINTS] != 0 else None


def integrate_rk45(
    assemble, layout, y0, t0, t_end, t_eval, params, rtol, atol, alpha, beta, project, max_steps, y_out, cond_out
):
    """Dormand-Prince 5(4) exactly as scipy's ``solve_ivp(method="RK45")``, samples at ``t_eval``.

    y0 (2n,) initial ``[theta, omega]``; t_eval (T,) sorted within [t0, t_end]; y_out (T, 2n) and cond_out (T,) are
    filled with the sampled states and accel's condition estimate there. alpha, beta are passed to accel (Baumgarte
    gains); project (pinned chains only) projects every accepted step and every sample onto the loop constraint.
    Returns ``(status, n_steps, n_rhs, t_reached, n_filled)`` (see the module docstring).

    A plain function choosing the compiled driver's variant: numba compiles only what the run calls.
    """
    arguments = (assemble, layout, RK45_A, y0, t0, t_end, t_eval, params, rtol, atol, alpha, beta,
                 _projecting(layout, project), max_steps, y_out, cond_out)
    return call_announced(_integrate_explicit_rk, arguments, "RK45")


def integrate_dop853(
    assemble, layout, y0, t0, t_end, t_eval, params, rtol, atol, alpha, beta, project, max_steps, y_out, cond_out
):
    """Dormand-Prince 8(5,3) exactly as scipy's ``solve_ivp(method="DOP853")``; arguments as integrate_rk45."""
    arguments = (assemble, layout, DOP853_A, y0, t0, t_end, t_eval, params, rtol, atol, alpha, beta,
                 _projecting(layout, project), max_steps, y_out, cond_out)
    return call_announced(_integrate_explicit_rk, arguments, "DOP853")
