"""A chain's reduced model (methods "reduced" and "reduced_fixed"): the general reduced model of
physics/mechanism/reduced.py on the four-bar written as a mechanism (physics/simulate/reduced_adapter.py), checked
against physics it does not share: the index-1 loop equations from the generated open-chain Lagrange code, an
independent full-coordinate integration, energy, the chain's dead-centre geometry and its damped formulations."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from physics import Bar, Chain, LinkageError, Settings, get_preset, load_compiled, simulate
from physics.kinematics import potential_energy
from physics.loop_closure import (
    DEAD_CENTRE_EVENTS,
    assemble,
    count_dead_centres,
    dead_centre_metrics,
    driving_range,
    loop_condition,
    loop_jacobian,
    loop_residual,
    tip_position,
)
from physics.mechanism.assembly import sketch_size
from physics.mechanism.chains import chain_mechanism, chain_state
from physics.mechanism.joint_coordinates import JointCoordinates
from physics.mechanism.numeric_dae import MechanismDAE
from physics.mechanism.reduced import DEAD_CENTRE_SHARE, simulate_reduced
from physics.mechanism.reduced_partition import Partition
from physics.simulate.reduced_adapter import CHAIN_JOINTS, CHAIN_SWITCH_SHARE

PRESET = get_preset("four-bar")
SEED_CHAIN, SEED_THETA0 = PRESET.chain, PRESET.theta0
SEED_L = SEED_CHAIN.array("L")

# DOP853 at rtol = atol = 1e-10 keeps the seed's energy to ~3e-8 over 100 s (measured); the bound leaves
# a factor ~30 for platform differences while still catching any error in the reduced equation (a wrong
# gamma term or mass projection drifts by 1e-2 or more).
ENERGY_TOLERANCE = 1e-6


def open_chain(params, theta, omega):
    """``(M, f)`` of the free chain from the generated Lagrange code (no constraint, no reduction)."""
    return load_compiled("lagrange", 3, False).matrix(theta, omega, params)


def full_coordinate_acceleration(params, theta, omega):
    """Independent reference: all three angles and the tip reaction R from
    ``M theta_ddot - J^T R = f``, ``J theta_ddot = -J_dot omega`` (the index-1 DAE of the loop)."""
    L = params[:3]
    M, f = open_chain(params, theta, omega)
    J = loop_jacobian(L, theta)
    jdot_omega = np.array([-np.sum(L * np.sin(theta) * omega**2), np.sum(L * np.cos(theta) * omega**2)])
    K = np.block([[M, -J.T], [J, np.zeros((2, 2))]])
    x = np.linalg.solve(K, np.concatenate([f, -jdot_omega]))
    return x[:3], x[3:]


def random_assembled_chain(rng):
    L = rng.uniform(0.5, 2.0, 3)
    pin = tip_position(L, rng.uniform(-math.pi, math.pi, 3))
    (lo, hi), *_ = driving_range(L, pin)
    theta = assemble(L, pin, [rng.uniform(lo, hi)], elbow=int(rng.choice([-1, 1])))
    d, m, I = rng.uniform(0.1, 1.0, 3) * L, rng.uniform(0.5, 2, 3), rng.uniform(0.1, 0.5, 3)
    chain = Chain(bars=[Bar(L=L[k], d=d[k], m=m[k], I=I[k]) for k in range(3)], g=9.81, pin=tuple(pin))
    return chain, theta


def joint_rates(omega):
    """Each chain joint's rate in CHAIN_JOINTS order (O: theta1, J1, J2: relative, H: theta3), from the angles."""
    omega = np.atleast_2d(omega)
    return np.abs(np.column_stack([omega[:, 0], omega[:, 1] - omega[:, 0], omega[:, 2] - omega[:, 1], omega[:, 2]]))


# ---------------------------------------------------------------------------------------------------
# The reduced equation


