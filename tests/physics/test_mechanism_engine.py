"""Any mechanism on the one compiled engine (physics/mechanism/engine.py): generated code per structure, the
numbers a parameter vector, the chain kernels' integrators.

Checked here against independent numbers: the numeric maximal-coordinate DAE of physics/mechanism/numeric_dae.py
(written from the constraint equations with numpy), the chain's own derived formulations (the chain written as
a mechanism must give the chain formulas of docs/physics.md), and the motors' prescribed angles.
"""

from __future__ import annotations

import numpy as np
import pytest

from physics import Settings, get_preset, load_compiled, simulate
from physics.codegen import cache
from physics.mechanism import MECHANISM_PRESETS, assemble, engine
from physics.mechanism.chains import chain_mechanism, chain_state
from physics.mechanism.description import Mechanism
from physics.mechanism.numeric_dae import MechanismDAE
from physics.mechanism.parameters import parameter_vector
from physics.mechanism.simulate import project_velocity, simulate_mechanism
from physics.mechanism.singularity import jacobian_condition

from .test_mechanism_symbolic import random_mechanism

METHODS = ("dae", "lagrange", "newton_euler")


def _scaled(mechanism: Mechanism, rng) -> Mechanism:
    """The same structure with other numbers: masses, inertias, g and motor speeds changed."""
    data = mechanism.model_dump()
    for body in data["bodies"]:
        body["mass"] = float(body["mass"] * rng.uniform(0.5, 2.0))
        body["inertia"] = float(body["inertia"] * rng.uniform(0.5, 2.0))
    data["g"] = float(rng.uniform(1.0, 20.0))
    for driver in data["drivers"]:
        if driver.get("speed") is not None:
            driver["speed"] = float(driver["speed"] * rng.uniform(0.5, 1.5))
    return Mechanism.model_validate(data)


@pytest.mark.parametrize("name", sorted(MECHANISM_PRESETS))
def test_compiled_dae_equals_the_numeric_dae_at_random_states_and_numbers(name):
    """Accelerations and every reaction row from the generated DAE (machine code, parameters at run time) equal
    the numeric DAE's at states near the assembled pose, for two sets of numbers of one structure."""
    rng = np.random.default_rng(3)
    base = MECHANISM_PRESETS[name]()
    for mechanism in (base, _scaled(base, rng)):
        compiled = engine.compiled_system(mechanism, "dae")
        dae = MechanismDAE(mechanism)
        q = assemble(mechanism).q
        params = parameter_vector(mechanism)
        for _ in range(3):
            qdot = project_velocity(dae, q, rng.normal(size=q.size))
            full, _ = compiled.solve_full(q, qdot, params)
            expected = dae.solve(q, qdot)
            scale = max(1.0, float(np.max(np.abs(expected.reactions))))
            np.testing.assert_allclose(full[compiled.theta_ddot_index], expected.qddot, atol=1e-9 * scale)
            np.testing.assert_allclose(full[compiled.multiplier_index], expected.reactions, atol=1e-9 * scale)


def test_editing_numbers_derives_and_compiles_nothing(monkeypatch):
    """Once a structure is compiled, runs with other masses, inertias, g and motor speeds load the same system:
    no derivation, no generated file, no new machine code."""
    rng = np.random.default_rng(5)
    base = MECHANISM_PRESETS["slider-crank"]()
    for method in METHODS:
        simulate_mechanism(base, 0.05, 3, method=method)
    loaded = {method: engine.compiled_system(base, method) for method in METHODS}

    def refuse(*_args, **_kwargs):
        raise AssertionError("a number's edit derived or generated code")

    monkeypatch.setattr(cache, "_generate", refuse)
    for _ in range(3):
        edited = _scaled(base, rng)
        for method in METHODS:
            assert engine.compiled_system(edited, method) is loaded[method]
            run = simulate_mechanism(edited, 0.2, 5, method=method)
            assert np.all(np.isfinite(run.q)) and np.max(run.residual) < 1e-9


