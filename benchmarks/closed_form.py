"""Anchor for the BENCHMARKS.md targets "Seed case C within 2x of a hand-written closed-form numba Dormand-Prince"
(this generic n-bar version) and "within 1.5x of one written for three bars" (issue 25,
:mod:`benchmarks.closed_form_three`).

    python -m benchmarks.closed_form [--repeats N]

Nothing here comes from Linkage Lab's derivation or code generation: the right-hand side of an n-bar compound
pendulum chain is written by hand from first principles, and the integrator is a hand-written numba copy of
scipy's RK45 (Dormand-Prince 5(4)), so the pair is the fastest plain implementation of the seed's run that one
would write without a symbolic pipeline. ``physics.simulate`` is measured against it.

Physics (conventions of docs/architecture.md: theta absolute from the downward vertical, counter-clockwise
positive; params ``[L_1..L_n, d_1..d_n, m_1..m_n, I_1..I_n, g, pin_x, pin_y, damping]``; an open chain, so the pin
is ignored). With ``tail_mass_k = sum_{i>k} m_i`` and ``moment_k = m_k d_k + L_k tail_mass_k`` (first moment of
bars k..n about joint k-1, along bar k), the kinetic energy is ``T = 1/2 sum_jk coupling_jk cos(theta_j - theta_k)
omega_j omega_k`` with

    coupling_jj = I_j + m_j d_j^2 + L_j^2 tail_mass_j,      coupling_jk = L_j moment_k  (j < k, symmetric),

so the mass matrix is ``M_jk = coupling_jk cos(theta_j - theta_k)`` and Lagrange's equations read

    sum_k M_jk theta_ddot_k = - sum_k coupling_jk sin(theta_j - theta_k) omega_k^2 - g moment_j sin(theta_j)
                              - c (omega_j - omega_{j-1}) + c (omega_{j+1} - omega_j)     (omega_0 = 0; no j+1 term
                                                                                           for the last bar).

``M`` is symmetric positive definite; it is factored by a hand-written Cholesky decomposition.

Integrator: scipy.integrate.solve_ivp(method="RK45") reproduced step for step: the same tableau, error estimate
and RMS error norm, SAFETY 0.9, MIN_FACTOR 0.2, MAX_FACTOR 10, the step-size cap after a rejection, the same
initial step (scipy's select_initial_step), the 10-ulp minimum step, and output at ``t_eval`` through RK45's
fourth-order interpolant (RkDenseOutput with the P matrix). Its ``n_rhs`` therefore equals scipy's ``nfev``.

``time_case_c(repeats)`` times seed case C (triple pendulum, theta = (pi, pi/3, pi/3) at rest, RK45,
rtol = atol = 1e-6, 20 s, 200 samples) end to end, with this generic version and the three-bar one interleaved
with ``physics.simulate``, and checks the tip against ``physics.simulate`` (Lagrange, compiled RK45) over the
first 10 s (the motion is chaotic afterwards: the difference past 10 s is reported too).
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import statistics
import sys
import time

import numpy as np
from numba import njit

# Seed case C at the seed's settings.
CASE_C_PRESET = "triple-c"
CASE_C_RTOL = 1e-6
CASE_C_ATOL = 1e-6
CASE_C_T_END = 20.0
CASE_C_SAMPLES = 200
# The tip must agree with physics.simulate to this over the first AGREEMENT_WINDOW_S seconds (100 x atol: the two
# right-hand sides differ only by rounding, which the chaotic motion amplifies later on).
TIP_AGREEMENT = 1e-4
AGREEMENT_WINDOW_S = 10.0
DEFAULT_REPEATS = 21
MAX_STEPS = 10_000_000

STATUS_OK = 0
STATUS_STEP_TOO_SMALL = -1  # as scipy: the step fell below 10 ulp of t
STATUS_NOT_FINITE = -2
STATUS_MAX_STEPS = -3
STATUS_NOT_POSITIVE_DEFINITE = -4  # the mass matrix lost positive definiteness (a bar with no inertia)

# scipy.integrate._ivp.rk: step-size controller.
SAFETY = 0.9
MIN_FACTOR = 0.2
MAX_FACTOR = 10.0
ERROR_EXPONENT = -1.0 / 5.0  # -1 / (error estimator order 4 + 1)

# Dormand-Prince 5(4) tableau (scipy.integrate._ivp.rk.RK45).
RK45_C = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0])
RK45_A = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0],
    [1 / 5, 0.0, 0.0, 0.0, 0.0],
    [3 / 40, 9 / 40, 0.0, 0.0, 0.0],
    [44 / 45, -56 / 15, 32 / 9, 0.0, 0.0],
    [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0.0],
    [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656],
])
RK45_B = np.array([35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])
# Error weights over the six stages and the derivative at the new point (first-same-as-last).
RK45_E = np.array([-71 / 57600, 0.0, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40])
# Dense output: y(t_old + x h) = y_old + h * sum_j (K^T P)[:, j] x^(j+1), x in [0, 1].
RK45_P = np.array([
    [1.0, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
    [0.0, 0.0, 0.0, 0.0],
    [0.0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799],
    [0.0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072],
    [0.0, 127303824393 / 49829197408, -318862633887 / 49829197408, 701980252875 / 199316789632],
    [0.0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
    [0.0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423],
])
N_STAGES = 6


# ---------------------------------------------------------------------------------------------------------------
# Right-hand side, by hand


@njit(cache=True)
def chain_constants(params, n, coupling, moment):
    """Configuration-independent pieces: ``coupling`` (n, n) symmetric and ``moment`` (n,) (module docstring)."""
    tail_mass = 0.0  # sum of the masses of the bars beyond bar k
    for k in range(n - 1, -1, -1):
        L_k, d_k, m_k = params[k], params[n + k], params[2 * n + k]
        moment[k] = m_k * d_k + L_k * tail_mass
        coupling[k, k] = params[3 * n + k] + m_k * d_k * d_k + L_k * L_k * tail_mass
        tail_mass += m_k
    for j in range(n):
        for k in range(j + 1, n):
            coupling[j, k] = params[j] * moment[k]
            coupling[k, j] = coupling[j, k]


@njit(cache=True)
def theta_ddot_closed_form(theta, omega, params, coupling, moment, mass, force, sin_theta, cos_theta, theta_ddot):
    """Angular accelerations (written into ``theta_ddot``) of the open chain; returns False when the mass matrix
    is not positive definite. ``mass`` (n, n), ``force``, ``sin_theta``, ``cos_theta`` (n,) are work arrays."""
    n = theta.size
    g = params[4 * n]
    damping = params[4 * n + 3]
    for k in range(n):
        sin_theta[k] = math.sin(theta[k])
        cos_theta[k] = math.cos(theta[k])
    for j in range(n):
        mass[j, j] = coupling[j, j]
        total = -g * moment[j] * sin_theta[j]
        for k in range(n):
            if k == j:
                continue
            # sin(theta_j - theta_k) and cos(theta_j - theta_k) from the sines and cosines of the angles
            sin_jk = sin_theta[j] * cos_theta[k] - cos_theta[j] * sin_theta[k]
            if k > j:
                mass[j, k] = coupling[j, k] * (cos_theta[j] * cos_theta[k] + sin_theta[j] * sin_theta[k])
            total -= coupling[j, k] * sin_jk * omega[k] * omega[k]
        if damping != 0.0:
            relative = omega[j] - (omega[j - 1] if j > 0 else 0.0)
            total -= damping * relative
            if j + 1 < n:
                total += damping * (omega[j + 1] - omega[j])
        force[j] = total
    # Cholesky M = C C^T, C lower triangular, stored in the lower triangle of ``mass`` (upper triangle kept).
    for j in range(n):
        diagonal = mass[j, j]
        for k in range(j):
            diagonal -= mass[j, k] * mass[j, k]
        if not diagonal > 0.0:
            return False
        diagonal = math.sqrt(diagonal)
        mass[j, j] = diagonal
        for i in range(j + 1, n):
            value = mass[j, i]  # M_ij = M_ji, from the upper triangle
            for k in range(j):
                value -= mass[i, k] * mass[j, k]
            mass[i, j] = value / diagonal
    # C z = force, then C^T theta_ddot = z
    for i in range(n):
        value = force[i]
        for k in range(i):
            value -= mass[i, k] * theta_ddot[k]
        theta_ddot[i] = value / mass[i, i]
    for i in range(n - 1, -1, -1):
        value = theta_ddot[i]
        for k in range(i + 1, n):
            value -= mass[k, i] * theta_ddot[k]
        theta_ddot[i] = value / mass[i, i]
    return True


@njit(cache=True)
def state_derivative(y, params, coupling, moment, mass, force, sin_theta, cos_theta, dydt):
    """``dydt = [omega, theta_ddot]`` for ``y = [theta, omega]``; False when the mass matrix is singular."""
    n = y.size // 2
    for i in range(n):
        dydt[i] = y[n + i]
    return theta_ddot_closed_form(
        y[:n], y[n:], params, coupling, moment, mass, force, sin_theta, cos_theta, dydt[n:]
    )


# ---------------------------------------------------------------------------------------------------------------
# Dormand-Prince 5(4), by hand (scipy's RK45 step for step)


@njit(cache=True)
def rms_norm(values):
    total = 0.0
    for value in values:
        total += value * value
    return math.sqrt(total / values.size)


@njit(cache=True)
def integrate_dormand_prince(y0, t_eval, params, rtol, atol, max_steps, y_out):
    """Integrate ``y' = state_derivative(y)`` from ``t_eval[0]`` to ``t_eval[-1]`` (forward), writing the state
    at every ``t_eval`` into ``y_out`` (rows not reached stay as they were). Returns ``(status, n_steps, n_rhs,
    t_reached)``; ``n_rhs`` counts right-hand-side calls as scipy's ``nfev`` does."""
    dim = y0.size
    n = dim // 2
    coupling = np.empty((n, n))
    moment = np.empty(n)
    mass = np.empty((n, n))
    force = np.empty(n)
    sin_theta = np.empty(n)
    cos_theta = np.empty(n)
    chain_constants(params, n, coupling, moment)

    t = t_eval[0]
    t_bound = t_eval[-1]
    y = y0.copy()
    y_new = np.empty(dim)
    y_stage = np.empty(dim)
    scaled_error = np.empty(dim)
    stages = np.empty((N_STAGES + 1, dim))  # K: six stages, then the derivative at the new point
    f = np.empty(dim)
    dense = np.empty((dim, 4))  # Q = K^T P

    for i in range(dim):
        y_out[0, i] = y[i]
    next_sample = 1
    n_steps = 0
    n_rhs = 1
    if not state_derivative(y, params, coupling, moment, mass, force, sin_theta, cos_theta, f):
        return STATUS_NOT_POSITIVE_DEFINITE, n_steps, n_rhs, t
    if t_bound == t:
        return STATUS_OK, n_steps, n_rhs, t

    # Initial step: scipy.integrate._ivp.common.select_initial_step (max_step = inf, direction = +1).
    interval_length = t_bound - t
    for i in range(dim):
        scale = atol + abs(y[i]) * rtol
        scaled_error[i] = y[i] / scale
    d0 = rms_norm(scaled_error)
    for i in range(dim):
        scale = atol + abs(y[i]) * rtol
        scaled_error[i] = f[i] / scale
    d1 = rms_norm(scaled_error)
    if d0 < 1e-5 or d1 < 1e-5:
        h0 = 1e-6
    else:
        h0 = 0.01 * d0 / d1
    h0 = min(h0, interval_length)
    for i in range(dim):
        y_stage[i] = y[i] + h0 * f[i]
    n_rhs += 1
    if not state_derivative(y_stage, params, coupling, moment, mass, force, sin_theta, cos_theta, stages[0]):
        return STATUS_NOT_POSITIVE_DEFINITE, n_steps, n_rhs, t
    for i in range(dim):
        scale = atol + abs(y[i]) * rtol
        scaled_error[i] = (stages[0, i] - f[i]) / scale
    d2 = rms_norm(scaled_error) / h0
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

            for i in range(dim):
                stages[0, i] = f[i]
            for s in range(1, N_STAGES):
                for i in range(dim):
                    increment = 0.0
                    for r in range(s):
                        increment += stages[r, i] * RK45_A[s, r]
                    y_stage[i] = y[i] + increment * h
                n_rhs += 1
                if not state_derivative(
                    y_stage, params, coupling, moment, mass, force, sin_theta, cos_theta, stages[s]
                ):
                    return STATUS_NOT_POSITIVE_DEFINITE, n_steps, n_rhs, t
            for i in range(dim):
                increment = 0.0
                for r in range(N_STAGES):
                    increment += stages[r, i] * RK45_B[r]
                y_new[i] = y[i] + h * increment
            n_rhs += 1
            if not state_derivative(
                y_new, params, coupling, moment, mass, force, sin_theta, cos_theta, stages[N_STAGES]
            ):
                return STATUS_NOT_POSITIVE_DEFINITE, n_steps, n_rhs, t

            for i in range(dim):
                error = 0.0
                for r in range(N_STAGES + 1):
                    error += stages[r, i] * RK45_E[r]
                scale = atol + max(abs(y[i]), abs(y_new[i])) * rtol
                scaled_error[i] = error * h / scale
            error_norm = rms_norm(scaled_error)
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
        if next_sample < t_eval.size and t_eval[next_sample] <= t_new:
            for i in range(dim):
                for j in range(4):
                    value = 0.0
                    for r in range(N_STAGES + 1):
                        value += stages[r, i] * RK45_P[r, j]
                    dense[i, j] = value
            while next_sample < t_eval.size and t_eval[next_sample] <= t_new:
                x = (t_eval[next_sample] - t) / h
                power = x
                for i in range(dim):
                    y_out[next_sample, i] = 0.0
                for j in range(4):
                    for i in range(dim):
                        y_out[next_sample, i] += dense[i, j] * power
                    power *= x
                for i in range(dim):
                    y_out[next_sample, i] = y[i] + h * y_out[next_sample, i]
                next_sample += 1
        t = t_new
        for i in range(dim):
            y[i] = y_new[i]
            f[i] = stages[N_STAGES, i]
    return STATUS_OK, n_steps, n_rhs, t


