"""The variational integrator (``integrate_variational``): order, symplecticity, long-run energy, the closed loop.

It steps ``(theta, p)`` with the midpoint discrete Lagrangian built from the Lagrange derivation's mass matrix
and force; the checks below are independent of how it is written: the symplectic condition of its one-step map
measured by finite differences (and, as a control, violated by the midpoint rule in ``(theta, omega)``), the
convergence order against a tight DOP853 run, the pinned tip held exactly by RATTLE, dissipation with damping.
The bounded energy error on chaotic motion is case 2 of the stability study (tests/physics/test_stability.py).
"""

import numpy as np
import pytest

from physics import LinkageError, Settings, get_preset, load_compiled, simulate
from physics.model import validated

from ..conftest import random_params


def _mass(compiled, theta, params):
    return compiled.mass_and_force(theta, np.zeros(theta.size), params)[0]


def _one_step(compiled, integrator, theta, momentum, params, h):
    """The one-step map (theta, p) -> (theta', p') of an integrator, with p = M(theta) omega."""
    n = theta.size
    omega = np.linalg.solve(_mass(compiled, theta, params), momentum)
    y0 = np.concatenate([theta, omega])
    t_eval = np.array([0.0, h])
    y_out = np.empty((2, 2 * n))
    cond = np.empty(0)
    if integrator == "variational":
        status = compiled.integrate_variational(y0, 0.0, h, h, t_eval, params, y_out, cond)[0]
    else:
        status = compiled.integrate_midpoint(y0, 0.0, h, h, t_eval, params, 0.0, 0.0, False, y_out, cond)[0]
    assert status == 0
    theta1, omega1 = y_out[1, :n], y_out[1, n:]
    return np.concatenate([theta1, _mass(compiled, theta1, params) @ omega1])


def _symplectic_defect(compiled, integrator, state, params, h, eps=1e-6):
    """max |Phi^T J Phi - J| for the one-step map's Jacobian Phi (central differences)."""
    size = state.size
    n = size // 2
    jacobian = np.empty((size, size))
    for j in range(size):
        up, down = state.copy(), state.copy()
        up[j] += eps
        down[j] -= eps
        jacobian[:, j] = (_one_step(compiled, integrator, up[:n], up[n:], params, h)
                          - _one_step(compiled, integrator, down[:n], down[n:], params, h)) / (2 * eps)
    J = np.block([[np.zeros((n, n)), np.eye(n)], [-np.eye(n), np.zeros((n, n))]])
    return float(np.max(np.abs(jacobian.T @ J @ jacobian - J)))


def test_variational_step_is_symplectic_and_the_midpoint_rule_in_theta_omega_is_not(rng):
    compiled = load_compiled("lagrange", 3, False)
    params = random_params(rng, 3)
    theta = rng.uniform(-2.0, 2.0, 3)
    momentum = _mass(compiled, theta, params) @ rng.uniform(-2.0, 2.0, 3)
    state = np.concatenate([theta, momentum])
    h = 0.05
    variational = _symplectic_defect(compiled, "variational", state, params, h)
    midpoint = _symplectic_defect(compiled, "midpoint", state, params, h)
    assert variational < 1e-7, variational
    assert midpoint > 1e3 * variational and midpoint > 1e-5, (midpoint, variational)


@pytest.mark.parametrize("preset_name", ["triple-a", "four-bar"])
def test_second_order_convergence(preset_name):
    preset = get_preset(preset_name)
    horizon = 2.0
    reference = simulate(preset.chain, preset.theta0, preset.omega0,
                         Settings(integrator="DOP853", rtol=1e-12, atol=1e-12, t_end=horizon, samples=3))
    errors = []
    for h in (0.02, 0.01, 0.005):
        run = simulate(preset.chain, preset.theta0, preset.omega0,
                       Settings(integrator="variational", step=h, t_end=horizon, samples=3))
        assert run.status == 0, run.message
        errors.append(float(np.max(np.abs(run.theta[-1] - reference.theta[-1]))))
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    assert all(3.5 < r < 4.5 for r in ratios), (errors, ratios)


def _windows(t, error, t_end):
    early = error[(t >= t_end / 10) & (t <= t_end / 5)].max()
    late = error[t >= t_end / 2].max()
    return late / early


def test_small_steps_keep_converging_on_the_loop():
    """At small steps the increment, not the new angle, must be what Newton solves for: otherwise v = (q1 - q0)/h
    inherits |q| eps / h of rounding and, near a turning point, Newton cannot meet a tolerance relative to q1."""
    preset = get_preset("four-bar")
    horizon = 20.0
    reference = simulate(preset.chain, preset.theta0, preset.omega0,
                         Settings(integrator="DOP853", rtol=1e-13, atol=1e-13, t_end=horizon, samples=3))
    run = simulate(preset.chain, preset.theta0, preset.omega0,
                   Settings(integrator="variational", step=1e-4, t_end=horizon, samples=3))
    assert run.status == 0, run.message
    assert np.max(np.abs(run.theta[-1] - reference.theta[-1])) < 1e-6


def test_pinned_chain_keeps_its_tip_on_the_pin_and_its_energy():
    preset = get_preset("four-bar")
    run = simulate(preset.chain, preset.theta0, preset.omega0,
                   Settings(integrator="variational", step=0.002, t_end=100.0, samples=2001))
    assert run.status == 0, run.message
    assert np.max(np.abs(run.constraint_xy)) < 1e-12
    assert np.max(np.abs(run.constraint_velocity)) < 1e-12
    error = np.abs(run.energy - run.energy[0]) / abs(run.energy[0])
    assert error.max() < 1e-3
    assert _windows(run.t, error, 100.0) < 1.5


def test_damping_dissipates_energy_monotonically():
    preset = get_preset("triple-a")
    run = simulate(preset.chain, preset.theta0, preset.omega0,
                   Settings(integrator="variational", step=0.005, t_end=20.0, samples=2001, damping=0.2))
    assert run.status == 0, run.message
    energy = run.energy[::10]  # node-to-node (samples between nodes are interpolated)
    assert np.all(np.diff(energy) < 1e-9 * abs(energy[0]))
    assert energy[0] - energy[-1] > 1e-2 * abs(energy[0])


def test_needs_the_lagrange_formulation():
    with pytest.raises(LinkageError, match="method = lagrange"):
        validated(Settings, integrator="variational", method="newton_euler")
    compiled = load_compiled("newton_euler", 2, False)
    assert not compiled.has_lagrangian
    assert load_compiled("lagrange", 2, False).has_lagrangian
