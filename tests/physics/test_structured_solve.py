"""The generated elimination of a mechanism's DAE takes its fast path along a real run, and agrees with a dense
solve.

The kernels accept the unpivoted, generated elimination only when its pivot ratio is at most
``RESCALE_ABOVE``; otherwise every right-hand side is assembled again and solved by a pivoted dense LU. Two
faults once sent every evaluation of every integrated mechanism preset down that slow path: a pivot on a guide's
direction component, which is zero for a horizontal guide (the slider-crank's ratio was inf), and a ratio of
the largest to the smallest pivot, which compared an inertia with a Schur complement in other units (5e4 for a
six-bar whose system has condition number 400). The ratio is now a pivot's shrinkage against its own row."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from physics.kernels import system as kernel_system
from physics.kernels.abi import LAYOUT_SOLVE, call_native_ratio, data_pointer
from physics.mechanism import engine
from physics.mechanism.presets import MECHANISM_PRESETS
from physics.mechanism.simulate import simulate_mechanism

from .dae_states import STRUCTURED_PRESETS, preset_dae


@njit(cache=False)
def _fast_solves(assemble, layout, theta, omega, params, x_out, ratio_out, a_out, b_out):
    system = kernel_system.make_system(assemble, layout)
    for row in range(theta.shape[0]):
        kernel_system.assemble_into(system, theta[row], omega[row], params, 0.0, 0.0)
        a_out[row] = system[2]
        b_out[row] = system[3]
        ratio_out[row] = call_native_ratio(layout[LAYOUT_SOLVE], data_pointer(system[2]), data_pointer(system[3]),
                                           data_pointer(system[4]))
        x_out[row] = system[4]


@pytest.mark.parametrize("name", STRUCTURED_PRESETS)
def test_the_dae_solve_stays_on_its_fast_path_along_a_run_and_matches_a_dense_solve(name):
    dae = preset_dae(name, 2.0, 41)
    count, k = dae.theta.shape[0], int(dae.layout[1])
    x, ratio = np.empty((count, k)), np.empty(count)
    a, b = np.empty((count, k, k)), np.empty((count, k))
    _fast_solves(dae.compiled.assemble_function, dae.layout, dae.theta, dae.omega, dae.params, x, ratio, a, b)
    assert np.all(ratio <= kernel_system.RESCALE_ABOVE), (name, float(np.max(ratio)))
    dense = np.linalg.solve(a, b[..., None])[..., 0]
    scale = np.max(np.abs(dense), axis=1, keepdims=True)
    assert np.max(np.abs(x - dense) / scale) < 1e-11


def test_a_singular_system_reports_a_ratio_that_sends_the_kernels_to_the_dense_solve():
    """Bodies without mass or inertia make the DAE singular (zeros on the pivots): the generated solve must say
    so (an infinite or NaN ratio), not return numbers as if they held."""
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    compiled = engine.compiled_system(mechanism, "dae")
    params, layout = engine.run_parameters(mechanism, compiled, 0.0, None)
    run = simulate_mechanism(mechanism, 0.1, 2, method="dae")
    params = params.copy()
    for body in range(len(mechanism.bodies)):  # parameter_vector: m, I, cx, cy of each body first
        params[4 * body: 4 * body + 2] = 0.0
    theta, omega = np.ascontiguousarray(run.q[:1]), np.ascontiguousarray(run.qdot[:1])
    k = int(layout[1])
    x, ratio = np.empty((1, k)), np.empty(1)
    _fast_solves(compiled.assemble_function, layout, theta, omega, params, x, ratio, np.empty((1, k, k)),
                 np.empty((1, k)))
    assert not ratio[0] <= kernel_system.RESCALE_ABOVE
