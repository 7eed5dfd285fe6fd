"""The generated ``rhs`` (a structured system's assemble and elimination in one function, no matrix in memory)
gives the very bits of ``assemble`` then ``solve`` through memory, and the same pivot ratio: the kernels' right-hand
side uses it whenever there are no Baumgarte terms, so any difference would change every integrated run."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from physics.codegen.cache import clear_memory_cache
from physics.kernels import system as kernel_system
from physics.kernels.abi import (
    LAYOUT_ACCELERATION,
    LAYOUT_RHS,
    LAYOUT_SOLVE,
    LAYOUT_TIME,
    call_native_ratio,
    data_pointer,
)
from physics.mechanism import engine
from physics.mechanism.presets import MECHANISM_PRESETS
from physics.mechanism.simulate import simulate_mechanism

from .dae_states import STRUCTURED_PRESETS, preset_dae


@njit(cache=False)
def _both_ways(assemble, layout, t, theta, omega, params, fused_out, fused_ratio, memory_out, memory_ratio):
    system = kernel_system.make_system(assemble, layout)
    n = theta.shape[1]
    y = np.empty(2 * n)
    dydt = np.empty(2 * n)
    local = params.copy()
    for row in range(theta.shape[0]):
        if layout[LAYOUT_TIME] >= 0:
            local[layout[LAYOUT_TIME]] = t[row]
        for i in range(n):
            y[i] = theta[row, i]
            y[n + i] = omega[row, i]
        fused_ratio[row] = call_native_ratio(layout[LAYOUT_RHS], data_pointer(y), data_pointer(local),
                                             data_pointer(dydt))
        fused_out[row] = dydt
        kernel_system.assemble_into(system, theta[row], omega[row], local, 0.0, 0.0)
        memory_ratio[row] = call_native_ratio(layout[LAYOUT_SOLVE], data_pointer(system[2]),
                                              data_pointer(system[3]), data_pointer(system[4]))
        for i in range(n):
            memory_out[row, i] = omega[row, i]
            memory_out[row, n + i] = system[4][layout[LAYOUT_ACCELERATION + i]]


@pytest.mark.parametrize("name", STRUCTURED_PRESETS)
def test_the_fused_rhs_gives_the_bits_of_assemble_then_solve(name):
    dae = preset_dae(name, 1.0, 21)
    assert dae.layout[LAYOUT_RHS] != 0, "a mechanism's DAE has a fused rhs for the integrators"
    # Away from the run's states too (off the constraints, faster), where nothing cancels the same way.
    rng = np.random.default_rng(7)
    theta = np.concatenate([dae.theta, dae.theta + 1e-3 * rng.standard_normal(dae.theta.shape)])
    omega = np.concatenate([dae.omega, 3.0 * dae.omega + rng.standard_normal(dae.omega.shape)])
    t = np.concatenate([dae.t, dae.t + 0.37])
    count, n = theta.shape
    fused, memory = np.empty((count, 2 * n)), np.empty((count, 2 * n))
    fused_ratio, memory_ratio = np.empty(count), np.empty(count)
    _both_ways(dae.compiled.assemble_function, dae.layout, t, theta, omega, dae.params, fused, fused_ratio, memory,
               memory_ratio)
    assert np.all(np.isfinite(fused))
    assert np.array_equal(fused, memory), float(np.max(np.abs(fused - memory)))
    assert np.array_equal(fused_ratio, memory_ratio)


def test_the_fused_rhs_is_compiled_only_for_an_integration():
    """Its module is separate and compiled on first use: a driven mechanism's run (position analysis, no
    integration) never compiles it, and an integrated run's kernels get its address."""
    clear_memory_cache()
    driven = MECHANISM_PRESETS["jansen-leg"]()
    simulate_mechanism(driven, 0.5, 11, method="dae")
    compiled = engine.compiled_system(driven, "dae")
    assert compiled.module.STRUCTURED and compiled.layout[LAYOUT_RHS] == 0
    assert "LLVM_IR" in compiled._functions and "LLVM_IR_RHS" not in compiled._functions  # never compiled
    integrated = MECHANISM_PRESETS["slider-crank"]()
    simulate_mechanism(integrated, 0.5, 11, method="dae")
    compiled = engine.compiled_system(integrated, "dae")
    assert "LLVM_IR_RHS" in compiled._functions
    assert compiled.integration_layout[LAYOUT_RHS] != 0 and compiled.layout[LAYOUT_RHS] == 0
