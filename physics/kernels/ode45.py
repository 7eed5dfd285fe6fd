"""MATLAB's ``ode45`` as published, compiled like the other kernels: the integrator the seed report used.

The same Dormand-Prince 5(4) pair as RK45 (:mod:`physics.kernels.explicit_rk`, scipy's), with MATLAB's own
controller, first step, step limits, error norm and continuous extension. Each rule and where it is stated
(docs/integrators.md, "ode45", lists them with the same numbering):

1. Error norm (MATLAB documentation of ``odeset``, RelTol/AbsTol; ode45.m): the estimate ``E = h sum_r e_r K_r``
   measured in the max norm relative to ``max(|y|, |y_new|, threshold)``, ``threshold = AbsTol / RelTol``:
   ``err = |h| max_j |(K^T e)_j| / max(|y_j|, |y_new,j|, threshold)``; the step is accepted when
   ``err <= RelTol`` (Shampine & Reichelt 1997, Sec. 3 and 7; ode45.m). RelTol below ``100 eps`` is raised to
   it, as ode45 does.
2. ``MaxStep`` (odeset documentation): ``hmax = |tfinal - t0| / 10`` by default.
3. First step (ode45.m, after Shampine & Reichelt Sec. 3): ``absh = min(hmax, htspan)`` with ``htspan = |tspan(2)
   - tspan(1)|``; ``rh = ||f0 / max(|y0|, threshold)||_inf / (0.8 RelTol^(1/5))``; if ``absh rh > 1`` then
   ``absh = 1 / rh``; ``absh = max(absh, hmin)``.
4. Every step (ode45.m): ``hmin = 16 eps(t)``; ``absh = min(hmax, max(hmin, absh))``; when ``1.1 absh >=
   tfinal - t`` the step is stretched (or shrunk) to end exactly at tfinal.
5. A failed step (ode45.m; the paper: "reduce by at most a factor of 10 after a failure, halve after repeated
   failures"): at ``absh <= hmin`` the run stops (STATUS_STEP_TOO_SMALL); the first failure of a step sets
   ``absh = max(hmin, absh max(0.1, 0.8 (RelTol / err)^(1/5)))``, each later one ``absh = max(hmin, absh / 2)``.
6. After an accepted step that had no failure (ode45.m; the paper: "increase by at most a factor of 5"):
   ``absh = absh min(5, 0.8 (RelTol / err)^(1/5))`` (written there as ``temp = 1.25 (err/rtol)^(1/5)``,
   ``absh / temp`` if ``temp > 0.2`` else ``5 absh``); after a step that had a failure, h is not increased.
7. Output (ode45.m and ntrp45.m; ``Refine`` in the odeset documentation): when ``tspan`` has more than two
   entries the solution is given at those times only, by the continuous extension ``ntrp45`` (a quartic in
   ``s``, :data:`physics.kernels.tables.ODE45_BI`), and at a tspan point that is a step's end by ``y_new`` itself.
   With two entries, ``Refine = 4`` outputs per step: ``ntrp45`` at ``t + h k / 4``, ``k = 1, 2, 3``, and
   ``y_new`` (:func:`integrate_ode45_refined`).

Not MATLAB's (the project's additions, as for RK45): projection of pinned chains onto their loop after every
accepted step and every sample (with a fresh derivative after each projected step, so first-same-as-last is
kept on the projected state), Baumgarte gains through the right-hand side, ``max_steps``, and the status codes
instead of warnings. MATLAB's ``NonNegative``, ``Events``, ``Mass`` and ``NormControl`` options are not offered.

Arguments and return value as :func:`physics.kernels.explicit_rk.integrate_rk45`. The module is imported
(and so compiled, the first time, about as long as RK45's kernel) only when ode45 is asked for.
"""

import numpy as np
from numba import njit

from . import disk_cache  # noqa: F401  (numba's cache locator, before any kernel here is defined)
from .arrays import copy_row, stage_sum_into
from .common import check_arguments, initial_samples, ode_rhs, rhs_into, sample_condition, start_rhs, step_status
from .constants import STATUS_MAX_STEPS, STATUS_NOT_FINITE, STATUS_OK, STATUS_STEP_TOO_SMALL
from .projection import project_state
from .system import has_constraints, make_system
from .tables import ODE45_BI, ODE45_E, ODE45_ERROR_EXPONENT, ODE45_N_STAGES, RK45_A, RK45_B, RK45_C

