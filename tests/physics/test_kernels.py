"""The once-compiled integration kernels (physics.kernels) on their own, against scipy and known behaviour.

The kernels take the address of a mechanism's ``assemble`` (the generated code's contract,
physics/kernels/abi.py). Here each test system is a hand-written ``assemble`` (equations written out below and in
tests/physics/kernel_toys.py, independent of the project's derivations), compiled with ``numba.cfunc`` and handed
to the same kernels that every generated mechanism uses.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from .kernel_toys import DOUBLE_PARAMS, DOUBLE_Y0, Toy, double_assemble


# Compound pendulum: (I + m d^2) theta'' = -m g d sin(theta). params[5] (pin_x, unused by an open chain) makes it
# break once theta exceeds 0.5: 1 singular system (a zero matrix), 2 NaN acceleration, 3 a jump of 1e10 that no
# step is small enough to follow.
def pendulum_assemble(theta, omega, params, A, b):
    d = params[1]
    m = params[2]
    inertia = params[3]
    g = params[4]
    A[0] = inertia + m * d * d
    b[0] = -m * g * d * math.sin(theta[0])
    fault = params[5]
    if fault != 0.0 and theta[0] > 0.5:
        if fault == 1.0:
            A[0] = 0.0
        if fault == 2.0:
            b[0] = np.nan
        if fault == 3.0:
            b[0] = 1e10 * A[0]


# Pinned three-bar toy with a unit mass matrix: free acceleration u_i = -g m_i sin(theta_i) plus the constraint
# force J^T lambda; rows 3 and 4 state the tip's acceleration J theta'' + Jdot omega = 0. Unknowns
# x = [theta''_1..3, lambda_x, lambda_y].
def pinned_assemble(theta, omega, params, A, b):
    g = params[12]
    for i in range(3):
        L = params[i]
        jx = L * math.cos(theta[i])
        jy = L * math.sin(theta[i])
        A[i * 5 + i] = 1.0
        A[i * 5 + 3] = jx
        A[i * 5 + 4] = jy
        A[3 * 5 + i] = jx
        A[4 * 5 + i] = jy
        b[i] = -g * params[6 + i] * math.sin(theta[i])
    b[3] = 0.0
    b[4] = 0.0
    for i in range(3):
        L = params[i]
        b[3] += L * math.sin(theta[i]) * omega[i] ** 2
        b[4] -= L * math.cos(theta[i]) * omega[i] ** 2


# The toy's constraint, written by hand as the generated ``constraints`` of a pinned chain: the tip on the pin
# (params[13], params[14]), its Jacobian J and v = [phi, J omega].
def pinned_constraints(theta, omega, params, J, v):
    tip_x = -params[13]
    tip_y = -params[14]
    speed_x = 0.0
    speed_y = 0.0
    for i in range(3):
        L = params[i]
        J[i] = L * math.cos(theta[i])
        J[3 + i] = L * math.sin(theta[i])
        tip_x += L * math.sin(theta[i])
        tip_y -= L * math.cos(theta[i])
        speed_x += J[i] * omega[i]
        speed_y += J[3 + i] * omega[i]
    v[0] = tip_x
    v[1] = tip_y
    v[2] = speed_x
    v[3] = speed_y


PENDULUM_PARAMS = np.array([1.0, 0.5, 1.0, 0.2, 1.0, 0.0, 0.0])
PENDULUM_Y0 = np.array([2.0, 0.0])


@pytest.fixture(scope="module")
def build():
    """Return ``build(name)``: the toy system ``name``, compiled once per test module."""
    makers = {
        "pendulum": lambda: Toy(pendulum_assemble, 1, 1),
        "double": lambda: Toy(double_assemble, 2, 2),
        "pinned": lambda: Toy(pinned_assemble, 3, 5, pinned_constraints, rows=(3, 4)),
    }
    built = {}

    def _build(name):
        if name not in built:
            built[name] = makers[name]()
        return built[name]

    return _build


def scipy_rhs(module, params):
    n = module.N_LINKS

    def rhs(t, y):
        return np.concatenate([y[n:], module.accel(y[:n], y[n:], params)])

    return rhs


def run(integrator, y0, t_end, t_eval, params, rtol=1e-8, atol=1e-10, project=False, max_steps=10**6):
    y_out = np.empty((len(t_eval), len(y0)))
    cond_out = np.empty(len(t_eval))
    result = integrator(y0, 0.0, t_end, t_eval, params, rtol, atol, 0.0, 0.0, project, max_steps, y_out, cond_out)
    return result, y_out, cond_out


def run_midpoint(module, y0, t_end, h, t_eval, params, project=False):
    y_out = np.empty((len(t_eval), len(y0)))
    cond_out = np.empty(len(t_eval))
    result = module.integrate_midpoint(y0, 0.0, t_end, h, t_eval, params, 0.0, 0.0, project, y_out, cond_out)
    return result, y_out, cond_out


def pendulum_energy(y):
    L, d, m, inertia, g = PENDULUM_PARAMS[:5]
    return 0.5 * (inertia + m * d * d) * y[..., 1] ** 2 - m * g * d * np.cos(y[..., 0])


CASES = [("pendulum", PENDULUM_Y0, PENDULUM_PARAMS, 20.0), ("double", DOUBLE_Y0, DOUBLE_PARAMS, 10.0)]


@pytest.mark.parametrize("method", ["RK45", "DOP853"])
@pytest.mark.parametrize("name, y0, params, t_end", CASES, ids=[case[0] for case in CASES])
@pytest.mark.parametrize("rtol, atol", [(1e-6, 1e-6), (1e-10, 1e-12)])
def test_explicit_rk_reproduces_scipy(build, method, name, y0, params, t_end, rtol, atol):
    module = build(name)
    integrator = module.integrate_rk45 if method == "RK45" else module.integrate_dop853
    t_eval = np.linspace(0.0, t_end, 101)
    result, y_out, cond_out = run(integrator, y0, t_end, t_eval, params, rtol, atol)
    status, n_steps, n_rhs, t_reached, n_filled = result
    rhs = scipy_rhs(module, params)
    reference = solve_ivp(rhs, (0.0, t_end), y0, method=method, t_eval=t_eval, rtol=rtol, atol=atol)
    assert reference.status == 0
    assert (status, t_reached, n_filled) == (0, t_end, len(t_eval))
    # The kernels copy the sample at t0 from y0; scipy takes it from the first step's dense output, which costs
    # DOP853 three extra evaluations when no other sample falls in that step. Without it the counts are equal.
    counted = solve_ivp(rhs, (0.0, t_end), y0, method=method, t_eval=t_eval[1:], rtol=rtol, atol=atol)
    assert n_rhs == counted.nfev
    assert reference.nfev - n_rhs in ((0,) if method == "RK45" else (0, 3))
    assert n_steps > 10
    np.testing.assert_allclose(y_out, reference.y.T, rtol=1e-9, atol=1e-12)
    assert np.all(np.isfinite(cond_out)) and np.all(cond_out >= 1.0)


def test_rk45_repeated_sample_times_and_t0(build):
    module = build("double")
    t_eval = np.array([0.0, 0.0, 1.0, 2.5, 2.5, 10.0])
    (status, *_, n_filled), y_out, _ = run(module.integrate_rk45, DOUBLE_Y0, 10.0, t_eval, DOUBLE_PARAMS)
    unique = np.unique(t_eval)  # scipy wants strictly increasing times
    rhs = scipy_rhs(module, DOUBLE_PARAMS)
    reference = solve_ivp(rhs, (0.0, 10.0), DOUBLE_Y0, t_eval=unique, rtol=1e-8, atol=1e-10)
    assert status == 0 and n_filled == len(t_eval)
    np.testing.assert_array_equal(y_out[:2], [DOUBLE_Y0, DOUBLE_Y0])
    np.testing.assert_array_equal(y_out[3], y_out[4])
    np.testing.assert_allclose(y_out[[0, 2, 3, 5]], reference.y.T, rtol=1e-9, atol=1e-12)


def midpoint_error(module, h, t_end=4.0):
    t_eval = np.array([t_end])
    reference = solve_ivp(
        scipy_rhs(module, PENDULUM_PARAMS), (0.0, t_end), PENDULUM_Y0, method="DOP853", rtol=1e-13, atol=1e-13
    ).y[:, -1]
    (status, n_steps, *_), y_out, _ = run_midpoint(module, PENDULUM_Y0, t_end, h, t_eval, PENDULUM_PARAMS)
    assert status == 0 and n_steps == round(t_end / h)
    return np.max(np.abs(y_out[-1] - reference))


def test_midpoint_converges_at_second_order(build):
    module = build("pendulum")
    errors = [midpoint_error(module, h) for h in (0.04, 0.02, 0.01)]
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    assert all(3.8 < ratio < 4.2 for ratio in ratios), (errors, ratios)


def test_midpoint_energy_error_stays_bounded(build):
    module = build("pendulum")
    t_end = 2000.0
    t_eval = np.linspace(0.0, t_end, 20001)
    (status, *_), y_out, _ = run_midpoint(module, PENDULUM_Y0, t_end, 0.05, t_eval, PENDULUM_PARAMS)
    assert status == 0
    # Samples every 0.1 s fall on step ends (h = 0.05), so no interpolation error enters.
    energy_error = np.abs(pendulum_energy(y_out) - pendulum_energy(PENDULUM_Y0))
    first, last = energy_error[: len(t_eval) // 10], energy_error[-len(t_eval) // 10 :]
    assert first.max() < 1e-3
    assert last.max() < 1.2 * first.max()
    # An explicit method of the same cost drifts secularly: RK45 at loose tolerance, for contrast.
    (status, *_), y_rk, _ = run(module.integrate_rk45, PENDULUM_Y0, t_end, t_eval, PENDULUM_PARAMS, 1e-4, 1e-6)
    rk_error = np.abs(pendulum_energy(y_rk) - pendulum_energy(PENDULUM_Y0))
    assert rk_error[-len(t_eval) // 10 :].max() > 5 * rk_error[: len(t_eval) // 10].max()


def test_midpoint_is_time_reversible(build):
    module = build("pendulum")
    t_end, h = 7.0, 0.05
    t_eval = np.array([t_end])
    (status, *_), forward, _ = run_midpoint(module, PENDULUM_Y0, t_end, h, t_eval, PENDULUM_PARAMS)
    flipped = forward[-1] * np.array([1.0, -1.0])  # reverse the velocity and run forward again
    (status_back, *_), back, _ = run_midpoint(module, flipped, t_end, h, t_eval, PENDULUM_PARAMS)
    assert status == status_back == 0
    assert np.max(np.abs(forward[-1] - PENDULUM_Y0)) > 0.5
    np.testing.assert_allclose(back[-1] * np.array([1.0, -1.0]), PENDULUM_Y0, atol=1e-11)


# Pinned three-bar toy: bars of length 1, tip pinned where the starting angles put it.
PINNED_THETA0 = np.array([0.9, 2.4, 3.9])
PINNED_L = np.array([1.0, 1.0, 1.0])


def pinned_params():
    tip = np.array([np.sum(PINNED_L * np.sin(PINNED_THETA0)), -np.sum(PINNED_L * np.cos(PINNED_THETA0))])
    return np.concatenate([PINNED_L, [0.5] * 3, [1.0, 2.0, 1.5], [0.1] * 3, [1.0], tip])


def pinned_y0():
    rows = np.array([PINNED_L * np.cos(PINNED_THETA0), PINNED_L * np.sin(PINNED_THETA0)])
    null_velocity = np.cross(rows[0], rows[1])  # the one direction that keeps the tip still
    return np.concatenate([PINNED_THETA0, 1.5 * null_velocity / np.linalg.norm(null_velocity)])


def constraint_residuals(y, params):
    theta, omega = y[:, :3], y[:, 3:]
    tip = np.stack([np.sum(PINNED_L * np.sin(theta), axis=1), -np.sum(PINNED_L * np.cos(theta), axis=1)], axis=1)
    tip_velocity = np.stack(
        [np.sum(PINNED_L * np.cos(theta) * omega, axis=1), np.sum(PINNED_L * np.sin(theta) * omega, axis=1)], axis=1
    )
    return np.linalg.norm(tip - params[13:15], axis=1), np.linalg.norm(tip_velocity, axis=1)


@pytest.mark.parametrize("method", ["rk45", "midpoint"])
def test_projection_keeps_pinned_chain_on_its_loop(build, method):
    module = build("pinned")
    params, y0 = pinned_params(), pinned_y0()
    t_eval = np.linspace(0.0, 20.0, 401)
    results = {}
    for project in (False, True):
        if method == "rk45":
            (status, *_), y_out, _ = run(module.integrate_rk45, y0, 20.0, t_eval, params, 1e-6, 1e-8, project)
        else:
            (status, *_), y_out, _ = run_midpoint(module, y0, 20.0, 0.02, t_eval, params, project)
        assert status == 0
        results[project] = constraint_residuals(y_out, params)
    position, velocity = results[True]
    assert position.max() < 1e-12 and velocity.max() < 1e-12
    drift_position, _ = results[False]
    assert drift_position.max() > 1e-9  # without projection the loop does open: the check above can fail


def test_project_position_and_velocity_are_least_change(build):
    module = build("pinned")
    params = pinned_params()
    rng = np.random.default_rng(7)
    theta = PINNED_THETA0 + 1e-3 * rng.standard_normal(3)
    start = theta.copy()
    residual = module.project_position(theta, params)
    assert residual < 1e-13
    assert constraint_residuals(np.concatenate([theta, np.zeros(3)])[None], params)[0][0] < 1e-13
    # Gauss-Newton's least change: orthogonal to the constraint's null space at the start, up to the second
    # order terms of the later iterations.
    rows = np.array([PINNED_L * np.cos(start), PINNED_L * np.sin(start)])
    null = np.cross(rows[0], rows[1])
    change = np.linalg.norm(theta - start)
    assert 1e-4 < change and abs(np.dot(theta - start, null)) / np.linalg.norm(null) < change**2
    rows = np.array([PINNED_L * np.cos(theta), PINNED_L * np.sin(theta)])
    null = np.cross(rows[0], rows[1])
    omega = rng.standard_normal(3)
    expected = null * np.dot(omega, null) / np.dot(null, null)
    speed = module.project_velocity(theta, omega, params)
    assert speed > 0.1
    np.testing.assert_allclose(omega, expected, atol=1e-13)


def run_any(module, method, y0, t_end, t_eval, params):
    if method == "midpoint":
        return run_midpoint(module, y0, t_end, 0.01, t_eval, params)
    integrator = module.integrate_rk45 if method == "rk45" else module.integrate_dop853
    return run(integrator, y0, t_end, t_eval, params)


@pytest.mark.parametrize("method", ["rk45", "dop853", "midpoint"])
@pytest.mark.parametrize("fault, expected", [(1.0, -1), (2.0, -2)], ids=["singular", "nan"])
def test_failure_is_reported_with_what_was_computed(build, method, fault, expected):
    module = build("pendulum")
    healthy = np.array([1.0, 0.5, 1.0, 0.25, 1.0, 0.0, 0.0])  # theta'' = -sin(theta)
    faulty = healthy.copy()
    faulty[5] = fault
    y0 = np.array([0.0, 1.0])
    t_eval = np.linspace(0.0, 5.0, 251)
    (status, n_steps, n_rhs, t_reached, n_filled), y_out, cond_out = run_any(module, method, y0, 5.0, t_eval, faulty)
    (healthy_status, *_), y_healthy, _ = run_any(module, method, y0, 5.0, t_eval, healthy)
    assert status == expected and healthy_status == 0
    assert 0.05 < t_reached < 0.6  # theta first reaches 0.5 at t = 0.55; a trial step may look beyond it first
    assert 0 < n_steps and 0 < n_rhs
    assert n_filled == np.count_nonzero(t_eval <= t_reached) and n_filled >= 2
    assert np.all(np.isnan(y_out[n_filled:])) and np.all(np.isnan(cond_out[n_filled:]))
    # Up to the failure the run is the healthy one, step for step.
    np.testing.assert_array_equal(y_out[:n_filled], y_healthy[:n_filled])
    assert np.all(y_out[:n_filled, 0] <= 0.5)


def test_rk45_reports_too_small_step_and_max_steps(build):
    module = build("pendulum")
    jump = np.array([1.0, 0.5, 1.0, 0.2, 1.0, 3.0, 0.0])
    t_eval = np.linspace(0.0, 5.0, 51)
    (status, *_, t_reached, _), _, _ = run(module.integrate_rk45, np.array([0.0, 1.0]), 5.0, t_eval, jump)
    reference = solve_ivp(scipy_rhs(module, jump), (0.0, 5.0), [0.0, 1.0], rtol=1e-8, atol=1e-10)
    assert status == -3 and reference.status == -1 and "step size" in reference.message
    assert t_reached == pytest.approx(reference.t[-1], rel=1e-12)  # the same step, to rounding
    smooth = np.array([1.0, 0.5, 1.0, 0.2, 1.0, 0.0, 0.0])
    (status, n_steps, *_), _, _ = run(module.integrate_rk45, np.array([0.0, 0.3]), 5.0, t_eval, smooth, max_steps=5)
    assert (status, n_steps) == (-4, 5)


def test_rk4_batch_step_matches_a_plain_rk4(build):
    module = build("double")
    rng = np.random.default_rng(3)
    theta = rng.uniform(-2.0, 2.0, (5, 2))
    omega = rng.uniform(-1.0, 1.0, (5, 2))
    h = 0.01
    f = scipy_rhs(module, DOUBLE_PARAMS)
    expected = []
    for y in np.hstack([theta, omega]):
        k1 = f(0, y)
        k2 = f(0, y + h / 2 * k1)
        k3 = f(0, y + h / 2 * k2)
        k4 = f(0, y + h * k3)
        expected.append(y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4))
    work = np.empty((module.RK4_WORK_ROWS, 2))
    cond_out = np.empty(5)
    worst = module.rk4_batch_step(theta, omega, DOUBLE_PARAMS, h, 0.0, 0.0, work, cond_out)
    np.testing.assert_allclose(np.hstack([theta, omega]), expected, rtol=1e-14, atol=1e-15)
    assert np.all(cond_out >= 1.0) and worst == cond_out.max()


def test_empty_interval_and_programming_errors(build):
    module = build("pendulum")
    t_eval = np.array([0.0, 0.0])
    result, y_out, _ = run(module.integrate_rk45, PENDULUM_Y0, 0.0, t_eval, PENDULUM_PARAMS)
    assert result == (0, 0, 1, 0.0, 2)  # status, n_steps, n_rhs, t_reached, n_filled
    np.testing.assert_array_equal(y_out, [PENDULUM_Y0, PENDULUM_Y0])
    with pytest.raises(ValueError, match="y0 must have shape"):
        run(module.integrate_rk45, np.zeros(4), 1.0, t_eval, PENDULUM_PARAMS)
    with pytest.raises(ValueError, match="t_end must be >= t0"):
        run(module.integrate_dop853, PENDULUM_Y0, -1.0, t_eval, PENDULUM_PARAMS)
    with pytest.raises(ValueError, match="h must be positive"):
        run_midpoint(module, PENDULUM_Y0, 1.0, 0.0, t_eval, PENDULUM_PARAMS)
