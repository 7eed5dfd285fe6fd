"""A mechanism run's ``condition="solve"`` (physics/mechanism/simulate.py, issue 24: a chain run as a mechanism
reports what the chain engine reports): every sample's condition estimate of the formulation's own solve, which
the run's samples' solve gives, so reading it computes nothing more.

* It is the samples' solve's estimate bit for bit (the compiled system's ``solve_samples`` at the run's own
  states), and every other field of the run is the default run's, bit for bit.
* Seed case C as a mechanism (sketched at theta = 0, absolute rotations) reports the chain engine's condition for
  Newton-Euler, Lagrange and the DAE in tree coordinates (their runs agree to the integration's rounding).
* The default stays the maximal ``Phi_q``'s condition; anything else is refused in one line.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import physics
from physics.chain_presets import get_preset
from physics.errors import LinkageError
from physics.mechanism import MECHANISM_PRESETS, engine
from physics.mechanism.chains import chain_mechanism, chain_state
from physics.mechanism.prepared import prepared
from physics.mechanism.simulate import simulate_mechanism
from physics.mechanism.singularity import jacobian_condition
from physics.mechanism.tree_dae import compiled_tree_dae
from physics.model import Settings

OPTIONS = dict(t_end=20.0, samples=200, integrator="RK45", rtol=1e-6, atol=1e-6)


def _seed_case_c():
    preset = get_preset("triple-c")
    zero = np.zeros(preset.chain.n)
    q0, qdot0 = chain_state(preset.chain, zero, preset.theta0, preset.omega0)
    return preset, chain_mechanism(preset.chain, zero), q0, qdot0


def _run(method: str, condition: str):
    _, mechanism, q0, qdot0 = _seed_case_c()
    extra = {"coordinates": "tree"} if method == "dae" else {}
    return mechanism, simulate_mechanism(mechanism, q0=q0, qdot0=qdot0, method=method, rotations="absolute",
                                         condition=condition, **OPTIONS, **extra)


@pytest.mark.parametrize("method", ["newton_euler", "lagrange", "dae"])
def test_the_solve_condition_is_the_samples_solve_and_nothing_else_changes(method):
    mechanism, run = _run(method, "solve")
    _, default = _run(method, "jacobian")
    for field in dataclasses.fields(run):
        if field.name != "condition":
            value, other = getattr(run, field.name), getattr(default, field.name)
            if isinstance(value, np.ndarray):
                assert np.array_equal(value, other, equal_nan=True), field.name
            else:
                assert value == other, field.name
    pieces = prepared(mechanism)
    compiled = (compiled_tree_dae(mechanism, pieces.structure_key, "absolute") if method == "dae"
                else engine.compiled_system(mechanism, method, pieces.structure_key, "absolute"))
    # absolute rotations of a chain: the tree state is every bar's angle and rate, read off q and qdot exactly
    x, v = np.ascontiguousarray(run.q[:, 2::3]), np.ascontiguousarray(run.qdot[:, 2::3])
    _, estimate = compiled.solve_samples(x, v, pieces.parameters_at(0.0))
    assert np.array_equal(run.condition, estimate)
    # the default: the maximal Phi_q's condition, a different measure (no singular pose in an open chain)
    assert default.condition[7] == pytest.approx(jacobian_condition(pieces.constraints, default.q[7]), rel=1e-12)
    assert not np.allclose(run.condition, default.condition)


@pytest.mark.parametrize("method", ["newton_euler", "lagrange", "dae"])
def test_seed_case_c_as_a_mechanism_reports_the_chain_engines_condition(method):
    preset, _, _, _ = _seed_case_c()
    chain_run = physics.simulate(preset.chain, preset.theta0, preset.omega0, Settings(method=method, **OPTIONS))
    _, run = _run(method, "solve")
    assert (run.n_steps, run.n_rhs) == (chain_run.n_steps, chain_run.n_rhs) == (192, 1502)
    assert np.allclose(run.q[:, 2::3], chain_run.theta, rtol=0, atol=1e-7)  # the same motion to rounding
    assert np.allclose(run.condition, chain_run.condition, rtol=1e-7, atol=0)


def test_other_conditions_are_refused():
    _, mechanism, q0, qdot0 = _seed_case_c()
    with pytest.raises(LinkageError, match="condition = 'svd': allowed values jacobian, solve"):
        simulate_mechanism(mechanism, 1.0, 5, q0=q0, method="lagrange", condition="svd")
    with pytest.raises(LinkageError, match="does not apply to method 'reduced'"):
        simulate_mechanism(MECHANISM_PRESETS["crank-rocker"](), 1.0, 5, method="reduced", condition="solve")
