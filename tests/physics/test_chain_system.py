"""A chain's compiled system (physics/simulate/chain_system.py: the chain written as a mechanism, the one route
physics.simulate takes), and the callers that run it themselves (the seed report's ode45 replay, the ensemble,
``accelerations``, the free-body diagrams), against the chain's own formulas (tests/physics/chain_formulas.py):
the chain's independent derivations (:func:`physics.load_compiled`) evaluated at the same states.

:data:`ROUNDING` 1e-11 relative: the same equations summed in another order. The ensemble's pinned copies are
held by Baumgarte's terms, which amplify the loop's rounding; over its short runs here they stay a hundred times
inside it.
"""

from __future__ import annotations

import numpy as np
import pytest

import physics
from physics import LinkageError, Settings, accelerations, get_preset, load_compiled, simulate
from physics import codegen as codegen_module
from physics.codegen import cache as cache_module
from physics.ensemble import BAUMGARTE_ALPHA, BAUMGARTE_BETA, Ensemble
from physics.fbd import free_bodies
from physics.model import FORMULATION_NAMES
from physics.seed_report import _ode45_as_called
from physics.simulate.chain_system import chain_system

from .chain_formulas import ROUNDING, assert_run_follows_chain_formulas, relative

PRESETS = ("single", "triple-a", "triple-c", "four-bar")


def test_the_system_is_the_chain_as_a_mechanism():
    """Not the chain's own generated system: the four-bar's coordinates in its tree's order."""
    chain = get_preset("four-bar").chain
    system = chain_system(chain, "lagrange")
    assert system.route is not None
    assert system.compiled is not load_compiled("lagrange", 3, True)
    np.testing.assert_array_equal(system.order, [0, 2, 1])
    np.testing.assert_array_equal(system.order[system.inverse], np.arange(3))
    theta = np.array([0.1, 0.2, 0.3])
    np.testing.assert_array_equal(system.bars(system.coordinates(theta)), theta)
    np.testing.assert_array_equal(system.state(theta, 2 * theta), [0.1, 0.3, 0.2, 0.2, 0.6, 0.4])


def test_an_unknown_method_is_refused():
    with pytest.raises(ValueError, match="method = 'reduced'"):
        chain_system(get_preset("single").chain, "reduced")


@pytest.mark.parametrize("preset", PRESETS)
@pytest.mark.parametrize("method", FORMULATION_NAMES)
def test_one_state_solves_to_the_chains_accelerations_and_reactions(preset, method):
    """At a state in motion: the angular accelerations by ``theta_ddot_index``, the DAE's joint reactions by
    ``reaction_index`` and a pinned chain's tip reaction by ``tip_reaction_index`` (where the system solves for
    it), read in the chain's order, are the chain's own system's."""
    chosen = get_preset(preset)
    chain = chosen.chain
    omega = chosen.omega0 + np.linspace(0.3, -0.2, chain.n)
    if chain.pinned:  # the tip's velocity must stay on the pin: a rate of the loop's one freedom
        run = simulate(chain, chosen.theta0, chosen.omega0, Settings(method="dae", t_end=0.3, samples=2))
        theta, omega = run.theta[-1], run.omega[-1]
    else:
        theta = chosen.theta0
    system = chain_system(chain, method, damping=0.2)
    x, condition = system.solve(theta, omega)
    assert np.isfinite(condition)
    compiled = load_compiled(method, chain.n, chain.pinned)  # the chain's own formulas
    expected, _ = compiled.solve_full(theta, omega, chain.params(damping=0.2))
    assert relative(x[system.theta_ddot_index], expected[compiled.theta_ddot_index]) <= ROUNDING
    assert relative(x[system.reaction_index], expected[compiled.reaction_index]) <= ROUNDING
    if method == "dae" and chain.pinned:
        assert x[system.tip_reaction_index].shape == (2,)
        assert relative(x[system.tip_reaction_index], expected[compiled.tip_reaction_index]) <= ROUNDING


@pytest.mark.parametrize(("preset", "method"), [("triple-c", "newton_euler"), ("four-bar", "dae"),
                                                ("four-bar", "lagrange")])
