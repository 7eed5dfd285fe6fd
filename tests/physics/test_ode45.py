"""MATLAB's ode45 (physics/kernels/ode45.py): exact solutions, its controller's first steps computed by hand here,
its Refine output, and every formulation and closed loop through ``simulate``.

The systems are hand-written ``assemble`` functions (``A theta'' = b``), compiled with ``numba.cfunc`` and given to
the kernel as every generated mechanism is. The hand computation below is written from the published algorithm
(Shampine & Reichelt 1997; MATLAB's ode45 documentation) with the Dormand-Prince coefficients typed in again,
independent of the kernel's tables.
"""

import math

import numpy as np
import pytest
from numba import cfunc

from physics.chain_presets import get_preset
from physics.codegen import load_compiled
from physics.kernels import ode45
from physics.kernels.abi import ASSEMBLE_SIGNATURE, make_layout
from physics.kernels.tables import ODE45_BI, RK45_B
from physics.model import Settings, validated
from physics.simulate import simulate


def oscillator_assemble(theta, omega, params, A, b):
    """theta'' = -k theta - c omega (k = params[0], c = params[1])."""
    A[0] = 1.0
    b[0] = -params[0] * theta[0] - params[1] * omega[0]


@pytest.fixture(scope="module")
def oscillator():
    compiled = cfunc(ASSEMBLE_SIGNATURE, error_model="numpy")(oscillator_assemble)
    return compiled, compiled.address, make_layout(1, 1, range(1), n_parameters=2)


PARAMS = np.zeros(7)


def params(k, c):
    out = PARAMS.copy()
    out[0], out[1] = k, c
    return out


def run(oscillator, y0, t_end, t_eval, p, tol, max_steps=1_000_000):
    _, address, layout = oscillator
    y_out = np.empty((len(t_eval), 2))
    result = ode45.integrate_ode45(address, layout, np.asarray(y0, float), 0.0, t_end, np.asarray(t_eval, float), p,
                                   tol, tol, 0.0, 0.0, False, max_steps, y_out, np.empty(0))
    return result, y_out


def refined(oscillator, y0, t_end, p, tol, refine, max_steps=10_000):
    _, address, layout = oscillator
    rows = ode45.refined_rows(max_steps, refine)
    t_out, y_out = np.empty(rows), np.empty((rows, 2))
    result = ode45.integrate_ode45_refined(address, layout, np.asarray(y0, float), 0.0, t_end, p, tol, tol, 0.0, 0.0,
                                           False, refine, t_out, y_out)
    return result, t_out[: result[4]], y_out[: result[4]]


def test_exact_harmonic_solution_error_follows_the_tolerance(oscillator):
    """theta = cos t: the error at every sample stays near the tolerance and falls with it."""
    t_eval = np.linspace(0.0, 10.0, 201)
    errors = []
    for tol in (1e-4, 1e-6, 1e-8, 1e-10):
        (status, n_steps, _, t_reached, n_filled), y = run(oscillator, [1.0, 0.0], 10.0, t_eval, params(1, 0), tol)
        assert (status, t_reached, n_filled) == (0, 10.0, len(t_eval))
        error = np.max(np.abs(y[:, 0] - np.cos(t_eval)) + np.abs(y[:, 1] + np.sin(t_eval)))
        assert error < 30 * tol, (tol, error)
        errors.append(error)
    assert all(later < earlier / 10 for earlier, later in zip(errors, errors[1:])), errors


def test_fifth_order_steps_scale_as_the_fifth_root_of_the_tolerance(oscillator):
    """Error per step ~ h^5 (the fourth-order estimate of a fifth-order step): tolerance / 1e5 takes 10x the steps."""
    counts = {}
    for tol in (1e-4, 1e-9):
        (status, n_steps, *_), _ = run(oscillator, [1.0, 0.0], 50.0, np.array([0.0, 50.0]), params(1, 0), tol)
        assert status == 0
        counts[tol] = n_steps
    ratio = counts[1e-9] / counts[1e-4]
    assert 7.0 < ratio < 14.0, counts


def test_exact_damped_solution(oscillator):
    """theta'' = -c theta' from (0, 1): theta = (1 - e^(-c t)) / c, omega = e^(-c t)."""
    c = 0.7
    t_eval = np.linspace(0.0, 8.0, 81)
    (status, *_), y = run(oscillator, [0.0, 1.0], 8.0, t_eval, params(0, c), 1e-9)
    assert status == 0
    np.testing.assert_allclose(y[:, 1], np.exp(-c * t_eval), atol=1e-8)
    np.testing.assert_allclose(y[:, 0], (1 - np.exp(-c * t_eval)) / c, atol=1e-8)


