"""The chain's run on the mechanism engine reads its samples through generic native code
(physics/codegen/mechanism_observables*.py, mechanism_run.py; issue 24): the one-buffer run gives the
Trajectory the integration and samples' calls one at a time give, bit for bit, and the generic observables
(points along paths of bodies, energies, reaction rows as constant maps of ``M qddot - Q`` and the unknowns)
agree to rounding with what the route computed before them: the chain's kinematics of the angles and
``engine.body_reactions`` on the kinematics' poses (a change of a row, a sign or a path would be off by order
one)."""

from __future__ import annotations

import numpy as np
import pytest

from physics import Settings, get_preset, simulate
from physics.codegen import cache
from physics.codegen.mechanism_samples import mechanism_samples
from physics.kinematics import energies, joint_positions, point_on_bar, tip_velocity
from physics.mechanism import engine
from physics.simulate import mechanism_route
from physics.simulate.chain_prepared import chain_arrays

ROUNDING = 1e-13  # relative to 1 + the largest value; measured at most 9e-16

CASES = [("triple-a", "lagrange", 0.0), ("triple-a", "newton_euler", 0.3), ("triple-a", "dae", 0.3),
         ("four-bar", "lagrange", 0.0), ("four-bar", "newton_euler", 0.3), ("four-bar", "dae", 0.0),
         ("chain", "lagrange", 0.0)]


@pytest.fixture(autouse=True)
def _specialised_in_the_foreground(monkeypatch):
    monkeypatch.setattr(cache, "SPECIALISE_IN_BACKGROUND", False)


def _run(preset: str, method: str, damping: float, **extra):
    chosen = get_preset(preset, 5 if preset == "chain" else None)
    settings = Settings(method=method, damping=damping, t_end=1.0, samples=21, **extra)
    return chosen.chain, settings, simulate(chosen.chain, chosen.theta0, chosen.omega0, settings)


@pytest.mark.parametrize(("preset", "method", "damping"), CASES)
def test_the_one_buffer_run_is_bit_identical_to_the_calls_one_at_a_time(monkeypatch, preset, method, damping):
    monkeypatch.setattr(mechanism_route, "ONE_BUFFER_RUN", False)
    *_, reference = _run(preset, method, damping)
    monkeypatch.setattr(mechanism_route, "ONE_BUFFER_RUN", True)
    *_, fused = _run(preset, method, damping)
    assert (fused.status, fused.message, fused.n_steps, fused.n_rhs) == (
        reference.status, reference.message, reference.n_steps, reference.n_rhs)
    for name, value in reference.columns().items():
        assert np.array_equal(np.asarray(fused.columns()[name]), np.asarray(value), equal_nan=True), name


def _relative(mine, theirs) -> float:
    return float(np.max(np.abs(mine - theirs)) / (1.0 + np.max(np.abs(theirs)))) if np.size(theirs) else 0.0


@pytest.mark.parametrize(("preset", "method", "damping"), CASES)
def test_the_generic_observables_are_the_chains_kinematics_and_newtons_law(preset, method, damping):
    trace = {"bar": 2, "along": 0.3, "across": -0.1}
    chain, settings, run = _run(preset, method, damping, trace=trace)
    bars = chain_arrays(chain)
    params = bars.params_with(damping)
    kinetic, potential, energy = energies(params, run.theta, run.omega)
    joints = joint_positions(bars.L, run.theta)
    expected = {"kinetic": kinetic, "potential": potential, "energy": energy, "joints": joints,
                "trace_xy": point_on_bar(bars.L, run.theta, 2, 0.3, -0.1)}
    if chain.pinned:
        expected["constraint_xy"] = joints[:, -1, :] - np.asarray(chain.pin)
        expected["constraint_velocity"] = tip_velocity(bars.L, run.theta, run.omega)
    # the reactions as the route computed them before: the DAE's multipliers, or Newton's law on every body
    # from the kinematics' poses by engine.body_reactions
    route = mechanism_route.chain_route(chain, method, damping)
    alpha, beta = (10.0, 10.0) if settings.stabilization == "baumgarte" else (0.0, 0.0)
    s, sd = run.theta[:, route.order], run.omega[:, route.order]
    compiled = route.compiled
    arrays = mechanism_samples(compiled, run.t, np.ascontiguousarray(s), np.ascontiguousarray(sd),
                               route.pieces.parameters_at(0.0), alpha=alpha, beta=beta, matrices=chain.pinned)
    if route.own_reactions:
        rows = arrays.full[:, compiled.multiplier_index]
    else:
        qdot = np.einsum("kij,kj->ki", arrays.pose_jacobian, sd)
        qddot = np.einsum("kij,kj->ki", arrays.pose_jacobian, arrays.full[:, compiled.theta_ddot_index]) + arrays.bias
        empty = np.zeros(0)
        rows = engine.body_reactions(route.dynamics, engine.Samples(arrays.pose, qdot, qddot, *[empty] * 4),
                                     closed_form=route.pieces.tree_reactions)
    expected["joint_reactions"] = rows[:, route.joint_rows].reshape(len(run.t), chain.n, 2)
    expected["tip_reaction"] = rows[:, route.tip_rows]
    for name, value in expected.items():
        assert _relative(getattr(run, name), value) <= ROUNDING, (name, _relative(getattr(run, name), value))
    if chain.pinned:  # the condition of the solved matrices, as compiled.sample_matrices gives them
        A, _ = compiled.sample_matrices(np.ascontiguousarray(s), np.ascontiguousarray(sd),
                                        route.pieces.parameters_at(0.0))
        assert np.array_equal(arrays.matrices, A)
        assert np.array_equal(run.condition, np.linalg.cond(A))