# ---------------------------------------------------------------------------------------------------------------
# Python entry points


def _run(params, theta0, omega0, t_end, samples, rtol, atol):
    params = np.ascontiguousarray(params, dtype=np.float64)
    y0 = np.concatenate([np.asarray(theta0, dtype=np.float64), np.asarray(omega0, dtype=np.float64)])
    t = np.linspace(0.0, float(t_end), int(samples))
    y = np.full((t.size, y0.size), np.nan)
    status, n_steps, n_rhs, t_reached = integrate_dormand_prince(y0, t, params, rtol, atol, MAX_STEPS, y)
    if status != STATUS_OK:
        raise RuntimeError(f"closed-form Dormand-Prince failed with status {status} at t = {t_reached:.6g} s")
    return t, y, int(n_steps), int(n_rhs)


def simulate_closed_form(params, theta0, omega0, t_end, samples, rtol, atol) -> tuple[np.ndarray, np.ndarray]:
    """``(t, y)``: ``t`` (samples,) equally spaced on [0, t_end], ``y`` (samples, 2n) = [theta, omega] there.

    ``params`` in the layout of docs/architecture.md (length 4n + 4). Raises RuntimeError if the run fails."""
    t, y, _, _ = _run(params, theta0, omega0, t_end, samples, rtol, atol)
    return t, y


