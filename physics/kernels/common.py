"""Small helpers of every integrator: the ODE right-hand side through the mechanism's system, norms, checks.

A closed loop's geometric singularity (the constraints' Jacobian losing rank: a dead centre, a change point) is
judged once per accepted step (:func:`step_status`) and at the start (:func:`start_rhs`), not at every stage
(:func:`ode_rhs`): building ``J J^T`` and factoring it costs about as much as the stage's whole solve, and the
stages of a step lie between its two ends. A stage's own solve still reports a singular or non-finite system."""

import math

import numpy as np
from numba import njit

from . import checks, disk_cache  # noqa: F401  (disk_cache: numba's cache locator, before any kernel here is defined)
from .abi import (
    LAYOUT_ACCELERATION,
    LAYOUT_COORDINATES,
    LAYOUT_RHS,
    LAYOUT_TIME,
    call_native_ratio,
    data_pointer,
)
from .arrays import copy_row
from .constants import RESCALE_ABOVE, SINGULAR_PIVOT_RATIO, STATUS_NOT_FINITE, STATUS_OK, STATUS_SINGULAR
from .system import constraint_ratio, has_constraints, load_state, solve_accel, unknowns_into

# fused_rhs's status when the generated rhs could not answer (none, or its pivot ratio asks for the fallback).
NOT_FUSED = 1


@njit(cache=True, error_model="numpy", nogil=True, inline="always")
def fused_rhs(layout, t, y, params, dydt):
    """``dydt`` at ``(t, y)`` by the generated ``rhs`` alone (no Baumgarte terms): ``(status, ratio)``, or
    ``(NOT_FUSED, ratio)`` when there is no generated ``rhs`` or its pivot ratio is above RESCALE_ABOVE (then
    :func:`rhs_into` evaluates the state again by the general path).

    Inlined where it is called (numba's ``inline="always"``): the integrators' stages call it directly, since a
    call through :func:`rhs_into`'s seventeen arguments cost as much again as the generated function itself
    (a micro-benchmark over a six-bar's states: 0.42 to 0.56 us a call, 0.23 us inlined)."""
    fused = layout[LAYOUT_RHS]
    if fused == 0:
        return NOT_FUSED, 0.0
    slot = layout[LAYOUT_TIME]
    if slot >= 0:
        params[slot] = t
    ratio = call_native_ratio(fused, data_pointer(y), data_pointer(params), data_pointer(dydt))
    if not ratio <= RESCALE_ABOVE:
        return NOT_FUSED, ratio
    n = layout[LAYOUT_COORDINATES]
    for i in range(n):
        if not np.isfinite(dydt[n + i]):
            return STATUS_NOT_FINITE, ratio
    return STATUS_OK, ratio


@njit(cache=True, error_model="numpy", nogil=True)
def rhs_into(assemble, layout, A, b, x, col_scale, J, v, t, y, params, alpha, beta, theta, omega, theta_ddot, dydt):
    """:func:`ode_rhs` with the system's arrays one by one (the first eight entries of the system tuple, in
    order): what an integrator's inner loop calls, since handing the tuple down costs more than the solve
    (:func:`physics.kernels.system.unknowns_into`).

    Without Baumgarte terms, a mechanism with a generated ``rhs`` (assemble and the structured solve fused,
    :mod:`physics.kernels.abi`) is evaluated by that one call: the same numbers as assembling and solving
    through memory, at half the cost for a six-bar (a micro-benchmark over the states of a run: about 0.42
    against 0.85 us a call, most of the difference being the zeroing, storing and loading of its 29 x 29 matrix
    and the calls between). Where its pivot ratio asks for the equilibrated fallback, the general path below
    evaluates the state again, as before. ``theta``, ``omega`` and ``theta_ddot`` are then not written."""
    if alpha == 0.0 and beta == 0.0:
        status, ratio = fused_rhs(layout, t, y, params, dydt)
        if status != NOT_FUSED:
            return status, ratio
    load_state(layout, params, t, y, theta, omega)
    n = theta.shape[0]
    condition = unknowns_into(assemble, layout, A, b, x, col_scale, J, v, theta, omega, params, alpha, beta)
    finite = condition == condition
    for i in range(n):
        theta_ddot[i] = x[layout[LAYOUT_ACCELERATION + i]]
        dydt[i] = omega[i]
        dydt[n + i] = theta_ddot[i]
        if not np.isfinite(theta_ddot[i]):
            finite = False
    if condition > SINGULAR_PIVOT_RATIO:
        return STATUS_SINGULAR, condition
    if not finite:
        return STATUS_NOT_FINITE, condition
    return STATUS_OK, condition


