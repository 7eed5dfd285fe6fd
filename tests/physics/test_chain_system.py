"""A chain's compiled system on the route the switch chooses (physics/simulate/chain_system.py), and the callers
that run it themselves (the seed report's ode45 replay, the ensemble, ``accelerations``, the free-body diagrams),
on both routes: the same answers to
rounding, and on the mechanism engine when the switch is on (so the chain's own kernels can go).

:data:`ROUNDING` is tests/physics/test_chain_on_mechanism.py's (its docstring says what it measures): 1e-11
relative, for the same equations summed in another order. The ensemble's pinned copies are held by Baumgarte's
terms, which amplify the loop's rounding; over its short runs here they stay a hundred times inside it.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

from physics import LinkageError, Settings, accelerations, get_preset, load_compiled, simulate
from physics.ensemble import Ensemble
from physics.fbd import free_bodies
from physics.model import FORMULATION_NAMES
from physics.seed_report import _ode45_as_called
from physics.simulate import on_mechanism
from physics.simulate.chain_system import chain_system

ROUNDING = 1e-11
PRESETS = ("single", "triple-a", "triple-c", "four-bar")


def relative(mine, theirs) -> float:
    mine, theirs = np.asarray(mine, dtype=float), np.asarray(theirs, dtype=float)
    assert mine.shape == theirs.shape
    if theirs.size == 0:
        return 0.0
    return float(np.max(np.abs(mine - theirs)) / (1.0 + np.max(np.abs(theirs))))


def on_both_routes(monkeypatch, make):
    """``make()`` with the switch off (the chain's kernels), then on (the mechanism engine)."""
    results = []
    for enabled in (False, True):
        monkeypatch.setattr(on_mechanism, "ENABLED", enabled)
        results.append(make())
    return results


def test_switch_off_is_the_chains_own_kernel(monkeypatch):
    """The default route hands out the very system physics.simulate runs, in the chain's order."""
    monkeypatch.setattr(on_mechanism, "ENABLED", False)
    chain = get_preset("four-bar").chain
    system = chain_system(chain, "dae", damping=0.25)
    assert system.route is None and not system.on_mechanism
    assert system.compiled is load_compiled("dae", 3, True)
    np.testing.assert_array_equal(system.order, np.arange(3))
    np.testing.assert_array_equal(system.params, chain.params(damping=0.25))
    np.testing.assert_array_equal(system.tip_reaction_index, system.compiled.tip_reaction_index)


def test_switch_on_is_the_chain_as_a_mechanism(monkeypatch):
    """With the switch on: another compiled system, the four-bar's coordinates in its tree's order."""
    monkeypatch.setattr(on_mechanism, "ENABLED", True)
    chain = get_preset("four-bar").chain
    system = chain_system(chain, "lagrange")
    assert system.on_mechanism
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
def test_one_state_solves_to_the_same_accelerations_and_reactions(preset, method, monkeypatch):
    """At a state in motion: the angular accelerations by ``theta_ddot_index``, the DAE's joint reactions by
    ``reaction_index`` and a pinned chain's tip reaction by ``tip_reaction_index`` (where the system solves for
    it), read in the chain's order, agree between the routes."""
    chosen = get_preset(preset)
    chain = chosen.chain
    omega = chosen.omega0 + np.linspace(0.3, -0.2, chain.n)
    if chain.pinned:  # the tip's velocity must stay on the pin: a rate of the loop's one freedom
        run = simulate(chain, chosen.theta0, chosen.omega0, Settings(method="dae", t_end=0.3, samples=2))
        theta, omega = run.theta[-1], run.omega[-1]
    else:
        theta = chosen.theta0
    chain_side, mechanism_side = on_both_routes(monkeypatch, lambda: chain_system(chain, method, damping=0.2))
    answers = []
    for system in (chain_side, mechanism_side):
        x, condition = system.solve(theta, omega)
        assert np.isfinite(condition)
        answers.append((x[system.theta_ddot_index], x[system.reaction_index], x[system.tip_reaction_index]))
    assert relative(answers[1][0], answers[0][0]) <= ROUNDING
    assert relative(answers[1][1], answers[0][1]) <= ROUNDING
    if method == "dae" and chain.pinned:
        assert answers[0][2].shape == (2,)
        assert relative(answers[1][2], answers[0][2]) <= ROUNDING


@pytest.mark.parametrize(("preset", "method"), [("triple-c", "newton_euler"), ("four-bar", "dae"),
                                                ("four-bar", "lagrange")])
def test_the_ode45_replay_is_the_same_on_both_routes(preset, method, monkeypatch):
    """The seed report's ode45 replay takes the same steps on either route and reads the same samples; with the
    switch on it runs on the mechanism engine (the chain's kernel is never asked for)."""
    settings = Settings(method=method, integrator="ode45", rtol=1e-6, atol=1e-6, t_end=2.0, samples=21)
    chain_run, mechanism_run = on_both_routes(monkeypatch, lambda: _ode45_as_called(preset, settings))
    assert (mechanism_run.n_steps, mechanism_run.n_rhs) == (chain_run.n_steps, chain_run.n_rhs)
    np.testing.assert_array_equal(mechanism_run.t, chain_run.t)
    for name in ("theta", "omega", "tip_xy", "energy", "joint_reactions", "tip_reaction", "constraint_xy"):
        assert relative(getattr(mechanism_run, name), getattr(chain_run, name)) <= ROUNDING, name


def test_the_ode45_replay_runs_on_the_mechanism_engine_when_the_switch_is_on(monkeypatch):
    """With the switch on, the replay never loads the chain's kernel: a load of it fails the test."""
    monkeypatch.setattr(on_mechanism, "ENABLED", True)

    def refused(*_arguments, **_keywords):
        raise AssertionError("the chain's own kernel was loaded on the mechanism route")

    # by the module object: the name physics.simulate is the function simulate (physics/__init__.py)
    monkeypatch.setattr(sys.modules[chain_system.__module__], "load_compiled", refused)
    settings = Settings(method="lagrange", integrator="ode45", rtol=1e-6, atol=1e-6, t_end=1.0, samples=11)
    run = _ode45_as_called("four-bar", settings)
    assert run.success and run.n_steps > 0


@pytest.mark.parametrize(("preset", "method"), [("triple-a", "lagrange"), ("triple-a", "dae"),
                                                ("four-bar", "newton_euler"), ("four-bar", "dae")])
def test_an_ensemble_steps_the_same_copies_on_both_routes(preset, method, monkeypatch):
    """Ten copies over 0.5 s (120 RK4 steps): the same states in the chain's order, the same living copies
    (measured: 1e-16 relative open, 2e-13 on the four-bar's rates, held by Baumgarte's terms)."""
    chosen = get_preset(preset)

    def run() -> Ensemble:
        ensemble = Ensemble(chosen.chain, chosen.theta0, chosen.omega0, method=method, count=10, spread=1e-3)
        ensemble.advance(0.25)
        ensemble.advance(0.25)
        return ensemble

    chain_side, mechanism_side = on_both_routes(monkeypatch, run)
    assert mechanism_side._system.on_mechanism and not chain_side._system.on_mechanism
    assert mechanism_side.steps_taken == chain_side.steps_taken == 120
    assert relative(mechanism_side.theta, chain_side.theta) <= ROUNDING
    assert relative(mechanism_side.omega, chain_side.omega) <= ROUNDING
    np.testing.assert_array_equal(mechanism_side.alive, chain_side.alive)
    assert mechanism_side.alive.all()
    assert relative(mechanism_side.energy(), chain_side.energy()) <= ROUNDING


def test_an_ensemble_copy_follows_simulate_on_the_mechanism_engine(monkeypatch):
    """On the mechanism engine, copy 0 of a fine-stepped ensemble follows the adaptive run of the same route."""
    monkeypatch.setattr(on_mechanism, "ENABLED", True)
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
def test_the_accelerations_command_answers_the_same_on_both_routes(preset, method, monkeypatch):
    """``accelerations`` (the CLI's JSON): the same keys and values (a pinned chain's tip reaction for every
    method: read off a tree formulation's bodies on the mechanism engine); the condition estimate equal for an
    open chain of two bars or more (the same matrix), the solved system's own elsewhere."""
    chain, theta, omega = moving_state(preset)
    chain_side, mechanism_side = on_both_routes(
        monkeypatch, lambda: accelerations(chain, theta, omega, method, damping=0.2))
    assert mechanism_side.keys() == chain_side.keys()
    assert ("tip_reaction" in chain_side) == chain.pinned
    assert ("joint_reactions" in chain_side) == (method == "dae")
    for key in ("theta_ddot", "joint_reactions", "tip_reaction"):
        if key in chain_side:
            assert relative(mechanism_side[key], chain_side[key]) <= ROUNDING, key
    assert np.isfinite(mechanism_side["condition"])
    if not chain.pinned and chain.n > 1:
        assert relative(mechanism_side["condition"], chain_side["condition"]) <= ROUNDING


def test_a_singular_state_is_refused_on_both_routes(monkeypatch):
    """The collinear change-point four-bar: refused as an impossible request on either route."""
    chain = get_preset("change-point").chain
    collinear = np.array([np.pi / 2, np.pi / 2, -np.pi / 2])
    for enabled in (False, True):
        monkeypatch.setattr(on_mechanism, "ENABLED", enabled)
        with pytest.raises(LinkageError, match="singular configuration"):
            accelerations(chain, collinear, np.zeros(3), "lagrange")


@pytest.mark.parametrize("preset", ("triple-a", "four-bar"))
def test_free_body_diagrams_are_the_same_on_both_routes(preset, monkeypatch):
    """Every force on every bar, from the DAE's reactions on either route; on the mechanism engine they balance
    (sum of forces = m a_G, moments about G = I alpha) as on the chain's kernels."""
    chain, theta, omega = moving_state(preset)
    chain_side, mechanism_side = on_both_routes(monkeypatch, lambda: free_bodies(chain, theta, omega))
    for mine, theirs in zip(mechanism_side, chain_side, strict=True):
        assert [f.name for f in mine.forces] == [f.name for f in theirs.forces]
        assert relative([f.force for f in mine.forces], [f.force for f in theirs.forces]) <= ROUNDING
        assert relative(mine.alpha, theirs.alpha) <= ROUNDING
        np.testing.assert_allclose(mine.net_force(), mine.mass * mine.com_acceleration, atol=1e-10)
        assert mine.net_moment_about_com() == pytest.approx(mine.inertia * mine.alpha, abs=1e-10)


def test_accelerations_and_free_bodies_never_load_the_chains_kernel_with_the_switch_on(monkeypatch):
    monkeypatch.setattr(on_mechanism, "ENABLED", True)

    def refused(*_arguments, **_keywords):
        raise AssertionError("the chain's own kernel was loaded on the mechanism route")

    monkeypatch.setattr(sys.modules[chain_system.__module__], "load_compiled", refused)
    chain, theta, omega = moving_state("four-bar")
    assert "tip_reaction" in accelerations(chain, theta, omega, "lagrange")
    assert len(free_bodies(chain, theta, omega)) == 3