def tip_xy(lengths, theta) -> np.ndarray:
    """Tip H of the chain for every row of ``theta`` (T, n): (T, 2)."""
    lengths = np.asarray(lengths)
    return np.stack([np.sum(lengths * np.sin(theta), axis=1), -np.sum(lengths * np.cos(theta), axis=1)], axis=-1)


def _time_once(call) -> tuple[float, float]:
    """Wall seconds and this thread's CPU seconds (``thread_time``, less disturbed by other jobs on a shared
    machine) of one call, with the garbage collector paused (as timeit does)."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        cpu_start = time.thread_time()
        start = time.perf_counter()
        call()
        wall = time.perf_counter() - start
        return wall, time.thread_time() - cpu_start
    finally:
        if was_enabled:
            gc.enable()


def _summary(samples: list[float], cpu_samples: list[float]) -> dict:
    quartiles = statistics.quantiles(samples, n=4) if len(samples) >= 2 else [samples[0]] * 3
    return {
        "median_s": statistics.median(samples),
        "p25_s": quartiles[0],
        "p75_s": quartiles[2],
        "min_s": min(samples),
        "count": len(samples),
        "cpu_median_s": statistics.median(cpu_samples),
    }


def _integration_only(physics, method: str, chain, theta0, omega0):
    """A call of the compiled RK45 integration loop alone that ``physics.simulate`` runs for seed case C, with
    every argument made beforehand: what ``simulate`` adds around it is the difference of the two. The system is
    the one of the route ``simulate`` takes (:func:`physics.simulate.chain_system.chain_system`: the chain
    written as a mechanism on the general engine since that route is the default, else the chain's own
    kernel), its state in that system's coordinate order."""
    from physics.simulate.chain_system import chain_system  # noqa: PLC0415

    system = chain_system(chain, method)
    compiled = system.compiled
    y0 = system.state(theta0, omega0)
    t_eval = np.linspace(0.0, CASE_C_T_END, CASE_C_SAMPLES)
    params = system.params
    y_out = np.empty((CASE_C_SAMPLES, y0.size))
    no_condition = np.empty(0)
    max_steps = physics.Settings().max_steps

    def run():
        return compiled.integrate_rk45(y0, 0.0, CASE_C_T_END, t_eval, params, CASE_C_RTOL, CASE_C_ATOL, 0.0, 0.0,
                                       False, max_steps, y_out, no_condition)

    return run


