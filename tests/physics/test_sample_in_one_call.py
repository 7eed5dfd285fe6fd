"""A sample's solve and kinematics in one generated call (physics/codegen/emit.py ``sample``,
physics/codegen/samples_ir.py ``solve_pose_states``) and the observables reading each body's cosine and sine from
the kinematics (physics/codegen/mechanism_observables_ir.py, ``tree`` 2 and 3): the same bits as the separate
calls they replace, at random states of every formulation, open and pinned, and in a chain's whole run; and the
runs do take them (a regression that silently falls back would lose the speed, not the numbers)."""

from __future__ import annotations

import copy
import ctypes

import numpy as np
import pytest

from physics import Settings, get_preset, simulate
from physics.codegen import cache, mechanism_run, native_states
from physics.codegen.mechanism_samples import mechanism_samples
from physics.codegen.native_samples import pose_counterpart
from physics.simulate import mechanism_route

from .test_route_call_cache import _assert_same, _fields

METHODS = ["lagrange", "newton_euler", "dae"]
PRESETS = [("triple-c", None), ("four-bar", None), ("chain", 7)]
_SAMPLE = ctypes.CFUNCTYPE(None, *[ctypes.c_void_p] * 5)


def _route(preset: str, links: int | None, method: str):
    chosen = get_preset(preset, links)
    return chosen, mechanism_route.chain_route(chosen.chain, method, 0.0)


def _random_states(n: int, rows: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return rng.uniform(-7.0, 7.0, (rows, n)), rng.uniform(-9.0, 9.0, (rows, n))


@pytest.mark.parametrize("preset, links", PRESETS)
@pytest.mark.parametrize("method", METHODS)
def test_the_generated_sample_is_assemble_then_kinematics_bit_for_bit(preset, links, method):
    chosen, route = _route(preset, links, method)
    compiled = route.compiled
    assert compiled.sample_function != 0  # every tree-coordinate system has one
    n, k, size, width = chosen.chain.n, compiled.n_unknowns, compiled.pose_size, compiled.pose_vector_size
    params = np.array(route.parameters, dtype=float)
    theta, omega = _random_states(n, 40, seed=len(preset) + n + len(method))
    sample = _SAMPLE(compiled.sample_function)
    for row in range(theta.shape[0]):
        A_sample = np.zeros((k, k))
        out = np.zeros(k + size * n + width)
        state_theta, state_omega = np.ascontiguousarray(theta[row]), np.ascontiguousarray(omega[row])
        sample(state_theta.ctypes.data, state_omega.ctypes.data, params.ctypes.data, A_sample.ctypes.data,
               out.ctypes.data)
        A, b = compiled.sample_matrices(theta[row:row + 1].copy(), omega[row:row + 1].copy(), params)
        jacobian = np.zeros((1, size, n))
        vector = np.zeros((1, width))
        native_states.native_states(compiled._native("kinematics"), compiled.layout, np.zeros(1),
                                    theta[row:row + 1].copy(), omega[row:row + 1].copy(), params, jacobian, vector)
        assert A_sample.tobytes() == A[0].tobytes()
        assert out[:k].tobytes() == b[0].tobytes()
        assert out[k:k + size * n].tobytes() == jacobian[0].ravel().tobytes()
        assert out[k + size * n:].tobytes() == vector[0].tobytes()
        # the kinematics' last 2 B entries are each body's cosine and sine, of the coordinate named for it
        angles = compiled.pose_angle_index
        assert np.array_equal(vector[0, 2 * size:2 * size + size // 3], np.cos(theta[row, angles]))
        assert np.array_equal(vector[0, 2 * size + size // 3:], np.sin(theta[row, angles]))


@pytest.mark.parametrize("preset, links", PRESETS)
@pytest.mark.parametrize("method", METHODS)
def test_observables_reading_the_kinematics_turns_give_the_bits_of_evaluating_them(preset, links, method):
    chosen, route = _route(preset, links, method)
    settings = Settings(method=method, samples=31, t_end=2.0)
    plan = mechanism_route._chain_plan(chosen.chain, settings, route)
    assert plan.mode in (2, 3)  # the chain route reads them: absolute rotations, one coordinate per bar
    evaluating = copy.copy(plan)  # the same constants, each body's cosine and sine evaluated from its angle
    evaluating.mode = {2: 1, 3: 0}[plan.mode]  # a tree's reactions either way, or neither
    theta, omega = _random_states(chosen.chain.n, 31, seed=3)
    params = np.array(route.parameters, dtype=float)
    results = [mechanism_samples(route.compiled, np.zeros(31), theta, omega, params, constraints=False,
                                 kinematics=True, observables=chosen_plan, g=chosen.chain.g)
               for chosen_plan in (plan, evaluating)]
    for name in ("points", "velocities", "energies", "reactions", "full", "pose", "bias", "pose_jacobian"):
        assert getattr(results[0], name).tobytes() == getattr(results[1], name).tobytes(), name


@pytest.mark.parametrize("preset, links", PRESETS)
@pytest.mark.parametrize("method", METHODS)
def test_a_chain_runs_solve_takes_the_one_call_and_gives_the_separate_calls_bits(monkeypatch, preset, links, method):
    monkeypatch.setattr(cache, "SPECIALISE_IN_BACKGROUND", False)  # the specialised pass in place by the third run
    chosen = get_preset(preset, links)
    settings = Settings(method=method, integrator="RK45", rtol=1e-6, atol=1e-6, t_end=1.5, samples=33)
    theta0, omega0 = np.asarray(chosen.theta0, float), np.asarray(chosen.omega0, float)
    for _ in range(3):  # the specialised functions in place by the third run
        fused = _fields(simulate(chosen.chain, theta0, omega0, settings))  # (its columns read: the samples solved)
    compiled = mechanism_route.chain_route(chosen.chain, method, 0.0).compiled
    sample = compiled.compiled_sample_function
    assert sample != 0  # compiled with the specialised samples' pass, from the second run on
    runs = [entry for entry in mechanism_run._runs.values() if entry.compiled is compiled]
    assert runs and all(entry.pose_in_solve for entry in runs)
    specialised = compiled.specialised_samples()
    assert specialised is not None and specialised.solve_pose is not None
    assert pose_counterpart(specialised.solve, specialised) is specialised.solve_pose
    for entry in runs:  # the plan of the samples' solve (a reader's, mechanism_run.solve_samples) takes it
        address = entry.solve_plan_address(specialised.solve)
        (kept,) = [kept for kept in entry._plans.values() if kept[4] == address]
        assert kept[3][mechanism_run.PLAN_SLOTS.index("sample")] == sample
        assert kept[3][mechanism_run.PLAN_SLOTS.index("solve_pose")] != 0
        assert kept[3][mechanism_run.PLAN_SLOTS.index("solve_samples")] == 1
    monkeypatch.setattr(mechanism_run, "ONE_CALL", False)  # each native call from Python: solve, then kinematics
    _assert_same(fused, _fields(simulate(chosen.chain, theta0, omega0, settings)))