# ---------------------------------------------------------------------------------------------- by hand
# Dormand & Prince (1980), the 5(4) pair (c, a, b of the fifth-order solution, b* of the fourth-order one).
C = [0.0, 0.2, 0.3, 0.8, 8.0 / 9.0, 1.0]
A = [[], [0.2], [3 / 40, 9 / 40], [44 / 45, -56 / 15, 32 / 9], [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729],
     [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656]]
B5 = [35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0.0]
B4 = [5179 / 57600, 0.0, 7571 / 16695, 393 / 640, -92097 / 339200, 187 / 2100, 1 / 40]


def hand_ode45(f, y0, t_end, rtol, atol, htspan, n_steps):
    """The first ``n_steps`` accepted steps of ode45 (end times, and failures seen), from the published rules."""
    y = list(y0)
    t = 0.0
    threshold = atol / rtol
    hmax = 0.1 * t_end
    f0 = f(y)
    rh = max(abs(f0[j]) / max(abs(y[j]), threshold) for j in range(len(y))) / (0.8 * rtol ** 0.2)
    absh = min(hmax, htspan)
    if absh * rh > 1:
        absh = 1 / rh
    ends, failures = [], 0
    while len(ends) < n_steps:
        absh = min(hmax, absh)
        h = absh
        done = 1.1 * absh >= t_end - t
        if done:
            h = absh = t_end - t
        first_try = True
        while True:
            k = [f0]
            for s in range(1, 6):
                k.append(f([y[j] + h * sum(A[s][r] * k[r][j] for r in range(s)) for j in range(len(y))]))
            y5 = [y[j] + h * sum(B5[r] * k[r][j] for r in range(6)) for j in range(len(y))]
            k.append(f(y5))
            err = absh * max(abs(sum((B5[r] - B4[r]) * k[r][j] for r in range(7))) /
                             max(abs(y[j]), abs(y5[j]), threshold) for j in range(len(y)))
            if err <= rtol:
                break
            failures += 1
            absh = absh * max(0.1, 0.8 * (rtol / err) ** 0.2) if first_try else absh / 2
            first_try = False
            h = absh
            done = False
        t += h
        ends.append(t)
        if done:
            break
        if first_try:
            absh *= min(5.0, 0.8 * (rtol / err) ** 0.2) if err > 0 else 5.0
        y, f0 = y5, k[6]
    return ends, failures


@pytest.mark.parametrize("htspan_points, tol", [(2, 1e-6), (201, 1e-6), (2, 1e-3)])
def test_first_steps_match_a_hand_computation(oscillator, htspan_points, tol):
    """Step ends of the kernel (Refine = 1 gives one output per step; a tspan of many points bounds the first step
    by its spacing, as MATLAB's ``htspan``) against the rules applied by hand, failures included."""
    p = params(4.0, 0.0)

    def f(y):
        return [y[1], -4.0 * y[0]]

    t_end = 10.0
    htspan = t_end / (htspan_points - 1)
    ends, failures = hand_ode45(f, [1.0, 0.0], t_end, tol, tol, htspan, 12)
    if htspan_points == 2:
        (status, n_steps, n_rhs, *_), t_out, _ = refined(oscillator, [1.0, 0.0], t_end, p, tol, 1)
    else:
        _, address, layout = oscillator
        t_eval = np.linspace(0.0, t_end, htspan_points)
        y_out = np.empty((len(t_eval), 2))
        status, n_steps, n_rhs, *_ = ode45.integrate_ode45(address, layout, np.array([1.0, 0.0]), 0.0, t_end, t_eval,
                                                            p, tol, tol, 0.0, 0.0, False, len(ends), y_out, np.empty(0))
        assert status == -4  # stopped after exactly the steps computed by hand (max_steps)
        t_out = None
    assert n_steps >= len(ends)
    if t_out is not None:
        # The error estimate is a difference of nearly equal sums: its rounding differs here in the 11th digit.
        np.testing.assert_allclose(t_out[1 : len(ends) + 1], ends, rtol=1e-9)
    else:
        assert n_steps == len(ends) and n_rhs == 1 + 6 * (len(ends) + failures)


