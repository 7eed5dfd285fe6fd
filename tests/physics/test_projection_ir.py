"""The projection's and the per-sample loops written as LLVM IR (physics.codegen.projection_ir, called through
physics.codegen.native_states) give the numba kernels' very bits: ``project_states`` (a driven mechanism's
position analysis, CompiledSystem.project) and ``native_states`` (a mechanism's samples' constraints and tree
kinematics), on every mechanism preset in maximal coordinates (with projection weights) and in tree
coordinates, from states moved off the constraints."""

from __future__ import annotations

import numpy as np
import pytest

from physics.codegen import native_states
from physics.kernels import projection, system
from physics.kernels.layout import LAYOUT_CONSTRAINTS
from physics.mechanism import engine
from physics.mechanism.presets import MECHANISM_PRESETS
from physics.mechanism.simulate import simulate_mechanism
from physics.mechanism.tree_coordinates import tree_state


def _case(name: str, method: str):
    """``(compiled, layout, params, t, theta, omega)``: a 1 s run's 11 samples, moved off the constraints."""
    rng = np.random.default_rng(7)
    mechanism = MECHANISM_PRESETS[name]()
    run = simulate_mechanism(mechanism, 1.0, 11, integrate=True)
    q, qdot = run.q, run.qdot
    weights = None
    if method == "tree":
        pairs = [tree_state(mechanism, a, b) for a, b in zip(q, qdot, strict=True)]
        q, qdot = np.array([pair[0] for pair in pairs]), np.array([pair[1] for pair in pairs])
    else:
        weights = np.abs(rng.normal(size=2 * q.shape[1])) + 0.5
    compiled = engine.compiled_system(mechanism, method)
    params, layout = engine.run_parameters(mechanism, compiled, 0.0, weights)
    theta = np.ascontiguousarray(q + 1e-3 * rng.normal(size=q.shape))
    omega = np.ascontiguousarray(qdot + 1e-2 * rng.normal(size=q.shape))
    return compiled, layout, params, np.ascontiguousarray(run.t), theta, omega


@pytest.mark.parametrize("method", ["dae", "tree"])
@pytest.mark.parametrize("name", sorted(MECHANISM_PRESETS))
def test_project_states_and_native_states_give_the_kernels_bits(name, method):
    compiled, layout, params, t, theta, omega = _case(name, method)
    assert layout[LAYOUT_CONSTRAINTS] > 0
    ir_theta, ir_omega, kernel_theta, kernel_omega = theta.copy(), omega.copy(), theta.copy(), omega.copy()
    ir_left = native_states.project_states(layout, t, ir_theta, ir_omega, params)
    kernel_left = projection.project_states(compiled.assemble_function, layout, t, kernel_theta, kernel_omega,
                                            params.copy())
    assert ir_left == kernel_left and 0.0 < ir_left < 1e-12
    assert np.array_equal(ir_theta, kernel_theta) and np.array_equal(ir_omega, kernel_omega)
    assert not np.array_equal(ir_theta, theta) and not np.array_equal(ir_omega, omega)  # both were moved
    r, n = int(layout[LAYOUT_CONSTRAINTS]), theta.shape[1]
    results = []
    for states in (native_states.native_states, system.native_states):
        matrix, vector = np.zeros((t.size, r, n)), np.zeros((t.size, 2 * r))
        states(compiled._native("constraints"), layout, t, theta, omega, params, matrix, vector)
        results.append((matrix, vector))
    assert np.array_equal(results[0][0], results[1][0]) and np.array_equal(results[0][1], results[1][1])
    assert np.count_nonzero(results[0][0]) > r


def test_a_wrong_array_is_refused_before_any_pointer_is_handed_over():
    compiled, layout, params, t, theta, omega = _case("slider-crank", "dae")
    with pytest.raises(ValueError, match="C-contiguous"):
        native_states.project_states(layout, t, np.asfortranarray(theta), omega, params)
    with pytest.raises(ValueError, match="C-contiguous"):
        native_states.project_states(layout, t[:-1], theta, omega, params)
