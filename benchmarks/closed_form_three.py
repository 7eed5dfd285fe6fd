"""The fastest plain seed case C: a closed-form Dormand-Prince written for three bars only.

    python -m benchmarks.closed_form            # times it beside the generic n-bar version and physics.simulate

:mod:`benchmarks.closed_form` writes the compound-pendulum chain for any ``n`` (loops over ``n`` read at run
time, a Cholesky factorisation in loops). Written for exactly three bars, as one would for a single known
problem, the same arithmetic needs no loop bound read at run time: every loop runs over the constant 3 (or 6,
the state's size) so the compiler unrolls it, the 3 x 3 mass matrix is factored in closed form from scalars,
and the tableau's coefficients are constants folded into the code. The physics, the integrator (scipy's RK45
step for step: tableau, error norm, step-size controller, initial step, 10-ulp minimum step, quartic dense
output) and every result are the same as the generic version's; only the speed differs. Issue 25 measures
``physics.simulate`` against this one (target: within 1.5x).

Physics (docs/architecture.md's conventions, params ``[L_1..L_3, d_1..d_3, m_1..m_3, I_1..I_3, g, pin_x, pin_y,
damping]``, an open chain): ``M_jk = coupling_jk cos(theta_j - theta_k)``, ``force_j = -sum_k coupling_jk
sin(theta_j - theta_k) omega_k^2 - g moment_j sin(theta_j)`` minus the joints' damping; ``coupling`` and
``moment`` as in :mod:`benchmarks.closed_form`'s docstring.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .closed_form import (
    ERROR_EXPONENT,
    MAX_FACTOR,
    MAX_STEPS,
    MIN_FACTOR,
    SAFETY,
    STATUS_MAX_STEPS,
    STATUS_NOT_FINITE,
    STATUS_NOT_POSITIVE_DEFINITE,
    STATUS_OK,
    STATUS_STEP_TOO_SMALL,
)

N_BARS = 3
N_STATE = 6  # [theta_1..3, omega_1..3]

# Dormand-Prince 5(4), scipy.integrate._ivp.rk.RK45's tableau as scalars (numba folds globals into the code).
A21 = 1 / 5
A31, A32 = 3 / 40, 9 / 40
A41, A42, A43 = 44 / 45, -56 / 15, 32 / 9
A51, A52, A53, A54 = 19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729
A61, A62, A63, A64, A65 = 9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656
B1, B3, B4, B5, B6 = 35 / 384, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84
E1, E3, E4, E5, E6, E7 = -71 / 57600, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40
# Dense output (RK45_P's non-zero entries, rows = stages 1, 3..7; columns = powers x, x^2, x^3, x^4).
P1 = (1.0, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432)
P3 = (0.0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799)
P4 = (0.0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072)
P5 = (0.0, 127303824393 / 49829197408, -318862633887 / 49829197408, 701980252875 / 199316789632)
P6 = (0.0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844)
P7 = (0.0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423)


@njit(cache=True)
def three_bar_constants(params, constants):
    """The configuration-independent pieces into ``constants`` (11,): ``coupling`` 11, 22, 33, 12, 13, 23,
    ``moment`` 1, 2, 3, then ``g`` and the damping."""
    L1, L2 = params[0], params[1]
    d1, d2, d3 = params[3], params[4], params[5]
    m1, m2, m3 = params[6], params[7], params[8]
    tail3 = 0.0
    tail2 = m3
    tail1 = m2 + m3
    moment3 = m3 * d3 + params[2] * tail3
    moment2 = m2 * d2 + L2 * tail2
    moment1 = m1 * d1 + L1 * tail1
    constants[0] = params[9] + m1 * d1 * d1 + L1 * L1 * tail1
    constants[1] = params[10] + m2 * d2 * d2 + L2 * L2 * tail2
    constants[2] = params[11] + m3 * d3 * d3 + params[2] * params[2] * tail3
    constants[3] = L1 * moment2
    constants[4] = L1 * moment3
    constants[5] = L2 * moment3
    constants[6] = moment1
    constants[7] = moment2
    constants[8] = moment3
    constants[9] = params[12]
    constants[10] = params[15]


@njit(cache=True, inline="always")
def three_bar_derivative(y, constants, dydt):
    """``dydt = [omega, theta_ddot]`` at ``y``; False when the mass matrix is not positive definite."""
    c11, c22, c33 = constants[0], constants[1], constants[2]
    c12, c13, c23 = constants[3], constants[4], constants[5]
    moment1, moment2, moment3 = constants[6], constants[7], constants[8]
    g, damping = constants[9], constants[10]
    w1, w2, w3 = y[3], y[4], y[5]
    s1, c1 = math.sin(y[0]), math.cos(y[0])
    s2, c2 = math.sin(y[1]), math.cos(y[1])
    s3, c3 = math.sin(y[2]), math.cos(y[2])
    # sin and cos of theta_j - theta_k from those of the angles
    sin12 = s1 * c2 - c1 * s2
    sin13 = s1 * c3 - c1 * s3
    sin23 = s2 * c3 - c2 * s3
    m12 = c12 * (c1 * c2 + s1 * s2)
    m13 = c13 * (c1 * c3 + s1 * s3)
    m23 = c23 * (c2 * c3 + s2 * s3)
    f1 = -g * moment1 * s1 - c12 * sin12 * w2 * w2 - c13 * sin13 * w3 * w3
    f2 = -g * moment2 * s2 + c12 * sin12 * w1 * w1 - c23 * sin23 * w3 * w3
    f3 = -g * moment3 * s3 + c13 * sin13 * w1 * w1 + c23 * sin23 * w2 * w2
    if damping != 0.0:  # in the generic version's order: the joint below, then the joint above
        f1 = f1 - damping * w1
        f1 = f1 + damping * (w2 - w1)
        f2 = f2 - damping * (w2 - w1)
        f2 = f2 + damping * (w3 - w2)
        f3 = f3 - damping * (w3 - w2)
    # M = C C^T (C lower triangular), in closed form
    diagonal = c11
    if not diagonal > 0.0:
        return False
    l11 = math.sqrt(diagonal)
    l21 = m12 / l11
    l31 = m13 / l11
    diagonal = c22 - l21 * l21
    if not diagonal > 0.0:
        return False
    l22 = math.sqrt(diagonal)
    l32 = (m23 - l31 * l21) / l22
    diagonal = c33 - l31 * l31 - l32 * l32
    if not diagonal > 0.0:
        return False
    l33 = math.sqrt(diagonal)
    # C z = f, then C^T theta_ddot = z
    z1 = f1 / l11
    z2 = (f2 - l21 * z1) / l22
    z3 = (f3 - l31 * z1 - l32 * z2) / l33
    a3 = z3 / l33
    a2 = (z2 - l32 * a3) / l22
    a1 = (z1 - l21 * a2 - l31 * a3) / l11
    dydt[0] = w1
    dydt[1] = w2
    dydt[2] = w3
    dydt[3] = a1
    dydt[4] = a2
    dydt[5] = a3
    return True


@njit(cache=True, inline="always")
def _rms_norm6(values):
    total = 0.0
    for i in range(N_STATE):
        total += values[i] * values[i]
    return math.sqrt(total / N_STATE)


@njit(cache=True)
def integrate_three_bar(y0, t_eval, params, rtol, atol, max_steps, y_out):
    """scipy's RK45 from ``t_eval[0]`` to ``t_eval[-1]`` for the three-bar chain; the state at every ``t_eval``
    into ``y_out`` (T, 6). Returns ``(status, n_steps, n_rhs, t_reached)`` as the generic version does."""
    constants = np.empty(11)
    three_bar_constants(params, constants)
    t = t_eval[0]
    t_bound = t_eval[-1]
    n_samples = t_eval.size
    y = np.empty(N_STATE)
    y_new = np.empty(N_STATE)
    y_stage = np.empty(N_STATE)
    work = np.empty(N_STATE)
    f = np.empty(N_STATE)
    k2 = np.empty(N_STATE)
    k3 = np.empty(N_STATE)
    k4 = np.empty(N_STATE)
    k5 = np.empty(N_STATE)
    k6 = np.empty(N_STATE)
    k7 = np.empty(N_STATE)
    for i in range(N_STATE):
        y[i] = y0[i]
        y_out[0, i] = y[i]
    next_sample = 1
    n_steps = 0
    n_rhs = 1
    if not three_bar_derivative(y, constants, f):
        return STATUS_NOT_POSITIVE_DEFINITE, n_steps, n_rhs, t
    if t_bound == t:
        return STATUS_OK, n_steps, n_rhs, t

    # scipy's select_initial_step (max_step = inf, direction = +1).
    interval_length = t_bound - t
    for i in range(N_STATE):
        work[i] = y[i] / (atol + abs(y[i]) * rtol)
    d0 = _rms_norm6(work)
    for i in range(N_STATE):
        work[i] = f[i] / (atol + abs(y[i]) * rtol)
    d1 = _rms_norm6(work)
    if d0 < 1e-5 or d1 < 1e-5:
        h0 = 1e-6
    else:
        h0 = 0.01 * d0 / d1
    h0 = min(h0, interval_length)
    for i in range(N_STATE):
        y_stage[i] = y[i] + h0 * f[i]
    n_rhs += 1
    if not three_bar_derivative(y_stage, constants, k2):
        return STATUS_NOT_POSITIVE_DEFINITE, n_steps, n_rhs, t
    for i in range(N_STATE):
        work[i] = (k2[i] - f[i]) / (atol + abs(y[i]) * rtol)
    d2 = _rms_norm6(work) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / 5.0)
    h_abs = min(100.0 * h0, h1, interval_length)

    while t < t_bound:
        if n_steps >= max_steps:
            return STATUS_MAX_STEPS, n_steps, n_rhs, t
        min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
        h_abs = max(h_abs, min_step)
        rejected = False
        while True:
            if h_abs < min_step:
                return STATUS_STEP_TOO_SMALL, n_steps, n_rhs, t
            t_new = min(t + h_abs, t_bound)
            h = t_new - t
            h_abs = abs(h)
            # Stages 2..6 (stage 1 is f), each sum in the generic version's order (stage by stage).
            for i in range(N_STATE):
                y_stage[i] = y[i] + (f[i] * A21) * h
            if not three_bar_derivative(y_stage, constants, k2):
                return STATUS_NOT_POSITIVE_DEFINITE, n_steps, n_rhs + 1, t
            for i in range(N_STATE):
                y_stage[i] = y[i] + (f[i] * A31 + k2[i] * A32) * h
            if not three_bar_derivative(y_stage, constants, k3):
                return STATUS_NOT_POSITIVE_DEFINITE, n_steps, n_rhs + 2, t
            for i in range(N_STATE):
                y_stage[i] = y[i] + (f[i] * A41 + k2[i] * A42 + k3[i] * A43) * h
            if not three_bar_derivative(y_stage, constants, k4):
                return STATUS_NOT_POSITIVE_DEFINITE, n_steps, n_rhs + 3, t
            for i in range(N_STATE):
                y_stage[i] = y[i] + (f[i] * A51 + k2[i] * A52 + k3[i] * A53 + k4[i] * A54) * h
            if not three_bar_derivative(y_stage, constants, k5):
                return STATUS_NOT_POSITIVE_DEFINITE, n_steps, n_rhs + 4, t
            for i in range(N_STATE):
                y_stage[i] = y[i] + (f[i] * A61 + k2[i] * A62 + k3[i] * A63 + k4[i] * A64 + k5[i] * A65) * h
            if not three_bar_derivative(y_stage, constants, k6):
                return STATUS_NOT_POSITIVE_DEFINITE, n_steps, n_rhs + 5, t
            for i in range(N_STATE):
                y_new[i] = y[i] + h * (f[i] * B1 + k3[i] * B3 + k4[i] * B4 + k5[i] * B5 + k6[i] * B6)
            n_rhs += 6
            if not three_bar_derivative(y_new, constants, k7):
                return STATUS_NOT_POSITIVE_DEFINITE, n_steps, n_rhs, t
            for i in range(N_STATE):
                error = f[i] * E1 + k3[i] * E3 + k4[i] * E4 + k5[i] * E5 + k6[i] * E6 + k7[i] * E7
                work[i] = error * h / (atol + max(abs(y[i]), abs(y_new[i])) * rtol)
            error_norm = _rms_norm6(work)
            if not math.isfinite(error_norm):
                return STATUS_NOT_FINITE, n_steps, n_rhs, t
            if error_norm < 1.0:
                if error_norm == 0.0:
                    factor = MAX_FACTOR
                else:
                    factor = min(MAX_FACTOR, SAFETY * error_norm ** ERROR_EXPONENT)
                if rejected:
                    factor = min(1.0, factor)
                h_abs *= factor
                break
            h_abs *= max(MIN_FACTOR, SAFETY * error_norm ** ERROR_EXPONENT)
            rejected = True

        n_steps += 1
        # Samples in (t, t_new]: RK45's quartic interpolant on the accepted step.
        while next_sample < n_samples and t_eval[next_sample] <= t_new:
            x = (t_eval[next_sample] - t) / h
            x2 = x * x
            x3 = x2 * x
            x4 = x3 * x
            for i in range(N_STATE):
                q0 = f[i] * P1[0]
                q1 = f[i] * P1[1] + k3[i] * P3[1] + k4[i] * P4[1] + k5[i] * P5[1] + k6[i] * P6[1] + k7[i] * P7[1]
                q2 = f[i] * P1[2] + k3[i] * P3[2] + k4[i] * P4[2] + k5[i] * P5[2] + k6[i] * P6[2] + k7[i] * P7[2]
                q3 = f[i] * P1[3] + k3[i] * P3[3] + k4[i] * P4[3] + k5[i] * P5[3] + k6[i] * P6[3] + k7[i] * P7[3]
                y_out[next_sample, i] = y[i] + h * (q0 * x + q1 * x2 + q2 * x3 + q3 * x4)
            next_sample += 1
        t = t_new
        for i in range(N_STATE):
            y[i] = y_new[i]
            f[i] = k7[i]
    return STATUS_OK, n_steps, n_rhs, t


def _run(params, theta0, omega0, t_end, samples, rtol, atol):
    params = np.ascontiguousarray(params, dtype=np.float64)
    if params.size != 4 * N_BARS + 4:
        raise ValueError(f"params: {params.size} entries, a three-bar chain has {4 * N_BARS + 4}")
    y0 = np.concatenate([np.asarray(theta0, dtype=np.float64), np.asarray(omega0, dtype=np.float64)])
    if y0.size != N_STATE:
        raise ValueError(f"theta0 and omega0: {y0.size} entries together, a three-bar chain has {N_STATE}")
    t = np.linspace(0.0, float(t_end), int(samples))
    y = np.full((t.size, N_STATE), np.nan)
    status, n_steps, n_rhs, t_reached = integrate_three_bar(y0, t, params, rtol, atol, MAX_STEPS, y)
    if status != STATUS_OK:
        raise RuntimeError(f"three-bar closed-form Dormand-Prince failed with status {status} at t = {t_reached:.6g} s")
    return t, y, int(n_steps), int(n_rhs)


def simulate_three_bar(params, theta0, omega0, t_end, samples, rtol, atol) -> tuple[np.ndarray, np.ndarray]:
    """``(t, y)`` as :func:`benchmarks.closed_form.simulate_closed_form`, for a three-bar chain only."""
    t, y, _, _ = _run(params, theta0, omega0, t_end, samples, rtol, atol)
    return t, y


def run_with_counts(params, theta0, omega0, t_end, samples, rtol, atol):
    """``(t, y, n_steps, n_rhs)``: the run and its step counts (scipy's ``nfev`` for ``n_rhs``)."""
    return _run(params, theta0, omega0, t_end, samples, rtol, atol)
