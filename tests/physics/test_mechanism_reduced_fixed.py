"""``method = "reduced_fixed"`` for every mobility-1 mechanism (issue 24: one registry of methods for chains and
mechanisms): the reduced model kept in the description's first free joint, stopping with a status and the
sentence that names the fix at that joint's dead centre.

Checked against what it does not share: the chain's own fixed-coordinate run (the four-bar, whose first joint is
``O``, theta1), the switching model's run up to the stop, the loop's closure and energy conservation."""

import numpy as np
import pytest

from physics import LinkageError, Settings, get_preset, simulate
from physics.mechanism import MECHANISM_PRESETS
from physics.mechanism.chains import chain_mechanism, chain_state
from physics.mechanism.reduced import fixed_coordinate
from physics.mechanism.simulate import RUN_METHODS, simulate_mechanism
from physics.status import Status

FOUR_BAR = get_preset("four-bar")
CHAIN, THETA0 = FOUR_BAR.chain, np.asarray(FOUR_BAR.theta0, dtype=float)


def _four_bar_as_mechanism():
    mechanism = chain_mechanism(CHAIN, THETA0)
    q0, qdot0 = chain_state(CHAIN, THETA0, THETA0, np.zeros(3))
    return mechanism, q0, qdot0


def test_every_method_of_the_registry_runs_a_mechanism():
    assert "reduced_fixed" in RUN_METHODS and "reduced" in RUN_METHODS


def test_the_kept_joint_is_the_first_free_one():
    mechanism, _, _ = _four_bar_as_mechanism()
    assert fixed_coordinate(mechanism) == "O"  # the chain's theta1
    slider_crank = MECHANISM_PRESETS["slider-crank"]()
    assert fixed_coordinate(slider_crank) == slider_crank.joints[0].name


def test_the_four_bar_as_a_mechanism_stops_where_the_chains_fixed_model_stops():
    """The same run two ways: the chain's reduced_fixed (theta1 kept) and the mechanism's (joint O kept)."""
    chain_run = simulate(CHAIN, THETA0, np.zeros(3),
                         Settings(method="reduced_fixed", t_end=30.0, samples=3001, rtol=1e-10, atol=1e-10))
    assert chain_run.status == -1, "the seed four-bar's fixed coordinate must meet a dead centre within 30 s"
    mechanism, q0, qdot0 = _four_bar_as_mechanism()
    run = simulate_mechanism(mechanism, 30.0, 3001, method="reduced_fixed", q0=q0, qdot0=qdot0,
                             rtol=1e-10, atol=1e-10)
    assert run.status == int(Status.SINGULAR) and not run.success
    assert run.method == "reduced_fixed"
    assert "joint 'O' stopped being a valid coordinate" in run.message
    assert "choose method 'reduced'" in run.message and "\n" not in run.message
    t_fail = float(run.message.split("at t = ")[1].split(" s")[0])
    t_chain = float(chain_run.message.split("at t = ")[1].split(" s")[0])
    assert abs(t_fail - t_chain) < 1e-6
    # what was computed is the chain's: the same angles (body turn + sketch angle) at the same times
    count = min(len(run.t), len(chain_run.t))
    assert count > 100
    np.testing.assert_allclose(run.t[:count], chain_run.t[:count], atol=1e-12)
    theta = run.q[:count, 2::3] + THETA0
    np.testing.assert_allclose(theta, chain_run.theta[:count], atol=1e-8)
    energy = run.kinetic + run.potential
    assert np.max(np.abs(energy - energy[0])) < 1e-6


def test_before_the_stop_it_is_the_switching_models_run():
    """The two reduced methods integrate the same equation; they part only where the fixed one stops."""
    six_bar = MECHANISM_PRESETS["stephenson-six-bar"]()
    fixed = simulate_mechanism(six_bar, 2.0, 201, method="reduced_fixed", rtol=1e-11, atol=1e-11)
    switching = simulate_mechanism(six_bar, 2.0, 201, method="reduced", rtol=1e-11, atol=1e-11)
    count = min(len(fixed.t), len(switching.t))
    assert count > 10
    np.testing.assert_allclose(fixed.q[:count], switching.q[:count], atol=1e-6)
    energy = fixed.kinetic + fixed.potential
    assert np.max(np.abs(energy - energy[0])) < 1e-6 * max(1.0, np.max(np.abs(energy)))


def test_a_mechanism_its_motors_fix_is_refused_in_one_line():
    with pytest.raises(LinkageError, match="no free coordinate") as error:
        simulate_mechanism(MECHANISM_PRESETS["crank-rocker"](), 1.0, 11, method="reduced_fixed")
    assert "\n" not in str(error.value)