@pytest.mark.parametrize("joint", CHAIN_JOINTS)
def test_reduced_acceleration_matches_the_full_coordinate_loop(joint):
    """In each joint coordinate the reduced model reproduces every angular acceleration of the constrained
    system (1e-10 relative), at random four-bars and states."""
    rng = np.random.default_rng(20 + CHAIN_JOINTS.index(joint))
    checked = 0
    while checked < 20:
        chain, theta = random_assembled_chain(rng)
        s = np.cross(*loop_jacobian(chain.array("L"), theta))  # the null vector of J: the loop's one motion
        omega = rng.normal() * s / np.linalg.norm(s)
        if joint_rates(omega)[0, CHAIN_JOINTS.index(joint)] < 0.05 * joint_rates(omega).max():
            continue  # too close to this coordinate's dead centre to be a fair comparison
        mechanism = chain_mechanism(chain, theta)
        dae = MechanismDAE(mechanism)
        coordinates = JointCoordinates(mechanism, dae.constraints)
        q, qdot = chain_state(chain, theta, theta, omega)
        partition = Partition(dae, coordinates, coordinates.index(joint), q, 0.0, sketch_size(mechanism))
        state = partition.state(0.0, *partition.coordinate_of(q, qdot))
        np.testing.assert_allclose(state.q[2::3] + theta, theta, atol=1e-12)
        np.testing.assert_allclose(state.qdot[2::3], omega, atol=1e-12 * (1 + np.max(np.abs(omega))))
        reference, _ = full_coordinate_acceleration(chain.params(), theta, omega)
        np.testing.assert_allclose(state.qddot[2::3], reference, rtol=1e-10, atol=1e-10 * np.max(np.abs(reference)))
        checked += 1


def test_reduced_trajectory_matches_a_full_coordinate_integration_across_switches():
    run = simulate(SEED_CHAIN, SEED_THETA0, np.zeros(3), Settings(method="reduced", t_end=10.0, samples=201))
    assert run.success and run.stats["n_switches"] >= 2  # J1 -> O at ~6.0 s, and on

    alpha = beta = 10.0  # Baumgarte: keeps the 6-state reference on the loop
    params, pin = SEED_CHAIN.params(), np.asarray(SEED_CHAIN.pin)

    def full_rhs(t, y):
        theta, omega = y[:3], y[3:]
        M, f = open_chain(params, theta, omega)
        J = loop_jacobian(SEED_L, theta)
        jdot_omega = np.array([-np.sum(SEED_L * np.sin(theta) * omega**2), np.sum(SEED_L * np.cos(theta) * omega**2)])
        rhs_c = -jdot_omega - 2 * alpha * (J @ omega) - beta**2 * loop_residual(SEED_L, theta, pin)
        x = np.linalg.solve(np.block([[M, -J.T], [J, np.zeros((2, 2))]]), np.concatenate([f, rhs_c]))
        return np.concatenate([omega, x[:3]])

    full = solve_ivp(full_rhs, (0, 10.0), np.concatenate([SEED_THETA0, np.zeros(3)]), method="DOP853",
                     t_eval=run.t, rtol=1e-11, atol=1e-11)
    np.testing.assert_allclose(run.t, np.linspace(0.0, 10.0, 201))
    np.testing.assert_allclose(run.theta, full.y[:3].T, atol=1e-6)
    np.testing.assert_allclose(run.omega, full.y[3:].T, atol=1e-6)


# ---------------------------------------------------------------------------------------------------
# The seed four-bar over its 100 s


@pytest.fixture(scope="module")
def seed_run():
    return simulate(SEED_CHAIN, SEED_THETA0, np.zeros(3),
                    Settings(method="reduced", t_end=100.0, samples=20001, rtol=1e-10, atol=1e-10))