def _wait_for_specialisation() -> None:
    """Wait for the background compilations of specialised drivers (physics.codegen.cache's threads named
    "specialise ..."), then run nothing timed before they are in place."""
    import threading  # noqa: PLC0415

    for thread in threading.enumerate():
        if thread.name.startswith("specialise"):
            thread.join()


def _read_solved(run):
    """Read every field a chain's run computes when first read (physics.simulate.trajectory.OnRequest)."""
    return run.reactions, run.joint_reactions, run.tip_reaction, run.condition


def time_case_c(repeats: int = DEFAULT_REPEATS, include_physics: bool = True,
                methods: tuple[str, ...] = ("lagrange", "newton_euler", "dae"), block: int = 1,
                read_solved: bool = False) -> dict:
    """Seed case C end to end (arrays in, sampled ``(t, y)`` out) after a warm-up call: timings, step counts and
    the tip check against ``physics.simulate``. ``include_physics``: also time ``physics.simulate`` (compiled
    RK45, same settings) for each of ``methods``, interleaved with the anchor in a rotating order (``block``
    calls of each in a row per turn), and report each ratio. ``read_solved``: each ``physics.simulate`` call also
    reads the reactions, joint reactions, tip reaction and condition (what a reader of the reactions pays)."""
    import physics

    from . import closed_form_three

    preset = physics.get_preset(CASE_C_PRESET)
    chain = preset.chain
    params = chain.params()
    theta0, omega0 = np.array(preset.theta0, dtype=float), np.array(preset.omega0, dtype=float)
    n = chain.n

    def settings(method):
        return physics.Settings(method=method, integrator="RK45", rtol=CASE_C_RTOL, atol=CASE_C_ATOL,
                                t_end=CASE_C_T_END, samples=CASE_C_SAMPLES)

    def run_closed_form():
        return simulate_closed_form(params, theta0, omega0, CASE_C_T_END, CASE_C_SAMPLES, CASE_C_RTOL, CASE_C_ATOL)

    def run_closed_form_three():
        return closed_form_three.simulate_three_bar(params, theta0, omega0, CASE_C_T_END, CASE_C_SAMPLES,
                                                    CASE_C_RTOL, CASE_C_ATOL)

    runners = {"closed_form": run_closed_form, "closed_form_three": run_closed_form_three}
    if include_physics:
        for method in methods:
            if read_solved:
                runners[method] = (lambda m=settings(method): _read_solved(physics.simulate(chain, theta0, omega0, m)))
            else:
                runners[method] = (lambda m=settings(method): physics.simulate(chain, theta0, omega0, m))
            runners[f"{method}_integration"] = _integration_only(physics, method, chain, theta0, omega0)
    for _ in range(2):  # warm-up: kernels loaded (or compiled); a system's second run makes its specialised driver
        for call in runners.values():
            call()
    _wait_for_specialisation()
    ours = physics.simulate(chain, theta0, omega0, settings("lagrange"))
    t, y, n_steps, n_rhs = _run(params, theta0, omega0, CASE_C_T_END, CASE_C_SAMPLES, CASE_C_RTOL, CASE_C_ATOL)
    _, y_three, n_steps_three, n_rhs_three = closed_form_three.run_with_counts(
        params, theta0, omega0, CASE_C_T_END, CASE_C_SAMPLES, CASE_C_RTOL, CASE_C_ATOL)

    times: dict = {name: [] for name in runners}
    cpu_times: dict = {name: [] for name in runners}
    names = list(runners)
    for round_index in range(repeats):
        shift = round_index % len(names)
        for name in names[shift:] + names[:shift]:
            for _ in range(block):  # block > 1: the runner's calls in a row, as a loop of runs meets them
                wall, cpu = _time_once(runners[name])
                times[name].append(wall)
                cpu_times[name].append(cpu)

    tip_closed = tip_xy(params[:n], y[:, :n])
    tip_difference = np.max(np.abs(tip_closed - ours.tip_xy), axis=1)
    window = t <= AGREEMENT_WINDOW_S + 1e-12
    max_difference_window = float(np.max(tip_difference[window]))
    result = {
        "case": "C",
        "preset": CASE_C_PRESET,
        "read_solved": read_solved,
        "settings": {"integrator": "RK45", "rtol": CASE_C_RTOL, "atol": CASE_C_ATOL, "t_end": CASE_C_T_END,
                     "samples": CASE_C_SAMPLES},
        "repeats": repeats,
        "block": block,
        "closed_form": _summary(times["closed_form"], cpu_times["closed_form"]),
        "closed_form_three": _summary(times["closed_form_three"], cpu_times["closed_form_three"]),
        "closed_form_n_steps": n_steps,
        "closed_form_n_rhs": n_rhs,
        "physics_n_steps": int(ours.n_steps),
        "physics_n_rhs": int(ours.n_rhs),
        "same_steps": n_rhs == int(ours.n_rhs) and n_steps == int(ours.n_steps),
        # the three-bar version against the generic one: same steps, largest difference of any state entry
        "three_same_steps": n_rhs_three == n_rhs and n_steps_three == n_steps,
        "three_max_abs_diff_state": float(np.max(np.abs(y_three - y))),
        "three_agree": n_rhs_three == n_rhs and float(np.max(np.abs(y_three - y))) < TIP_AGREEMENT,
        "tip_max_abs_diff_first_10s": max_difference_window,
        "tip_max_abs_diff_all_20s": float(np.max(tip_difference)),
        "tip_agreement_limit": TIP_AGREEMENT,
        "agree": max_difference_window < TIP_AGREEMENT,
    }
    if include_physics:
        closed = result["closed_form"]["median_s"]
        result["physics_simulate"] = {m: _summary(times[m], cpu_times[m]) for m in methods}
        result["integration_only"] = {m: _summary(times[f"{m}_integration"], cpu_times[f"{m}_integration"])
                                      for m in methods}
        result["physics_over_closed_form"] = {m: result["physics_simulate"][m]["median_s"] / closed for m in methods}
        three = result["closed_form_three"]["median_s"]
        result["physics_over_closed_form_three"] = {
            m: result["physics_simulate"][m]["median_s"] / three for m in methods
        }
        three_cpu = result["closed_form_three"]["cpu_median_s"]
        result["physics_over_closed_form_three_cpu"] = {
            m: result["physics_simulate"][m]["cpu_median_s"] / three_cpu for m in methods
        }
    return result