@njit(cache=True, error_model="numpy", nogil=True)
def ode_rhs(system, t, y, params, alpha, beta, theta, omega, theta_ddot, dydt):
    """Fill ``dydt = [omega, theta_ddot]`` at time ``t`` and state ``y``; return ``(status, condition)``, the
    condition being the solve's own (the geometric test is :func:`step_status`'s).

    ``theta, omega, theta_ddot`` are scratch arrays of shape ``(n,)``: accel always sees contiguous 1-D arrays.
    ``params`` is the integrator's own copy: ``t`` is written into its time slot (speed motors).
    """
    return rhs_into(system[0], system[1], system[2], system[3], system[4], system[5], system[6], system[7], t, y,
                    params, alpha, beta, theta, omega, theta_ddot, dydt)


@njit(cache=True, error_model="numpy", nogil=True)
def step_status(system, t, y, params, theta, omega):
    """The constraints' geometric test at the state ``y`` an integrator is about to accept: ``(STATUS_SINGULAR,
    ratio)`` when their Jacobian's condition estimate (:func:`physics.kernels.system.constraint_ratio`) is above
    SINGULAR_PIVOT_RATIO, else ``(STATUS_OK, ratio)``; ``(STATUS_OK, 1.0)`` without constraints. ``theta`` and
    ``omega`` are scratch (n,)."""
    if not has_constraints(system):
        return STATUS_OK, 1.0
    load_state(system[1], params, t, y, theta, omega)
    ratio = constraint_ratio(system, theta, omega, params)
    if ratio > SINGULAR_PIVOT_RATIO:
        return STATUS_SINGULAR, ratio
    return STATUS_OK, ratio


@njit(cache=True, error_model="numpy", nogil=True)
def start_rhs(system, t, y, params, alpha, beta, theta, omega, theta_ddot, dydt):
    """:func:`ode_rhs` at a run's start, with the geometric test of :func:`step_status`: a run released at a
    singular pose stops there. Returns ``(status, condition)``, the condition with the geometric test (as
    :func:`sample_condition`'s, for the samples at the start)."""
    status, condition = ode_rhs(system, t, y, params, alpha, beta, theta, omega, theta_ddot, dydt)
    if status == STATUS_SINGULAR or not all_finite(y):
        return status, condition
    geometric, ratio = step_status(system, t, y, params, theta, omega)
    condition = max(condition, ratio)
    if geometric != STATUS_OK:  # a singular pose is named as such even where the accelerations overflowed
        return geometric, condition
    return status, condition


@njit(cache=True, error_model="numpy", nogil=True)
def sample_condition(system, t, y, params, alpha, beta, theta, omega, theta_ddot):
    """Condition estimate of accel at time ``t`` and state ``y`` (the value stored in ``cond_out``), with the
    constraints' geometric test."""
    load_state(system[1], params, t, y, theta, omega)
    return solve_accel(system, theta, omega, params, alpha, beta, theta_ddot)


@njit(cache=True, error_model="numpy", nogil=True)
def all_finite(x):
    for i in range(x.shape[0]):
        if not np.isfinite(x[i]):
            return False
    return True


@njit(cache=True, error_model="numpy", nogil=True)
def rms_norm(x):
    """Root-mean-square norm, scipy's ``common.norm``."""
    total = 0.0
    for i in range(x.shape[0]):
        total += x[i] * x[i]
    return math.sqrt(total) / math.sqrt(x.shape[0])


# compiled from the plain function the IR drivers also run (one check, one set of messages)
check_arguments = njit(cache=True, error_model="numpy", nogil=True)(checks.check_arguments)


@njit(cache=True, error_model="numpy", nogil=True)
def hermite_sample(s, h, y_old, f_old, y_new, f_new, y_sample):
    """Cubic Hermite interpolant at fraction ``s`` of a step of length ``h``."""
    s2 = s * s
    s3 = s2 * s
    h00 = 2 * s3 - 3 * s2 + 1
    h10 = s3 - 2 * s2 + s
    h01 = -2 * s3 + 3 * s2
    h11 = s3 - s2
    for j in range(y_old.shape[0]):
        y_sample[j] = h00 * y_old[j] + h10 * h * f_old[j] + h01 * y_new[j] + h11 * h * f_new[j]


@njit(cache=True, error_model="numpy", nogil=True)
def initial_samples(y, t0, t_eval, condition, y_out, cond_out):
    """Write the start state into every sample at or before ``t0``; returns the next sample's index."""
    i_sample = 0
    while i_sample < t_eval.shape[0] and t_eval[i_sample] <= t0:
        copy_row(y, y_out, i_sample)
        if cond_out.shape[0]:
            cond_out[i_sample] = condition
        i_sample += 1
    return i_sample


@njit(cache=True, error_model="numpy", nogil=True)
def fixed_steps(t0, t_end, h):
    """``N = ceil((t_end - t0) / h)`` equal steps (so the step is at most ``h``): ``(N, step)``."""
    n_total = max(1, int(math.ceil((t_end - t0) / h * (1.0 - 1e-12))))
    return n_total, (t_end - t0) / n_total
