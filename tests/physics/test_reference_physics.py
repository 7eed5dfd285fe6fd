"""Independent physics: compound-pendulum period (elliptic integral), normal modes, rest, seed reductions."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import ellipk

from physics import Settings, get_preset, load_compiled, make_chain, simulate
from physics.kinematics import mass_matrix

from ..conftest import ALL_FORMULATIONS

ACCURATE = dict(integrator="DOP853", rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("method", ALL_FORMULATIONS)
@pytest.mark.parametrize("amplitude", [0.1, 1.0, 2.0, 3.0])
def test_single_bar_period_matches_elliptic_integral(method, amplitude):
    """T = 4 K(k^2) / w0 with k = sin(amplitude / 2), w0^2 = m g d / (I + m d^2): check the quarter period."""
    L, d, m, I, g = 1.0, 0.5, 1.0, 0.2, 1.0
    chain = make_chain([L], [d], [m], [I], g=g)
    w0 = np.sqrt(m * g * d / (I + m * d * d))
    period = 4.0 * ellipk(np.sin(amplitude / 2) ** 2) / w0
    t_quarter = period / 4
    trajectory = simulate(chain, [amplitude], [0.0], Settings(method=method, t_end=t_quarter, samples=2, **ACCURATE))
    assert trajectory.success, trajectory.message
    theta_q, omega_q = trajectory.theta[-1, 0], trajectory.omega[-1, 0]
    # theta crosses zero at the quarter period: one Newton step from the sample gives the measured crossing.
    measured_quarter = t_quarter - theta_q / omega_q
    assert abs(measured_quarter - t_quarter) / t_quarter < 1e-8
    # and a full period brings it back to the start, at rest
    full = simulate(chain, [amplitude], [0.0], Settings(method=method, t_end=period, samples=2, **ACCURATE))
    assert abs(full.theta[-1, 0] - amplitude) < 1e-8 * max(1.0, amplitude)


def _seed_params():
    return get_preset("triple-a").chain.params()


def test_triple_pendulum_small_oscillation_frequencies_match_generalized_eigenproblem(formulation):
    """Linearise each formulation's accelerations about hanging straight down (finite differences) and compare
    with the generalized eigenvalues of (K, M0), K = Hessian of V and M0 = mass matrix, both from T and V."""
    params = _seed_params()
    n = 3
    L, d, m = params[:3], params[3:6], params[6:9]
    g = params[12]
    M0 = mass_matrix(params, np.zeros(n))
    # V = sum m_i g y_Gi with y_Gi = -sum_{k<i} L_k cos th_k - d_i cos th_i: d2V/dth_k2 at 0 = g (m_k d_k + L_k sum_{i>k} m_i)
    K = np.diag([g * (m[k] * d[k] + L[k] * m[k + 1 :].sum()) for k in range(n)])
    expected = np.sort(np.sqrt(np.linalg.eigvals(np.linalg.solve(M0, K)).real))

    compiled = load_compiled(formulation, n, False)
    h = 1e-6
    jac = np.zeros((n, n))
    for k in range(n):
        step = np.zeros(n)
        step[k] = h
        plus, _ = compiled.accel(step, np.zeros(n), params)
        minus, _ = compiled.accel(-step, np.zeros(n), params)
        jac[:, k] = (plus - minus) / (2 * h)
    measured = np.sort(np.sqrt(np.linalg.eigvals(-jac).real))
    np.testing.assert_allclose(measured, expected, rtol=1e-7)


def test_hanging_at_rest_stays_at_rest(formulation):
    preset = get_preset("triple-a")
    trajectory = simulate(preset.chain, np.zeros(3), np.zeros(3), Settings(method=formulation, t_end=20.0))
    assert trajectory.success
    assert np.max(np.abs(trajectory.theta)) < 1e-12
    assert np.max(np.abs(trajectory.omega)) < 1e-12


def test_seed_reduction_moves_bar_one_as_a_compound_pendulum(formulation):
    """L2 = L3 = d2 = d3 = 0: bars 2 and 3 become point masses at E that spin freely; bar 1 is one compound
    pendulum with m = m1 + m2 + m3, m d = m1 d1 + (m2 + m3) L1, I_O = I1 + m1 d1^2 + (m2 + m3) L1^2."""
    L1, d1, m1, I1, m2, m3, g = 1.0, 0.5, 1.0, 0.2, 1.0, 1.0, 1.0
    triple = make_chain([L1, 0.0, 0.0], [d1, 0.0, 0.0], [m1, m2, m3], [I1, 0.3, 0.4], g=g)
    m = m1 + m2 + m3
    md = m1 * d1 + (m2 + m3) * L1
    I_O = I1 + m1 * d1**2 + (m2 + m3) * L1**2
    d = md / m
    single = make_chain([L1], [d], [m], [I_O - m * d * d], g=g)
    theta0 = np.array([2.0, 0.7, -1.1])
    settings = Settings(method=formulation, t_end=20.0, **ACCURATE)
    triple_run = simulate(triple, theta0, np.zeros(3), settings)
    single_run = simulate(single, theta0[:1], np.zeros(1), settings)
    assert triple_run.success and single_run.success
    np.testing.assert_allclose(triple_run.theta[:, 0], single_run.theta[:, 0], atol=1e-8)
    # the massless-lever bars only spin about E: started at rest, they stay at their angles
    np.testing.assert_allclose(triple_run.theta[:, 1:], np.broadcast_to(theta0[1:], (201, 2)), atol=1e-10)


def test_double_pendulum_limit(formulation):
    """A third bar with no length, no mass and only inertia (a free disc at F) leaves the double pendulum alone."""
    double = get_preset("double")
    bars = double.chain.bars
    triple = make_chain(
        [bars[0].L, bars[1].L, 0.0], [bars[0].d, bars[1].d, 0.0], [bars[0].m, bars[1].m, 0.0], [bars[0].I, bars[1].I, 0.4]
    )
    theta0 = np.array([*double.theta0, 0.3])
    settings = Settings(method=formulation, t_end=10.0, **ACCURATE)
    a = simulate(triple, theta0, np.zeros(3), settings)
    b = simulate(double.chain, double.theta0, np.zeros(2), settings)
    assert a.success and b.success
    np.testing.assert_allclose(a.theta[:, :2], b.theta, atol=1e-7)