def test_switching_survives_the_seed_100_s_with_energy_and_closure_kept(seed_run):
    run = seed_run
    assert run.success, run.message
    assert run.t[-1] == 100.0 and run.theta.shape == (20001, 3) and np.all(np.isfinite(run.theta))
    assert np.max(np.abs(run.constraint_xy)) < 1e-9
    assert np.max(np.abs(run.constraint_velocity)) < 1e-9
    drift = np.max(np.abs(run.energy - run.energy[0]))
    assert drift < ENERGY_TOLERANCE, drift
    assert run.energy[0] == pytest.approx(potential_energy(SEED_L, SEED_CHAIN.array("d"), SEED_CHAIN.array("m"),
                                                           SEED_CHAIN.g, SEED_THETA0))
    # more than one joint serves as the coordinate; the one in use always keeps its speed share (read here off
    # the chain's own angular rates)
    index = run.stats["independent_index"]
    assert index.shape == (20001,) and len(set(index.tolist())) >= 2
    rates = joint_rates(run.omega)[1:]  # after the start from rest, where every rate is zero
    in_use = rates[np.arange(rates.shape[0]), index[1:]]
    assert np.min(in_use / rates.max(axis=1)) >= CHAIN_SWITCH_SHARE * (1 - 1e-6)
    assert run.stats["n_switches"] == len(run.stats["switch_times"]) and 10 < run.stats["n_switches"] < 100
    # angles are continuous: no sample-to-sample jump of 2 pi from unwrapping
    assert np.max(np.abs(np.diff(run.theta, axis=0))) < 0.5


def test_seed_passes_every_kind_of_dead_centre_about_14_times(seed_run):
    counts = count_dead_centres(seed_run.theta)
    for name in DEAD_CENTRE_EVENTS:
        assert 12 <= counts[name] <= 16, counts
    # and the whole loop never gets near singular: some coordinate is always a good one
    assert np.max(loop_condition(SEED_L, seed_run.theta)) < 3.0  # measured 2.69


def first_dead_centre(run, event):
    metric = dead_centre_metrics(run.theta)[:, list(DEAD_CENTRE_EVENTS).index(event)]
    k = np.flatnonzero(np.sign(metric[1:]) != np.sign(metric[:-1]))[0]
    return run.t[k], run.t[k + 1]


def test_reduced_fixed_keeps_theta1_and_fails_at_its_first_dead_centre_with_a_clear_message(seed_run):
    run = simulate(SEED_CHAIN, SEED_THETA0, np.zeros(3),
                   Settings(method="reduced_fixed", t_end=100.0, samples=20001, rtol=1e-10, atol=1e-10))
    assert run.status == -1 and np.all(run.stats["independent_index"] == 0)
    assert "theta1 stopped being a valid coordinate" in run.message
    assert "bars 2 and 3 became collinear" in run.message  # the fold: DEAD_CENTRE_EVENTS["fold"]
    assert "choose method 'reduced', which switches coordinates" in run.message and "\n" not in run.message
    t_fail = float(run.message.split("at t = ")[1].split(" s")[0])
    _, t_dead_centre = first_dead_centre(seed_run, "fold")
    assert t_dead_centre - 0.1 < t_fail <= t_dead_centre  # just before the switching run's first crossing
    # what was computed up to the failure is sound: finite, closed, the right physics
    assert np.all(np.isfinite(run.theta)) and run.t[-1] <= t_fail
    assert np.max(np.abs(run.constraint_xy)) < 1e-9
    assert np.max(np.abs(run.energy - run.energy[0])) < ENERGY_TOLERANCE
    np.testing.assert_allclose(run.theta, seed_run.theta[: run.t.size], atol=1e-6)
    last = joint_rates(run.omega[-1])[0]
    assert last[0] < 20 * DEAD_CENTRE_SHARE * last.max()  # theta1 all but stood still at the last sample


def test_the_tip_angle_kept_fails_at_its_own_dead_centre(seed_run):
    """Joint H's coordinate is theta3: kept, it stops just before bars 1 and 2 first straighten."""
    mechanism = chain_mechanism(SEED_CHAIN, SEED_THETA0)
    reduced = simulate_reduced(mechanism, 100.0, 20001, coordinate="H", switching=False, stop_as_status=True)
    assert reduced.run.status == -1 and reduced.dead_centre is not None and reduced.dead_centre.joint == "H"
    _, t_dead_centre = first_dead_centre(seed_run, "straighten")
    assert t_dead_centre - 0.1 < reduced.dead_centre.t <= t_dead_centre
    theta = reduced.run.q[:, 2::3] + SEED_THETA0
    np.testing.assert_allclose(theta, seed_run.theta[: theta.shape[0]], atol=1e-6)


