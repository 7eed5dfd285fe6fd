"""What simulate() now works out once per chain or per request gives the same results as the code it replaces
(issue 25: a short run's per-call work outside the integration loop), and a run's joint reactions are Newton's
law per bar."""

from __future__ import annotations

import numpy as np
import pytest

import physics
from physics.chain_reactions import reactions_from_motion
from physics.errors import LinkageError
from physics.model import Bar
from physics.simulate.chain_prepared import chain_arrays, sample_times

SETTINGS = physics.Settings(method="lagrange", integrator="RK45", rtol=1e-6, atol=1e-6, t_end=2.0, samples=21)


@pytest.mark.parametrize("method", ["lagrange", "dae"])
def test_a_run_reports_the_joint_reactions_of_newtons_law(method):
    """A run's joint reactions are physics.chain_reactions' at each sample's accelerations (and the DAE's own)."""
    preset = physics.get_preset("triple-c")
    chain = preset.chain
    settings = SETTINGS.model_copy(update={"method": method})
    run = physics.simulate(chain, preset.theta0, preset.omega0, settings)
    theta_ddot = np.array([physics.accelerations(chain, theta, omega, method)["theta_ddot"]
                           for theta, omega in zip(run.theta, run.omega)])
    expected = reactions_from_motion(chain.array("L"), chain.array("d"), chain.array("m"), chain.g, run.theta,
                                     run.omega, theta_ddot)
    np.testing.assert_allclose(run.joint_reactions, expected, rtol=1e-12, atol=1e-12)
    if method == "dae":
        np.testing.assert_allclose(run.joint_reactions, run.reactions, rtol=1e-9, atol=1e-9)


def test_chain_arrays_follow_the_chain_object_and_its_bars():
    chain = physics.make_chain([1.0, 2.0], [0.5, 1.0], [1.0, 2.0], [0.1, 0.2], g=9.81)
    first = chain_arrays(chain)
    assert chain_arrays(chain) is first  # remembered for this object
    np.testing.assert_array_equal(first.params, chain.params())
    np.testing.assert_array_equal(first.params_with(0.25), chain.params(damping=0.25))
    first.params_with(0.5)[0] = -1.0  # a caller writing into its copy changes nothing remembered
    np.testing.assert_array_equal(first.params, chain.params())
    chain.bars[0] = Bar(L=3.0, d=1.0, m=1.0, I=0.1)  # the list of a frozen model can still be changed in place
    again = chain_arrays(chain)
    assert again is not first
    np.testing.assert_array_equal(again.L, [3.0, 2.0])
    np.testing.assert_array_equal(again.params, chain.params())
    assert again.tip.bar == 2 and again.tip.along == 2.0


def test_sample_times_are_linspace_and_a_run_cannot_change_the_next_one():
    preset = physics.get_preset("triple-c")
    first = physics.simulate(preset.chain, preset.theta0, preset.omega0, SETTINGS, t_start=1.5)
    np.testing.assert_array_equal(first.t, np.linspace(1.5, 3.5, 21))
    first.t[:] = -1.0
    second = physics.simulate(preset.chain, preset.theta0, preset.omega0, SETTINGS, t_start=1.5)
    np.testing.assert_array_equal(second.t, np.linspace(1.5, 3.5, 21))
    np.testing.assert_array_equal(second.theta, first.theta)


@pytest.mark.parametrize(("theta", "omega", "message"), [
    (np.array([0.1, np.nan, 0.3]), np.zeros(3), "theta2 = nan: must be a finite number"),
    (np.array([0.1, 0.2, 0.3]), np.array([0.0, 0.0, np.inf]), "omega3 = inf: must be a finite number"),
    (np.array([0.1, 2e4, 0.3]), np.zeros(3), "theta2 = 20000: allowed range"),
    (np.array([0.1, 0.2]), np.zeros(3), "theta must have 3 entries"),
    (np.array([1, 2, 3]), np.array([0, 0, 1e5]), "omega3 = 100000: allowed range"),
])
def test_a_bad_start_is_refused_with_the_entry_named(theta, omega, message):
    preset = physics.get_preset("triple-c")
    with pytest.raises(LinkageError, match=message.replace("(", r"\(")):
        physics.simulate(preset.chain, theta, omega, SETTINGS)


def test_a_start_given_as_lists_or_integers_runs_as_floats():
    preset = physics.get_preset("triple-c")
    as_arrays = physics.simulate(preset.chain, np.array([1.0, 0.0, 0.0]), np.zeros(3), SETTINGS)
    as_lists = physics.simulate(preset.chain, [1, 0, 0], [0, 0, 0], SETTINGS)
    np.testing.assert_array_equal(as_lists.theta, as_arrays.theta)
    assert as_arrays.message == "ok" and as_arrays.success


def test_remembered_sample_times_keep_each_formula_and_hand_out_copies():
    """A chain's ``linspace(t0, t0 + T)`` and a mechanism's ``t0 + linspace(0, T)`` differ in the last bits; the
    one memo keeps them apart and every caller gets its own array."""
    chain_times = sample_times(0.7, 0.3, 7)
    mechanism_times = sample_times(0.7, 0.3, 7, from_zero=True)
    np.testing.assert_array_equal(chain_times, np.linspace(0.7, 0.7 + 0.3, 7))
    np.testing.assert_array_equal(mechanism_times, 0.7 + np.linspace(0.0, 0.3, 7))
    assert not np.array_equal(chain_times, mechanism_times)  # the two formulas' last bits
    chain_times[:] = -1.0
    np.testing.assert_array_equal(sample_times(0.7, 0.3, 7), np.linspace(0.7, 0.7 + 0.3, 7))
