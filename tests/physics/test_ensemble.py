"""Ensembles: batched fixed-step RK4 copies (physics.ensemble)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from physics import LinkageError, Settings, get_preset, simulate
from physics.ensemble import Ensemble, initial_states


def test_copies_start_a_spread_apart_and_step_in_whole_steps():
    preset = get_preset("triple-c")
    ensemble = Ensemble(preset.chain, preset.theta0, preset.omega0, count=4, spread=1e-9, step=0.01)
    np.testing.assert_allclose(ensemble.theta - preset.theta0, 1e-9 * np.arange(4)[:, None] * np.ones(3), atol=1e-15)
    theta, omega = ensemble.advance(0.006)  # less than a step: nothing moves yet
    assert ensemble.steps_taken == 0 and np.array_equal(theta, ensemble.theta)
    ensemble.advance(0.006)  # the remainder carries over: one step now
    assert ensemble.steps_taken == 1
    theta, omega = ensemble.advance(0.5)
    assert ensemble.steps_taken == 51 and math.isclose(ensemble.time, 0.51)  # 0.002 carried + 0.5
    assert theta.shape == omega.shape == (4, 3)
    assert ensemble.joints().shape == (4, 4, 2)
    assert ensemble.alive.all() and ensemble.message == "ok"


def test_each_copy_is_independent_of_the_batch_it_is_in():
    preset = get_preset("triple-a")
    big = Ensemble(preset.chain, preset.theta0, preset.omega0, count=50, spread=1e-3, step=0.005)
    alone = Ensemble(preset.chain, preset.theta0 + 7e-3, preset.omega0, count=1, spread=0.0, step=0.005)
    big.advance(1.0)
    alone.advance(1.0)
    assert np.array_equal(big.theta[7], alone.theta[0])  # bit for bit, as the chaos map relies on


@pytest.mark.parametrize("method", ["newton_euler", "lagrange", "dae"])
def test_rk4_copy_follows_the_adaptive_reference(method):
    preset = get_preset("triple-b")
    ensemble = Ensemble(preset.chain, preset.theta0, preset.omega0, method=method, count=1, step=1 / 240)
    ensemble.advance(2.0)
    reference = simulate(preset.chain, preset.theta0, preset.omega0,
                         Settings(method=method, integrator="DOP853", rtol=1e-12, atol=1e-12, t_end=ensemble.time,
                                  samples=2))
    assert np.max(np.abs(ensemble.theta[0] - reference.theta[-1])) < 1e-7
    energy = ensemble.energy()
    assert abs(energy[0] - reference.energy[0]) < 1e-7


def test_nearby_copies_fan_apart_on_a_chaotic_case():
    preset = get_preset("triple-c")
    ensemble = Ensemble(preset.chain, preset.theta0, preset.omega0, count=8, spread=1e-9)
    start = ensemble.tip_spread()
    ensemble.advance(5.0)
    at_5 = ensemble.tip_spread()
    ensemble.advance(20.0)
    at_25 = ensemble.tip_spread()
    assert start < 1e-7
    assert at_25 > 1e3 * at_5 > 0.0  # exponential divergence, not a drift


def test_closed_loop_copies_are_assembled_and_stay_on_the_loop():
    preset = get_preset("four-bar")
    theta, omega = initial_states(preset.chain, preset.theta0, preset.omega0, 3, 1e-6)
    L = preset.chain.array("L")
    tips = np.stack([np.sum(L * np.sin(theta), axis=1), -np.sum(L * np.cos(theta), axis=1)], axis=1)
    np.testing.assert_allclose(tips, np.tile(preset.chain.pin, (3, 1)), atol=1e-12)
    assert np.ptp(theta[:, 0]) > 1e-6  # the driving angle differs between copies
    ensemble = Ensemble(preset.chain, preset.theta0, preset.omega0, count=3, spread=1e-6)
    ensemble.advance(5.0)
    gap = ensemble.joints()[:, -1, :] - np.asarray(preset.chain.pin)
    assert np.max(np.hypot(gap[:, 0], gap[:, 1])) < 1e-6  # Baumgarte holds the loop


def test_a_copy_at_a_singular_position_is_reported_not_hidden():
    chain = get_preset("change-point").chain
    theta1 = math.pi / 2 - 1e-8  # all four links within 1e-8 rad of one line
    ensemble = Ensemble(chain, np.array([theta1, math.pi / 2, theta1 + math.pi]), np.zeros(3), count=2, spread=0.0)
    ensemble.advance(0.05)
    assert not ensemble.alive.any()
    assert "singular" in ensemble.message and "copy 0" in ensemble.message


@pytest.mark.parametrize(
    "kwargs, field",
    [({"count": 0}, "count"), ({"step": 0.0}, "step"), ({"step": 1.0}, "step"), ({"method": "reduced"}, "method"),
     ({"spread": float("nan")}, "spread")],
)
def test_bad_arguments_name_the_field(kwargs, field):
    preset = get_preset("double")
    with pytest.raises(LinkageError, match=field):
        Ensemble(preset.chain, preset.theta0, preset.omega0, **kwargs)
    ensemble = Ensemble(preset.chain, preset.theta0, preset.omega0, count=1)
    with pytest.raises(LinkageError, match="dt"):
        ensemble.advance(-1.0)


def test_anchoring_moves_copy_zero_and_keeps_every_difference():
    """Ensemble.anchor (the app keeps copy 0 on the displayed pendulum): one common shift."""
    preset = get_preset("triple-a")
    ensemble = Ensemble(preset.chain, preset.theta0, preset.omega0, "lagrange", 8, 1e-6)
    ensemble.advance(0.5)
    theta, omega = ensemble.theta.copy(), ensemble.omega.copy()
    target_theta, target_omega = theta[0] + 1e-3, omega[0] - 2e-3
    size = ensemble.anchor(target_theta, target_omega)
    assert size == pytest.approx(2e-3)
    assert np.array_equal(ensemble.theta[0], target_theta) and np.array_equal(ensemble.omega[0], target_omega)
    assert np.allclose(ensemble.theta - ensemble.theta[0], theta - theta[0], atol=1e-15, rtol=0)
    assert np.allclose(ensemble.omega - ensemble.omega[0], omega - omega[0], atol=1e-15, rtol=0)
    with pytest.raises(LinkageError):
        ensemble.anchor(np.full(3, np.nan), target_omega)


def test_prepare_compiles_on_a_scratch_copy_and_leaves_the_copies_as_they_were():
    """The app compiles the step in its worker (Ensemble.prepare) so that no frame waits for it: the copies, their
    time and their conditions must be exactly as if it had not been called."""
    preset = get_preset("triple-a")
    prepared = Ensemble(preset.chain, preset.theta0, preset.omega0, count=5, spread=1e-6, step=0.01)
    plain = Ensemble(preset.chain, preset.theta0, preset.omega0, count=5, spread=1e-6, step=0.01)
    prepared.prepare()
    assert np.array_equal(prepared.theta, plain.theta) and np.array_equal(prepared.omega, plain.omega)
    assert prepared.steps_taken == 0 and np.array_equal(prepared.condition, plain.condition)
    prepared.advance(0.1)
    plain.advance(0.1)
    assert np.array_equal(prepared.theta, plain.theta) and np.array_equal(prepared.omega, plain.omega)
    assert prepared.message == plain.message == "ok" and prepared.alive.all()