def test_the_ode45_replay_reads_the_chains_formulas_at_its_samples(preset, method):
    """The seed report's ode45 replay runs the chain as a mechanism: it takes steps, ends at ``t_end``, and
    every sample is what the chain's own formulas give at its state."""
    settings = Settings(method=method, integrator="ode45", rtol=1e-6, atol=1e-6, t_end=2.0, samples=21)
    run = _ode45_as_called(preset, settings)
    assert run.success and run.n_rhs > run.n_steps > 0
    np.testing.assert_array_equal(run.t, np.linspace(0.0, 2.0, 21))
    assert_run_follows_chain_formulas(get_preset(preset).chain, settings, run)


def chain_rk4(chain, method, theta, omega, step, steps, alpha, beta):
    """``steps`` classical RK4 steps of the chain's own system (the chain's formulas), every copy at once."""
    compiled = load_compiled(method, chain.n, chain.pinned)
    params = chain.params()

    def accel(theta, omega):
        x, _ = compiled.solve_full_batch(theta, omega, params, alpha, beta)
        return x[:, compiled.theta_ddot_index]

    theta, omega = theta.copy(), omega.copy()
    for _ in range(steps):
        k1_theta, k1_omega = omega, accel(theta, omega)
        k2_theta = omega + 0.5 * step * k1_omega
        k2_omega = accel(theta + 0.5 * step * k1_theta, k2_theta)
        k3_theta = omega + 0.5 * step * k2_omega
        k3_omega = accel(theta + 0.5 * step * k2_theta, k3_theta)
        k4_theta = omega + step * k3_omega
        k4_omega = accel(theta + step * k3_theta, k4_theta)
        theta = theta + step / 6.0 * (k1_theta + 2.0 * k2_theta + 2.0 * k3_theta + k4_theta)
        omega = omega + step / 6.0 * (k1_omega + 2.0 * k2_omega + 2.0 * k3_omega + k4_omega)
    return theta, omega


@pytest.mark.parametrize(("preset", "method"), [("triple-a", "lagrange"), ("triple-a", "dae"),
                                                ("four-bar", "newton_euler"), ("four-bar", "dae")])
def test_an_ensemble_steps_the_copies_of_the_chains_formulas(preset, method):
    """Ten copies over 0.5 s (120 RK4 steps): the states in the chain's order are classical RK4 on the chain's
    own system (Baumgarte's gains on a pinned chain, as the ensemble holds it), every copy alive."""
    chosen = get_preset(preset)
    ensemble = Ensemble(chosen.chain, chosen.theta0, chosen.omega0, method=method, count=10, spread=1e-3)
    theta0, omega0 = ensemble.theta.copy(), ensemble.omega.copy()
    ensemble.advance(0.25)
    ensemble.advance(0.25)
    assert ensemble.steps_taken == 120
    gains = (BAUMGARTE_ALPHA, BAUMGARTE_BETA) if chosen.chain.pinned else (0.0, 0.0)
    theta, omega = chain_rk4(chosen.chain, method, theta0, omega0, ensemble.step, 120, *gains)
    assert relative(ensemble.theta, theta) <= ROUNDING
    assert relative(ensemble.omega, omega) <= ROUNDING
    assert ensemble.alive.all()


def test_an_ensemble_copy_follows_simulate():
    """Copy 0 of a fine-stepped ensemble follows the adaptive run of the same chain."""
    chosen = get_preset("four-bar")
    ensemble = Ensemble(chosen.chain, chosen.theta0, chosen.omega0, method="lagrange", count=2, spread=1e-6,
                        step=1e-3)
    ensemble.advance(1.0)
    reference = simulate(chosen.chain, chosen.theta0, chosen.omega0,
                         Settings(method="lagrange", rtol=1e-11, atol=1e-11, t_end=1.0, samples=2))
    assert np.max(np.abs(ensemble.theta[0] - reference.theta[-1])) < 1e-6



def moving_state(preset: str) -> tuple:
    """A state in motion of the preset's chain: a pinned chain's taken from a short run (its rates on the loop)."""
    chosen = get_preset(preset)
    if not chosen.chain.pinned:
        return chosen.chain, chosen.theta0, chosen.omega0 + np.linspace(0.3, -0.2, chosen.chain.n)
    run = simulate(chosen.chain, chosen.theta0, chosen.omega0, Settings(method="dae", t_end=0.3, samples=2))
    return chosen.chain, run.theta[-1], run.omega[-1]