def test_start_velocity_is_projected_onto_the_loop():
    run = simulate(SEED_CHAIN, SEED_THETA0, np.array([0.3, -0.2, 0.5]), Settings(method="reduced", t_end=1.0,
                                                                                 samples=2))
    assert run.success
    J = loop_jacobian(SEED_L, SEED_THETA0)
    assert np.max(np.abs(J @ run.omega[0])) < 1e-12 and np.max(np.abs(run.omega[0])) > 0.05


def test_joint_damping_balances_the_energy_lost_and_matches_the_damped_formulations():
    """Settings.damping is a torque -c times each joint's relative rate (docs/physics.md, the chain's Rayleigh
    function): E(t) - E(0) = -integral c sum_k (omega_k - omega_{k-1})^2 dt, and the run is the damped DAE's."""
    c = 0.05
    settings = dict(t_end=10.0, samples=10001, damping=c)
    run = simulate(SEED_CHAIN, SEED_THETA0, np.zeros(3), Settings(method="reduced", **settings))
    assert run.success and run.stats["n_switches"] >= 1  # the projection holds across a switch too
    relative = np.diff(np.column_stack([np.zeros(run.t.size), run.omega]), axis=1)
    power = c * np.sum(relative**2, axis=1)
    dissipated = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(run.t))])
    assert dissipated[-1] > 0.05  # the loss is real, not rounding
    np.testing.assert_allclose(run.energy - run.energy[0], -dissipated, atol=1e-5)
    dae = simulate(SEED_CHAIN, SEED_THETA0, np.zeros(3), Settings(method="dae", **settings))
    assert np.max(np.abs(run.theta - dae.theta)) < 1e-8
    assert np.max(np.abs(run.tip_reaction - dae.tip_reaction)) < 1e-7 * np.max(np.abs(dae.tip_reaction))


@pytest.mark.parametrize("name", ["four-bar", "change-point"])
def test_the_reduced_run_agrees_with_the_lagrange_run_and_its_tip_reaction(name):
    preset = get_preset(name)
    settings = dict(t_end=10.0, samples=201, rtol=1e-12, atol=1e-12)
    reduced = simulate(preset.chain, preset.theta0, preset.omega0, Settings(method="reduced", **settings))
    lagrange = simulate(preset.chain, preset.theta0, preset.omega0, Settings(method="lagrange", **settings))
    assert reduced.success and lagrange.success, reduced.message
    assert reduced.method == "reduced" and reduced.n_rhs > 0 and reduced.n_steps > 0
    assert np.max(np.abs(reduced.theta - lagrange.theta)) < 1e-7
    assert np.max(np.abs(reduced.omega - lagrange.omega)) < 1e-7 * (1 + np.max(np.abs(lagrange.omega)))
    scale = np.max(np.abs(lagrange.tip_reaction))
    assert np.max(np.abs(reduced.tip_reaction - lagrange.tip_reaction)) < 1e-6 * scale


def test_a_run_continued_from_t_start_goes_on_from_where_the_first_stopped():
    first = simulate(SEED_CHAIN, SEED_THETA0, np.zeros(3), Settings(method="reduced", t_end=5.0, samples=51))
    whole = simulate(SEED_CHAIN, SEED_THETA0, np.zeros(3), Settings(method="reduced", t_end=8.0, samples=81))
    later = simulate(SEED_CHAIN, first.theta[-1], first.omega[-1], Settings(method="reduced", t_end=3.0, samples=31),
                     t_start=5.0, continuing=True)
    assert later.t[0] == 5.0 and later.t[-1] == 8.0
    assert np.max(np.abs(later.theta - whole.theta[50:])) < 1e-7


@pytest.mark.parametrize(
    ("chain", "theta0", "match"),
    [
        (SEED_CHAIN, SEED_THETA0 + [0.0, 0.01, 0.0], "does not close the loop"),
        (Chain(bars=[Bar()] * 4, pin=tuple(tip_position(np.ones(4), [0.3, 1.0, 2.0, 0.5]))), [0.3, 1.0, 2.0, 0.5],
         "reduced model is for one-degree-of-freedom loops"),
    ],
)
def test_bad_input_raises_linkage_error(chain, theta0, match):
    with pytest.raises(LinkageError, match=match):
        simulate(chain, np.asarray(theta0, dtype=float), np.zeros(len(theta0)), Settings(method="reduced"))