EPSILON = 2.220446049250313e-16
MAX_STEP_FRACTION = 0.1  # rule 2: MaxStep = span / 10
STRETCH = 1.1  # rule 4: a step within 10 % of tfinal is stretched to reach it
SAFETY = 0.8  # rules 3, 5, 6
MAX_GROWTH = 5.0  # rule 6
MAX_SHRINK = 0.1  # rule 5, first failure
REPEATED_FAILURE_SHRINK = 0.5  # rule 5, later failures
HMIN_ULPS = 16.0  # rule 4: hmin = 16 eps(t)
DEFAULT_REFINE = 4  # rule 7


@njit(cache=True, error_model="numpy", nogil=True)
def _eps(t):
    """MATLAB's ``eps(t)``: the distance from |t| to the next larger double."""
    magnitude = abs(t)
    return np.nextafter(magnitude, np.inf) - magnitude


@njit(cache=True, error_model="numpy", nogil=True)
def ntrp45(s, h, y, K, y_sample):
    """ntrp45: ``y + h K^T BI [s, s^2, s^3, s^4]`` at fraction ``s`` of the step (rule 7)."""
    s2 = s * s
    s3 = s2 * s
    s4 = s3 * s
    for j in range(y.shape[0]):
        total = 0.0
        for r in range(ODE45_N_STAGES + 1):
            total += K[r, j] * (ODE45_BI[r, 0] * s + ODE45_BI[r, 1] * s2 + ODE45_BI[r, 2] * s3 + ODE45_BI[r, 3] * s4)
        y_sample[j] = y[j] + h * total