def test_a_rejected_step_shrinks_as_published(oscillator):
    """A first step far too long: from (0, 1) the first derivative (1, 0) says nothing of the spring k = 1e4
    (period 0.063 s), so the first-step rule allows 0.3 s. The first failure cuts by at most 10, later ones halve;
    the hand computation sees the failures and the kernel's evaluations count them (1 + 6 per attempt)."""
    p = params(1e4, 0.0)

    def f(y):
        return [y[1], -1e4 * y[0]]

    ends, failures = hand_ode45(f, [0.0, 1.0], 1.0, 1e-2, 1e-2, 1.0, 6)
    (status, n_steps, n_rhs, *_), t_out, _ = refined(oscillator, [0.0, 1.0], 1.0, p, 1e-2, 1, max_steps=6)
    assert failures >= 2 and status == -4 and n_steps == 6
    np.testing.assert_allclose(t_out[1:7], ends, rtol=1e-9)
    assert n_rhs == 1 + 6 * (6 + failures)


def test_refine_gives_four_outputs_per_step_through_the_function_api():
    """CompiledSystem.integrate_ode45_refined: the start, then for each step its three quarter points and its end."""
    compiled = load_compiled("lagrange", 1, False)
    preset = get_preset("chain", links=1)
    y0 = np.concatenate([preset.theta0, preset.omega0])
    t, y, status, n_steps = compiled.integrate_ode45_refined(y0, 0.0, 5.0, preset.chain.params(), 1e-6, 1e-6)
    assert status == 0 and n_steps > 5
    assert len(t) == 1 + 4 * n_steps and y.shape == (len(t), 2)
    ends = t[::4]
    assert ends[0] == 0.0 and ends[-1] == 5.0 and np.all(np.diff(ends) > 0)
    quarters = ends[:-1, None] + np.diff(ends)[:, None] * np.array([0.25, 0.5, 0.75])
    np.testing.assert_allclose(t[1:].reshape(-1, 4)[:, :3], quarters, rtol=1e-14)
    # The same steps sampled on a tspan of the step ends (the first spacing is the first step: same htspan only
    # when it does not bind, so compare with tspan = [0, 5] re-sampled): ntrp45 at s = 1 is y_new.
    t2, y2, _, _ = compiled.integrate_ode45_refined(y0, 0.0, 5.0, preset.chain.params(), 1e-6, 1e-6, refine=1)
    np.testing.assert_allclose(t2, ends, rtol=0, atol=0)
    np.testing.assert_allclose(y2, y[::4], rtol=1e-12, atol=1e-14)


def test_ntrp45_is_the_step_at_its_ends_and_fourth_order_inside(oscillator):
    """ntrp45 at s = 1 reproduces the fifth-order y_new; inside a step its error shrinks ~h^5 (order 4)."""
    np.testing.assert_allclose(ODE45_BI.sum(axis=1), np.append(RK45_B, 0.0), rtol=0, atol=1e-15)
    assert np.all(ODE45_BI[:, 0] == np.array([1, 0, 0, 0, 0, 0, 0]))  # derivative at s = 0 is f(y)
    gaps = []
    for tol in (1e-5, 1e-8):
        (status, n_steps, *_), t, y = refined(oscillator, [1.0, 0.0], 10.0, params(1, 0), tol, 4)
        assert status == 0
        gaps.append(np.max(np.abs(y[:, 0] - np.cos(t))))
    assert gaps[1] < gaps[0] / 100


@pytest.mark.parametrize("method", ["newton_euler", "lagrange", "dae"])
@pytest.mark.parametrize("stabilization", ["projection", "baumgarte", "none"])
def test_every_formulation_and_the_closed_loop(method, stabilization):
    """The four-bar under each formulation and stabilisation: ode45 runs, the chain closes as RK45's does."""
    preset = get_preset("four-bar")
    runs = {}
    for integrator in ("ode45", "RK45"):
        settings = validated(Settings, method=method, integrator=integrator, rtol=1e-8, atol=1e-8, t_end=3.0,
                             samples=31, stabilization=stabilization)
        runs[integrator] = simulate(preset.chain, preset.theta0, preset.omega0, settings)
        assert runs[integrator].success, runs[integrator].message
    gap = np.hypot(*runs["ode45"].constraint_xy.T)
    assert np.max(gap) < (1e-12 if stabilization == "projection" else 1e-5)
    assert np.max(np.abs(runs["ode45"].theta - runs["RK45"].theta)) < 1e-5


def test_open_chain_through_the_cli_settings():
    preset = get_preset("triple-a")
    settings = validated(Settings, method="newton_euler", integrator="ode45", rtol=1e-6, atol=1e-6, t_end=2.0,
                         samples=200)
    run_ = simulate(preset.chain, preset.theta0, preset.omega0, settings)
    assert run_.success and run_.n_steps > 10 and len(run_.t) == 200
    assert math.isclose(run_.t[-1], 2.0)