def _physics_from(tree: str) -> None:
    """Import ``physics`` from another checkout (``--physics-from``): the tree before a change, timed against the
    same baselines. Must run before anything imports ``physics``."""
    import os  # noqa: PLC0415

    if "physics" in sys.modules:
        raise RuntimeError("physics was imported before --physics-from could take effect")
    sys.path.insert(0, os.path.abspath(tree))


def _child(tree: str | None, repeats: int, cache: str | None = None, block: int = 1, read_solved: bool = False) -> dict:
    """One run of this command in a fresh process, ``physics`` from ``tree`` (None: this checkout), with
    ``cache`` (when given) as its ``LINKAGE_LAB_CACHE``: a generated system's file name carries its generator's
    digest, so two trees sharing one folder remove each other's files as stale and derive them again."""
    import os  # noqa: PLC0415
    import subprocess  # noqa: PLC0415

    command = [sys.executable, "-m", "benchmarks.closed_form", "--repeats", str(repeats), "--block", str(block)]
    if tree is not None:
        command += ["--physics-from", tree]
    if read_solved:
        command.append("--read-solved")
    import pathlib  # noqa: PLC0415

    root = pathlib.Path(__file__).resolve().parent.parent  # this checkout: its benchmarks, the baselines
    env = dict(os.environ)
    if cache is not None:
        env["LINKAGE_LAB_CACHE"] = cache
    done = subprocess.run(command, capture_output=True, text=True, check=False, cwd=root, env=env)
    if done.returncode not in (0, 1):
        raise RuntimeError(f"{' '.join(command)} failed:\n{done.stderr}")
    return json.loads(done.stdout)