@njit(cache=True, error_model="numpy", nogil=True)
def _ode45(system, y0, t0, t_end, t_eval, htspan, refine, params, rtol, atol, alpha, beta, project, max_steps,
           t_out, y_out, cond_out):
    """The ode45 loop. ``refine == 0``: samples at ``t_eval`` into ``y_out`` (tspan of more than two entries);
    ``refine >= 1``: ``refine`` outputs per step into ``t_out``/``y_out`` (tspan = [t0, t_end]), row 0 = y0."""
    params = params.copy()  # the integrator writes t into it
    projecting = has_constraints(system) and project
    # The system's arrays one by one for the right-hand sides of the steps (common.rhs_into).
    assemble, layout, matrix, vector, unknowns = system[0], system[1], system[2], system[3], system[4]
    col_scale, jacobian, constraint_vector = system[5], system[6], system[7]
    n = y0.shape[0] // 2
    n_state = y0.shape[0]
    refined = refine >= 1
    n_samples = y_out.shape[0] if refined else t_eval.shape[0]
    rtol = max(rtol, 100.0 * EPSILON)  # rule 1
    threshold = atol / rtol

    theta = np.empty(n)
    omega = np.empty(n)
    theta_ddot = np.empty(n)
    K = np.empty((ODE45_N_STAGES + 1, n_state))
    y = y0.copy()
    y_new = np.empty(n_state)
    y_stage = np.empty(n_state)
    y_out[:, :] = np.nan
    t_out[:] = np.nan
    if cond_out.shape[0]:
        cond_out[:] = np.nan

    t = t0
    n_steps = 0
    n_rhs = 0
    if projecting and not project_state(system, t, y, params, theta, omega):
        return STATUS_NOT_FINITE, n_steps, n_rhs, t, 0
    status, condition = start_rhs(system, t, y, params, alpha, beta, theta, omega, theta_ddot, K[0])
    n_rhs += 1
    if status != STATUS_OK:
        return status, n_steps, n_rhs, t, 0
    if refined:
        t_out[0] = t0
        copy_row(y, y_out, 0)
        i_sample = 1
    else:
        i_sample = initial_samples(y, t0, t_eval, condition, y_out, cond_out)
    span = t_end - t0
    if span == 0.0:
        return STATUS_OK, n_steps, n_rhs, t, i_sample

    hmax = MAX_STEP_FRACTION * span  # rule 2
    hmin = HMIN_ULPS * _eps(t)
    # Rule 3: the first step.
    absh = min(hmax, htspan)
    rh = 0.0
    for j in range(n_state):
        rh = max(rh, abs(K[0, j]) / max(abs(y[j]), threshold))
    rh /= SAFETY * rtol**ODE45_ERROR_EXPONENT
    if absh * rh > 1.0:
        absh = 1.0 / rh
    absh = max(absh, hmin)

    done = False
    while not done:
        if n_steps >= max_steps:
            status = STATUS_MAX_STEPS
            break
        # Rule 4.
        hmin = HMIN_ULPS * _eps(t)
        absh = min(hmax, max(hmin, absh))
        h = absh
        if STRETCH * absh >= abs(t_end - t):
            h = t_end - t
            absh = abs(h)
            done = True
        no_failure = True
        err = 0.0
        t_new = t
        while True:
            for s in range(1, ODE45_N_STAGES):
                stage_sum_into(y, h, K, RK45_A[s], s, y_stage)
                status, _ = rhs_into(assemble, layout, matrix, vector, unknowns, col_scale, jacobian,
                                     constraint_vector, t + RK45_C[s] * h, y_stage, params, alpha, beta, theta, omega,
                                     theta_ddot, K[s])
                n_rhs += 1
                if status != STATUS_OK:
                    break
            if status != STATUS_OK:
                break
            t_new = t + h * RK45_C[ODE45_N_STAGES - 1]
            if done:
                t_new = t_end
            h = t_new - t  # MATLAB's "purify h"
            stage_sum_into(y, h, K, RK45_B, ODE45_N_STAGES, y_new)
            status, _ = rhs_into(assemble, layout, matrix, vector, unknowns, col_scale, jacobian, constraint_vector,
                                 t_new, y_new, params, alpha, beta, theta, omega, theta_ddot, K[ODE45_N_STAGES])
            n_rhs += 1
            if status != STATUS_OK:
                break
            # Rule 1: the error in the max norm, relative to max(|y|, |y_new|, threshold).
            err = 0.0
            for j in range(n_state):
                estimate = 0.0
                for r in range(ODE45_N_STAGES + 1):
                    estimate += K[r, j] * ODE45_E[r]
                err = max(err, abs(estimate) / max(max(abs(y[j]), abs(y_new[j])), threshold))
            err *= absh
            if not np.isfinite(err):
                status = STATUS_NOT_FINITE
                break
            if err <= rtol:
                break
            # Rule 5: a failed step.
            if absh <= hmin:
                status = STATUS_STEP_TOO_SMALL
                break
            if no_failure:
                no_failure = False
                absh = max(hmin, absh * max(MAX_SHRINK, SAFETY * (rtol / err) ** ODE45_ERROR_EXPONENT))
            else:
                absh = max(hmin, REPEATED_FAILURE_SHRINK * absh)
            h = absh
            done = False
        if status != STATUS_OK:
            break
        # The constraints' geometric test, once per accepted step (not at its stages): a step that ends at a
        # singular pose is not taken, the run stops where it was.
        status, _ = step_status(system, t_new, y_new, params, theta, omega)
        if status != STATUS_OK:
            break
        n_steps += 1

        # Outputs of this step (rule 7), from the unprojected step as MATLAB's, each projected when projecting.
        if refined:
            for k in range(1, refine + 1):
                if i_sample >= n_samples:
                    break
                if k < refine:
                    t_out[i_sample] = t + h * (k / refine)
                    ntrp45(k / refine, h, y, K, y_stage)
                else:
                    t_out[i_sample] = t_new
                    for j in range(n_state):
                        y_stage[j] = y_new[j]
                if projecting:
                    project_state(system, t_out[i_sample], y_stage, params, theta, omega)
                copy_row(y_stage, y_out, i_sample)
                i_sample += 1
        else:
            while i_sample < n_samples and t_eval[i_sample] <= t_new:
                if t_eval[i_sample] == t_new:
                    for j in range(n_state):
                        y_stage[j] = y_new[j]
                else:
                    ntrp45((t_eval[i_sample] - t) / h, h, y, K, y_stage)
                if projecting:
                    project_state(system, t_eval[i_sample], y_stage, params, theta, omega)
                copy_row(y_stage, y_out, i_sample)
                if cond_out.shape[0]:
                    cond_out[i_sample] = sample_condition(system, t_eval[i_sample], y_stage, params, alpha, beta, theta, omega,
                                                          theta_ddot)
                i_sample += 1

        # Rule 6: grow only after a step without failure (err may be 0: then by 5).
        if no_failure and not done:
            temp = 1.25 * (err / rtol) ** ODE45_ERROR_EXPONENT
            if temp > 1.0 / MAX_GROWTH:
                absh = absh / temp
            else:
                absh = MAX_GROWTH * absh

        # The next state: y_new with f(y_new) (first same as last), or its projection with a fresh derivative.
        for j in range(n_state):
            y[j] = y_new[j]
            K[0, j] = K[ODE45_N_STAGES, j]
        t = t_new
        if projecting:
            if not project_state(system, t, y, params, theta, omega):
                status = STATUS_NOT_FINITE
                break
            status, _ = ode_rhs(system, t, y, params, alpha, beta, theta, omega, theta_ddot, K[0])
            n_rhs += 1
            if status != STATUS_OK:
                break
        if refined and i_sample >= n_samples and not done:
            status = STATUS_MAX_STEPS  # the output buffer is full: more steps than it was sized for
            break

    return status, n_steps, n_rhs, t, i_sample