@pytest.mark.parametrize("preset", ("single", "triple-c", "four-bar", "change-point"))
@pytest.mark.parametrize("method", FORMULATION_NAMES)
def test_the_accelerations_command_answers_the_chains_formulas(preset, method):
    """``accelerations`` (the CLI's JSON): the chain's own system's accelerations, DAE reactions and tip
    reaction (for every method on a pinned chain: read off a tree formulation's bodies, checked against the
    chain's pinned formulation, which solves for it); the condition estimate the chain's for an open chain of two
    bars or more (the same matrix), the solved system's own elsewhere."""
    chain, theta, omega = moving_state(preset)
    answer = accelerations(chain, theta, omega, method, damping=0.2)
    assert ("tip_reaction" in answer) == chain.pinned
    assert ("joint_reactions" in answer) == (method == "dae")
    compiled = load_compiled(method, chain.n, chain.pinned)
    expected, condition = compiled.solve_full(theta, omega, chain.params(damping=0.2))
    assert relative(answer["theta_ddot"], expected[compiled.theta_ddot_index]) <= ROUNDING
    if method == "dae":
        assert relative(answer["joint_reactions"], expected[compiled.reaction_index]) <= ROUNDING
    if chain.pinned:
        assert compiled.tip_reaction_index.size == 2
        assert relative(answer["tip_reaction"], expected[compiled.tip_reaction_index]) <= ROUNDING
    assert np.isfinite(answer["condition"])
    if not chain.pinned and chain.n > 1:
        assert relative(answer["condition"], condition) <= ROUNDING


def test_a_singular_state_is_refused():
    """The collinear change-point four-bar: refused as an impossible request."""
    chain = get_preset("change-point").chain
    collinear = np.array([np.pi / 2, np.pi / 2, -np.pi / 2])
    with pytest.raises(LinkageError, match="singular configuration"):
        accelerations(chain, collinear, np.zeros(3), "lagrange")


@pytest.mark.parametrize("preset", ("triple-a", "four-bar"))
def test_free_body_diagrams_hold_the_chains_reactions(preset):
    """Every force on every bar is the chain's own DAE's reaction at the state (its angular accelerations the
    bars' alpha), and the bars balance (sum of forces = m a_G, moments about G = I alpha)."""
    chain, theta, omega = moving_state(preset)
    compiled = load_compiled("dae", chain.n, chain.pinned)
    expected, _ = compiled.solve_full(theta, omega, chain.params())
    reactions = expected[compiled.reaction_index]
    alpha = expected[compiled.theta_ddot_index]
    bodies = free_bodies(chain, theta, omega)
    assert len(bodies) == chain.n
    for i, body in enumerate(bodies):
        by_name = {force.name.split(" ")[0]: force.force for force in body.forces}
        assert relative(by_name[f"R{i}"], reactions[i]) <= ROUNDING
        if i + 1 < chain.n:
            assert relative(by_name[f"-R{i + 1}"], -reactions[i + 1]) <= ROUNDING
        elif chain.pinned:
            assert relative(by_name["RH"], expected[compiled.tip_reaction_index]) <= ROUNDING
        assert relative(body.alpha, alpha[i]) <= ROUNDING
        np.testing.assert_allclose(body.net_force(), body.mass * body.com_acceleration, atol=1e-10)
        assert body.net_moment_about_com() == pytest.approx(body.inertia * body.alpha, abs=1e-10)


def test_accelerations_and_free_bodies_never_load_the_chains_kernel(monkeypatch):
    """The chain's own system is the tests' oracle, never what a caller runs: a load of it fails the test."""

    def refused(*_arguments, **_keywords):
        raise AssertionError("the chain's own kernel was loaded by a run")

    monkeypatch.setattr(cache_module, "load_compiled", refused)
    monkeypatch.setattr(codegen_module, "load_compiled", refused)
    monkeypatch.setattr(physics, "load_compiled", refused)
    chain, theta, omega = moving_state("four-bar")
    assert "tip_reaction" in accelerations(chain, theta, omega, "lagrange")
    assert len(free_bodies(chain, theta, omega)) == 3