def compare_before(before: str, rounds: int, repeats: int, block: int = 1, read_solved: bool = False) -> dict:
    """This checkout's ``physics.simulate`` and ``before``'s, each in its own process against the same two
    closed forms (this checkout's), the order alternating per round; medians over the rounds of each round's
    medians, and each tree's ratios. Each tree has a cache folder of its own, ``closed-form-after`` and
    ``closed-form-before`` under ``LINKAGE_LAB_CACHE`` or a new temporary folder."""
    import os  # noqa: PLC0415
    import tempfile  # noqa: PLC0415

    base = os.environ.get("LINKAGE_LAB_CACHE") or tempfile.mkdtemp(prefix="closed-form-")
    caches = {label: os.path.join(base, f"closed-form-{label}") for label in ("after", "before")}

    runs: dict[str, list[dict]] = {"after": [], "before": []}
    for round_index in range(rounds):
        order = [("after", None), ("before", before)]
        if round_index % 2:
            order.reverse()
        for label, tree in order:
            result = _child(tree, repeats, caches[label], block, read_solved)
            result["load_average"] = os.getloadavg()[0]
            runs[label].append(result)
    summary: dict = {"rounds": rounds, "repeats": repeats, "block": block, "read_solved": read_solved,
                     "before": os.path.abspath(before)}
    for label, results in runs.items():
        methods = list(results[0]["physics_simulate"])
        row = {
            "closed_form_three_ms": 1e3 * statistics.median(r["closed_form_three"]["median_s"] for r in results),
            "closed_form_ms": 1e3 * statistics.median(r["closed_form"]["median_s"] for r in results),
            "closed_form_three_cpu_ms": 1e3 * statistics.median(
                r["closed_form_three"]["cpu_median_s"] for r in results),
            "simulate_ms": {m: 1e3 * statistics.median(r["physics_simulate"][m]["median_s"] for r in results)
                            for m in methods},
            "simulate_cpu_ms": {
                m: 1e3 * statistics.median(r["physics_simulate"][m]["cpu_median_s"] for r in results)
                for m in methods},
            "integration_only_cpu_ms": {
                m: 1e3 * statistics.median(r["integration_only"][m]["cpu_median_s"] for r in results)
                for m in methods},
            "over_closed_form_three_cpu": {
                m: statistics.median(r["physics_over_closed_form_three_cpu"][m] for r in results)
                for m in methods},
            "over_closed_form_three": {
                m: statistics.median(r["physics_over_closed_form_three"][m] for r in results) for m in methods},
            "over_closed_form": {
                m: statistics.median(r["physics_over_closed_form"][m] for r in results) for m in methods},
            "agree": all(r["agree"] and r["three_agree"] for r in results),
            "load_average_after_each_round": [r["load_average"] for r in results],
        }
        summary[label] = row
    return summary


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.closed_form", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--repeats", type=int, default=DEFAULT_REPEATS, help="timed runs (median reported)")
    parser.add_argument("--no-physics", action="store_true", help="do not time physics.simulate alongside")
    parser.add_argument("--physics-from", metavar="DIR", help="import physics from this checkout instead")
    parser.add_argument("--before", metavar="DIR",
                        help="also time the checkout DIR's physics.simulate (e.g. a `git worktree add` of the base "
                             "commit), each tree in its own process, alternating per round")
    parser.add_argument("--rounds", type=int, default=3, help="rounds of --before (each runs both trees once)")
    parser.add_argument("--block", type=int, default=1,
                        help="calls of each runner in a row per turn (default 1: every call after the other "
                             "runners' calls, its caches and branch history cold; e.g. 10: as a loop of runs, a "
                             "study or timeit meets them; every call timed)")
    parser.add_argument("--read-solved", action="store_true",
                        help="each physics.simulate call also reads the reactions, joint reactions, tip reaction "
                             "and condition (computed when first read): what a reader of the reactions pays")
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error("--repeats: must be at least 1")
    if args.rounds < 1:
        parser.error("--rounds: must be at least 1")
    if args.block < 1:
        parser.error("--block: must be at least 1")
    if args.before:
        summary = compare_before(args.before, args.rounds, args.repeats, args.block, args.read_solved)
        print(json.dumps(summary, indent=2))
        return 0 if summary["after"]["agree"] and summary["before"]["agree"] else 1
    if args.physics_from:
        _physics_from(args.physics_from)
    result = time_case_c(args.repeats, include_physics=not args.no_physics, block=args.block,
                         read_solved=args.read_solved)
    print(json.dumps(result, indent=2))
    return 0 if result["agree"] and result["three_agree"] else 1


if __name__ == "__main__":
    sys.exit(main())