@pytest.mark.parametrize("method", METHODS)
def test_the_chain_written_as_a_mechanism_gives_the_chain_formulas(method):
    """The seed's triple pendulum as three bodies and three pins: its angular accelerations and joint reactions
    equal the chain formulation's (docs/physics.md) at random states, to 1e-12 relative."""
    preset = get_preset("triple-a")
    chain = preset.chain
    mechanism = chain_mechanism(chain, preset.theta0)
    compiled = engine.compiled_system(mechanism, "dae")
    chain_system = load_compiled(method, chain.n, False)
    params = parameter_vector(mechanism)
    rng = np.random.default_rng(11)
    for _ in range(5):
        theta, omega = rng.uniform(-3, 3, chain.n), rng.normal(size=chain.n)
        q, qdot = chain_state(chain, preset.theta0, theta, omega)
        full, _ = compiled.solve_full(q, qdot, params)
        expected, _ = chain_system.accel(theta, omega, chain.params())
        angular = full[compiled.theta_ddot_index][2::3]
        np.testing.assert_allclose(angular, expected, rtol=1e-12, atol=1e-12 * np.max(np.abs(expected)))


def test_a_chain_run_as_a_mechanism_follows_the_chain_run():
    """Five seconds of the triple pendulum through both pipelines' integrators, DOP853 at 1e-10."""
    preset = get_preset("triple-a")
    mechanism = chain_mechanism(preset.chain, preset.theta0)
    run = simulate_mechanism(mechanism, 5.0, 51, method="dae")
    settings = Settings(method="dae", integrator="DOP853", rtol=1e-10, atol=1e-10, t_end=5.0, samples=51)
    chain_run = simulate(preset.chain, preset.theta0, preset.omega0, settings)
    theta = run.q[:, 2::3] + preset.theta0
    np.testing.assert_allclose(theta, chain_run.theta, atol=1e-6)


def test_speed_motors_follow_the_clock_the_kernels_write():
    """A crank-rocker integrated (not by position analysis) keeps its crank at speed * t: the time slot of the
    parameter vector is written at every stage, so the projection and the samples hold the motor's angle."""
    mechanism = MECHANISM_PRESETS["crank-rocker"]()
    run = simulate_mechanism(mechanism, 1.0, 11, method="dae", integrate=True)
    driven = simulate_mechanism(mechanism, 1.0, 11, method="dae")
    assert run.integrated and not driven.integrated
    assert np.max(run.residual) < 1e-9
    np.testing.assert_allclose(run.q, driven.q, atol=1e-7)
    np.testing.assert_allclose(run.qdot, driven.qdot, atol=1e-6)


def test_every_sample_at_once_equals_each_sample_on_its_own():
    """A run's conditions and a tree formulation's reactions are computed for all its samples in one pass
    (batched Jacobians, applied forces, one QR): the same numbers as the per-sample evaluation and least squares,
    on random mechanisms with sliders on moving guides, dampers on every joint and torque motors."""
    rng = np.random.default_rng(24)
    torque_motors = 0
    for _ in range(12):
        mechanism = random_mechanism(rng)
        torque_motors += sum(driver.torque is not None for driver in mechanism.drivers)
        dae = MechanismDAE(mechanism)
        q = dae.constraints.sketch_pose() + rng.normal(scale=0.3, size=(9, dae.constraints.size))
        qdot = rng.normal(size=q.shape)
        qddot = rng.normal(size=q.shape)
        for batched, single in ((dae.constraints.jacobian, dae.constraints.jacobian),
                                (dae.constraints.damper_jacobian, dae.constraints.damper_jacobian),
                                (dae.constraints.driven_jacobian, dae.constraints.driven_jacobian)):
            assert np.array_equal(batched(q), np.array([single(pose) for pose in q]).reshape(batched(q).shape))
        applied = dae.applied(qdot, q)
        np.testing.assert_allclose(applied, [dae.applied(v, pose) for v, pose in zip(qdot, q)], rtol=1e-13, atol=1e-13)
        solved = engine.Samples(q, qdot, qddot, np.zeros((9, 0)), np.zeros(9), np.ones(9), np.zeros((9, 0, 0)))
        reactions = engine.body_reactions(dae, solved)
        for k in range(9):
            expected = np.linalg.lstsq(dae.constraints.jacobian(q[k]).T,
                                       dae.mass_diagonal * qddot[k] - dae.applied(qdot[k], q[k]), rcond=None)[0]
            np.testing.assert_allclose(reactions[k], expected, rtol=1e-9, atol=1e-9 * np.max(np.abs(expected)))
        conditions = engine._conditions(dae.constraints, solved, tree=True)
        assert np.allclose(conditions, [jacobian_condition(dae.constraints, pose) for pose in q], rtol=1e-12)
    assert torque_motors > 0  # the draws reached the torque motors' Jacobian
