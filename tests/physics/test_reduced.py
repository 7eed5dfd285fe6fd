"""Reduced one-degree-of-freedom model of the four-bar: dynamics, coordinate switching, dead centres."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from physics.assembly import (
    DEAD_CENTRE_EVENTS,
    assemble,
    count_dead_centres,
    dead_centre_metrics,
    driving_range,
    loop_jacobian,
    loop_residual,
    tip_position,
)
from physics.errors import LinkageError
from physics.reduced import (
    DEAD_CENTRE_RCOND,
    SWITCH_RCOND,
    _Partition,
    dependent_pair,
    elbow_of,
    open_chain_mass_and_forcing,
    partition_conditioning,
    potential_energy,
    simulate_reduced,
)

SEED = dict(
    L=np.array([1.0, 1.0, 2.0]),
    d=np.array([0.5, 0.5, 0.5]),
    m=np.array([1.0, 1.0, 1.0]),
    I=np.array([0.2, 0.3, 0.4]),
    g=1.0,
)
SEED_THETA0 = np.array([math.pi - math.pi / 30, math.pi / 2, 0.0])
SEED_PIN = tip_position(SEED["L"], SEED_THETA0)
SEED_PARAMS = np.concatenate([SEED["L"], SEED["d"], SEED["m"], SEED["I"], [SEED["g"]], SEED_PIN, [0.0]])

# DOP853 at rtol = atol = 1e-10 keeps the seed's energy to ~3e-8 over 100 s (measured); the bound leaves
# a factor ~30 for platform differences while still catching any error in the reduced equation (a wrong
# gamma term or mass projection drifts by 1e-2 or more).
ENERGY_TOLERANCE = 1e-6


def full_coordinate_acceleration(params, theta, omega):
    """Independent reference: all three angles and the tip reaction R from
    ``M theta_ddot - J^T R = f``, ``J theta_ddot = -J_dot omega`` (the index-1 DAE of the loop)."""
    L = params[:3]
    M, f = open_chain_mass_and_forcing(theta, omega, params)
    J = loop_jacobian(L, theta)
    jdot_omega = np.array([-np.sum(L * np.sin(theta) * omega**2), np.sum(L * np.cos(theta) * omega**2)])
    K = np.block([[M, -J.T], [J, np.zeros((2, 2))]])
    x = np.linalg.solve(K, np.concatenate([f, -jdot_omega]))
    return x[:3], x[3:]


def random_assembled_state(rng):
    L = rng.uniform(0.5, 2.0, 3)
    pin = tip_position(L, rng.uniform(-math.pi, math.pi, 3))
    (lo, hi), *_ = driving_range(L, pin)
    theta = assemble(L, pin, [rng.uniform(lo, hi)], elbow=int(rng.choice([-1, 1])))
    d, m, I = rng.uniform(0.1, 1.0, 3) * L, rng.uniform(0.5, 2, 3), rng.uniform(0.1, 0.5, 3)
    params = np.concatenate([L, d, m, I, [9.81], pin, [0.0]])
    return L, pin, theta, params


# ---------------------------------------------------------------------------------------------------
# The hand-derived open chain


def test_mass_matrix_matches_the_kinematic_definition():
    kinematics = pytest.importorskip("physics.kinematics")
    rng = np.random.default_rng(11)
    for n in (1, 3, 5):
        params = np.concatenate([rng.uniform(0.5, 2, n), rng.uniform(0.1, 0.5, n), rng.uniform(0.5, 2, n),
                                 rng.uniform(0.1, 0.5, n), [9.81, 0.0, 0.0, 0.0]])
        theta = rng.uniform(-3, 3, n)
        M, _ = open_chain_mass_and_forcing(theta, np.zeros(n), params)
        np.testing.assert_allclose(M, kinematics.mass_matrix(params, theta), rtol=1e-13, atol=1e-14)


def test_forcing_matches_lagrange_equations_by_finite_differences():
    """``f = dL/dtheta - M_dot omega`` with the Lagrangian ``0.5 omega^T M omega - V``, differentiated numerically."""
    rng = np.random.default_rng(12)
    n = 3
    params = np.concatenate([rng.uniform(0.5, 2, n), rng.uniform(0.1, 0.5, n), rng.uniform(0.5, 2, n),
                             rng.uniform(0.1, 0.5, n), [9.81, 0.0, 0.0, 0.0]])
    L, d, m, g = params[:n], params[n:2 * n], params[2 * n:3 * n], params[4 * n]
    theta, omega = rng.uniform(-3, 3, n), rng.normal(size=n)

    def lagrangian(th):
        M, _ = open_chain_mass_and_forcing(th, omega, params)
        return 0.5 * omega @ M @ omega - potential_energy(L, d, m, g, th)

    h = 1e-6
    dL_dtheta = np.array([(lagrangian(theta + h * e) - lagrangian(theta - h * e)) / (2 * h) for e in np.eye(n)])
    M_plus, _ = open_chain_mass_and_forcing(theta + h * omega, omega, params)
    M_minus, _ = open_chain_mass_and_forcing(theta - h * omega, omega, params)
    M_dot_omega = (M_plus - M_minus) @ omega / (2 * h)
    _, f = open_chain_mass_and_forcing(theta, omega, params)
    np.testing.assert_allclose(f, dL_dtheta - M_dot_omega, atol=1e-7)


# ---------------------------------------------------------------------------------------------------
# The reduced equation


@pytest.mark.parametrize("independent", [0, 1, 2])
def test_reduced_acceleration_matches_the_full_coordinate_loop(independent):
    """Each partition reproduces every angular acceleration of the constrained system (1e-10 relative)."""
    rng = np.random.default_rng(20 + independent)
    checked = 0
    while checked < 20:
        L, pin, theta, params = random_assembled_state(rng)
        if partition_conditioning(theta)[independent] < 0.05:
            continue  # too close to this coordinate's dead centre to be a fair comparison
        pair = list(dependent_pair(independent))
        partition = _Partition(L, pin, params, independent, elbow_of(*theta[pair]), open_chain_mass_and_forcing)
        np.testing.assert_allclose(partition.configuration(theta[independent], theta), theta, atol=1e-12)
        q_dot = rng.normal()
        s = partition.null_vector(theta)
        J_dep = loop_jacobian(L, theta)[:, pair]
        np.testing.assert_allclose(loop_jacobian(L, theta) @ s, 0.0, atol=1e-12)
        omega = s * q_dot
        _, q_ddot = partition.rhs(0.0, [theta[independent], q_dot])
        # theta_ddot = s q_ddot + gamma with gamma from the acceleration constraint
        w2 = L * omega**2
        jdot_omega = np.array([-np.dot(w2, np.sin(theta)), np.dot(w2, np.cos(theta))])
        gamma = np.zeros(3)
        gamma[pair] = np.linalg.solve(J_dep, -jdot_omega)
        reduced = s * q_ddot + gamma
        reference, _ = full_coordinate_acceleration(params, theta, omega)
        np.testing.assert_allclose(reduced, reference, rtol=1e-10, atol=1e-10 * np.max(np.abs(reference)))
        checked += 1


def test_reduced_trajectory_matches_a_full_coordinate_integration_across_switches():
    t_eval = np.linspace(0.0, 10.0, 201)
    reduced = simulate_reduced(**SEED, pin=SEED_PIN, theta0=SEED_THETA0, t_end=10.0, t_eval=t_eval)
    assert reduced.status == 0 and reduced.n_switches >= 2  # first switches at ~4.2 s and ~7.2 s

    alpha = beta = 10.0  # Baumgarte: keeps the 6-state reference on the loop

    def full_rhs(t, y):
        theta, omega = y[:3], y[3:]
        params = SEED_PARAMS
        L = params[:3]
        M, f = open_chain_mass_and_forcing(theta, omega, params)
        J = loop_jacobian(L, theta)
        jdot_omega = np.array([-np.sum(L * np.sin(theta) * omega**2), np.sum(L * np.cos(theta) * omega**2)])
        rhs_c = -jdot_omega - 2 * alpha * (J @ omega) - beta**2 * loop_residual(L, theta, SEED_PIN)
        x = np.linalg.solve(np.block([[M, -J.T], [J, np.zeros((2, 2))]]), np.concatenate([f, rhs_c]))
        return np.concatenate([omega, x[:3]])

    full = solve_ivp(full_rhs, (0, 10.0), np.concatenate([SEED_THETA0, np.zeros(3)]), method="DOP853",
                     t_eval=t_eval, rtol=1e-11, atol=1e-11)
    np.testing.assert_allclose(reduced.t, t_eval)
    np.testing.assert_allclose(reduced.theta, full.y[:3].T, atol=1e-6)
    np.testing.assert_allclose(reduced.omega, full.y[3:].T, atol=1e-6)


# ---------------------------------------------------------------------------------------------------
# The seed four-bar over its 100 s


@pytest.fixture(scope="module")
def seed_run():
    t_eval = np.linspace(0.0, 100.0, 20001)
    return simulate_reduced(**SEED, pin=SEED_PIN, theta0=SEED_THETA0, t_end=100.0, t_eval=t_eval,
                            rtol=1e-10, atol=1e-10)


def test_switching_survives_the_seed_100_s_with_energy_and_closure_kept(seed_run):
    run = seed_run
    assert run.status == 0, run.message
    assert run.t[-1] == 100.0 and run.theta.shape == (20001, 3) and np.all(np.isfinite(run.theta))
    assert np.max(np.abs(run.constraint_xy)) < 1e-9
    assert np.max(np.abs(run.constraint_velocity)) < 1e-9
    drift = np.max(np.abs(run.energy - run.energy[0]))
    assert drift < ENERGY_TOLERANCE, drift
    assert run.energy[0] == pytest.approx(potential_energy(SEED["L"], SEED["d"], SEED["m"], 1.0, SEED_THETA0))
    # more than one angle serves as the coordinate; the one in use is always well conditioned
    assert len(set(run.independent_index.tolist())) >= 2
    in_use = run.conditioning[np.arange(run.t.size), run.independent_index]
    assert np.min(in_use) >= SWITCH_RCOND * (1 - 1e-6)
    assert run.n_switches == len(run.switch_times) and 10 < run.n_switches < 100
    # angles are continuous: no sample-to-sample jump of 2 pi from unwrapping
    assert np.max(np.abs(np.diff(run.theta, axis=0))) < 0.5


def test_seed_passes_every_kind_of_dead_centre_about_14_times(seed_run):
    counts = count_dead_centres(seed_run.theta)
    for name in DEAD_CENTRE_EVENTS:
        assert 12 <= counts[name] <= 16, counts
    # and the whole loop never gets near singular: some angle is always a good coordinate
    assert np.min(seed_run.conditioning.max(axis=1)) > 0.3  # measured 0.40


def first_dead_centre(run, event):
    metric = dead_centre_metrics(run.theta)[:, list(DEAD_CENTRE_EVENTS).index(event)]
    k = np.flatnonzero(np.sign(metric[1:]) != np.sign(metric[:-1]))[0]
    return run.t[k], run.t[k + 1]


@pytest.mark.parametrize("independent, event", [(0, "fold"), (1, "parallel"), (2, "straighten")])
def test_fixed_coordinate_fails_at_its_first_dead_centre_with_a_clear_message(seed_run, independent, event):
    run = simulate_reduced(**SEED, pin=SEED_PIN, theta0=SEED_THETA0, t_end=100.0, t_eval=seed_run.t,
                           switching=False, independent_index=independent)
    assert run.status == -1
    bars = DEAD_CENTRE_EVENTS[event]
    assert f"theta{independent + 1} stopped being a valid coordinate" in run.message
    assert f"bars {bars[0]} and {bars[1]} became collinear" in run.message
    t_fail = float(run.message.split("at t = ")[1].split(" s")[0])
    _, t_dead_centre = first_dead_centre(seed_run, event)
    assert t_dead_centre - 0.1 < t_fail <= t_dead_centre  # just before the switching run's first crossing
    # what was computed up to the failure is sound: finite, closed, the right physics
    assert np.all(np.isfinite(run.theta)) and run.t[-1] <= t_fail
    assert np.max(np.abs(run.constraint_xy)) < 1e-9
    assert np.max(np.abs(run.energy - run.energy[0])) < ENERGY_TOLERANCE
    np.testing.assert_allclose(run.theta, seed_run.theta[: run.t.size], atol=1e-6)
    assert partition_conditioning(run.theta[-1])[independent] < 2 * DEAD_CENTRE_RCOND


def test_default_fixed_coordinate_is_theta1():
    run = simulate_reduced(**SEED, pin=SEED_PIN, theta0=SEED_THETA0, t_end=10.0, switching=False)
    assert run.status == -1 and "theta1" in run.message and np.all(run.independent_index == 0)


def test_output_at_every_accepted_step_without_t_eval():
    run = simulate_reduced(**SEED, pin=SEED_PIN, theta0=SEED_THETA0, t_end=5.0)
    assert run.status == 0 and run.t[0] == 0.0 and run.t[-1] == 5.0
    assert np.all(np.diff(run.t) > 0) and run.t.size > 20
    assert np.max(np.abs(run.constraint_xy)) < 1e-12


def test_start_velocity_is_projected_onto_the_loop():
    run = simulate_reduced(**SEED, pin=SEED_PIN, theta0=SEED_THETA0, t_end=1.0, t_eval=[0.0, 1.0],
                           omega0=np.array([0.3, -0.2, 0.5]))
    assert run.status == 0
    J = loop_jacobian(SEED["L"], SEED_THETA0)
    assert np.max(np.abs(J @ run.omega[0])) < 1e-12 and np.max(np.abs(run.omega[0])) > 0.05


def test_a_damping_force_is_projected_and_balances_the_energy_lost():
    """A forcing with damping torques -c omega (read from params[-1]): E(t) - E(0) = -integral c |omega|^2 dt."""

    def damped(theta, omega, params):
        M, f = open_chain_mass_and_forcing(theta, omega, params)
        return M, f - params[-1] * omega

    c = 0.05
    t_eval = np.linspace(0.0, 6.0, 6001)
    run = simulate_reduced(**SEED, pin=SEED_PIN, theta0=SEED_THETA0, t_end=6.0, t_eval=t_eval,
                           mass_and_forcing=damped, damping=c)
    assert run.status == 0 and run.n_switches >= 1  # the projection holds across a switch too
    power = c * np.sum(run.omega**2, axis=1)
    dissipated = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(run.t))])
    assert dissipated[-1] > 0.05  # the loss is real, not rounding
    np.testing.assert_allclose(run.energy - run.energy[0], -dissipated, atol=1e-5)
    with pytest.raises(LinkageError, match="damping"):
        simulate_reduced(**SEED, pin=SEED_PIN, theta0=SEED_THETA0, t_end=1.0, damping=c)


@pytest.mark.parametrize(
    "change, match",
    [
        (dict(theta0=SEED_THETA0 + [0.0, 0.01, 0.0]), "does not close the loop"),
        (dict(L=np.ones(4)), "expected 3 entries"),
        (dict(t_end=-1.0), "t_end"),
        (dict(independent_index=3), "independent_index"),
        (dict(t_eval=[0.0, 200.0]), "t_eval"),
    ],
)
def test_bad_input_raises_linkage_error(change, match):
    arguments = dict(SEED, pin=SEED_PIN, theta0=SEED_THETA0, t_end=1.0) | change
    with pytest.raises(LinkageError, match=match):
        simulate_reduced(**arguments)