@njit(cache=True, error_model="numpy", nogil=True)
def tspan_step(t0, t_end, t_eval):
    """MATLAB's ``htspan = |tspan(2) - tspan(1)|`` for ``tspan = t_eval`` (starting at t0), else the span."""
    if t_eval.shape[0] >= 2 and t_eval[0] == t0 and t_eval[1] > t0:
        return t_eval[1] - t_eval[0]
    return t_end - t0


@njit(cache=True, error_model="numpy", nogil=True)
def integrate_ode45(
    assemble, layout, y0, t0, t_end, t_eval, params, rtol, atol, alpha, beta, project, max_steps, y_out, cond_out
):
    """MATLAB's ``ode45(f, tspan, y0, odeset('RelTol', rtol, 'AbsTol', atol))`` with ``tspan = t_eval``: samples
    at ``t_eval`` by ntrp45; arguments and return value as ``integrate_rk45``."""
    system = make_system(assemble, layout)
    check_arguments(system[1], y0, t0, t_end, t_eval, params, y_out, cond_out)
    t_out = np.empty(0)
    return _ode45(system, y0, t0, t_end, t_eval, tspan_step(t0, t_end, t_eval), 0, params, rtol, atol, alpha, beta,
                  project, max_steps, t_out, y_out, cond_out)


@njit(cache=True, error_model="numpy", nogil=True)
def integrate_ode45_htspan(
    assemble, layout, y0, t0, t_end, t_eval, htspan, params, rtol, atol, alpha, beta, project, max_steps, y_out,
    cond_out
):
    """The steps of ``ode45(f, tspan, y0, ...)`` for a ``tspan`` whose first spacing is ``htspan`` (its only
    effect on the steps, rule 3), sampled at ``t_eval`` instead: how the seed report's runs on
    ``linspace(0, dur, 200)`` are read on a finer grid. Otherwise as ``integrate_ode45``."""
    system = make_system(assemble, layout)
    check_arguments(system[1], y0, t0, t_end, t_eval, params, y_out, cond_out)
    if not htspan > 0.0:
        raise ValueError("htspan must be positive")
    t_out = np.empty(0)
    return _ode45(system, y0, t0, t_end, t_eval, htspan, 0, params, rtol, atol, alpha, beta, project, max_steps,
                  t_out, y_out, cond_out)


@njit(cache=True, error_model="numpy", nogil=True)
def integrate_ode45_refined(assemble, layout, y0, t0, t_end, params, rtol, atol, alpha, beta, project, refine,
                            t_out, y_out):
    """``ode45(f, [t0 t_end], y0, odeset(..., 'Refine', refine))``: ``refine`` outputs per step (rule 7).

    ``t_out`` (R,) and ``y_out`` (R, 2n) receive row 0 = the start and then ``refine`` rows per step; a run
    that needs more than ``(R - 1) / refine`` steps stops with STATUS_MAX_STEPS. Returns ``(status, n_steps,
    n_rhs, t_reached, n_filled)``."""
    system = make_system(assemble, layout)
    empty = np.empty(0)
    check_arguments(system[1], y0, t0, t_end, empty, params, y_out[:0], empty)
    if refine < 1 or t_out.shape[0] != y_out.shape[0] or t_out.shape[0] < 1:
        raise ValueError("refine must be >= 1 and t_out, y_out must have the same number of rows (>= 1)")
    max_steps = (t_out.shape[0] - 1) // refine
    return _ode45(system, y0, t0, t_end, empty, t_end - t0, refine, params, rtol, atol, alpha, beta, project,
                  max_steps, t_out, y_out, empty)


def refined_rows(max_steps: int, refine: int = DEFAULT_REFINE) -> int:
    """Rows of ``t_out``/``y_out`` that hold the start and ``refine`` outputs for each of ``max_steps`` steps."""
    return 1 + refine * max_steps


__all__ = ["integrate_ode45", "integrate_ode45_htspan", "integrate_ode45_refined", "ntrp45", "refined_rows", "tspan_step"]
