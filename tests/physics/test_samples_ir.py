"""The samples' solve written as LLVM IR (physics.codegen.samples_ir) gives the numba kernels' very bits: every
unknown and condition estimate of solve_states, every matrix of assemble_states, for each formulation, open and
pinned chains, Baumgarte terms, the equilibrated fallback and a singular state."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import physics
from physics.codegen import load_compiled, native_samples
from physics.kernels import system


def _states(preset: str, method: str, links: int | None = None, samples: int = 60):
    chosen = physics.get_preset(preset, links)
    settings = physics.Settings(method=method, t_end=3.0, samples=samples, stabilization="none")
    run = physics.simulate(chosen.chain, chosen.theta0, chosen.omega0, settings)
    compiled = load_compiled(method, chosen.chain.n, chosen.chain.pinned)
    return chosen.chain, compiled, np.ascontiguousarray(run.theta), np.ascontiguousarray(run.omega)


def _solve_both(compiled, theta, omega, params, alpha=0.0, beta=0.0):
    outputs = []
    for solve in (native_samples.solve_states, system.solve_states):
        x = np.full((theta.shape[0], compiled.n_unknowns), 7.0)
        cond = np.full(theta.shape[0], 7.0)
        solve(compiled.assemble_function, compiled.layout, theta, omega, params, alpha, beta, x, cond)
        outputs.append((x, cond))
    return outputs


def _equal(ours, theirs) -> None:
    assert np.array_equal(ours, theirs, equal_nan=True), float(np.nanmax(np.abs(ours - theirs)))


CASES = [("triple-a", None), ("four-bar", None), ("chain", 10)]


@pytest.mark.parametrize("preset, links", CASES)
@pytest.mark.parametrize("method", ["lagrange", "newton_euler", "dae"])
def test_the_samples_solve_and_matrices_are_the_kernels(method, preset, links):
    chain, compiled, theta, omega = _states(preset, method, links)
    params = chain.params()
    (x, cond), (x_kernel, cond_kernel) = _solve_both(compiled, theta, omega, params)
    _equal(x, x_kernel)
    _equal(cond, cond_kernel)
    assert np.all(np.isfinite(x)) and np.all(cond >= 1.0)
    A, b = np.full((theta.shape[0], compiled.n_unknowns, compiled.n_unknowns), 7.0), np.full(x.shape, 7.0)
    A_kernel, b_kernel = A.copy(), b.copy()
    native_samples.assemble_states(compiled.assemble_function, compiled.layout, theta, omega, params, A, b)
    system.assemble_states(compiled.assemble_function, compiled.layout, theta, omega, params, A_kernel, b_kernel)
    _equal(A, A_kernel)
    _equal(b, b_kernel)


@pytest.mark.parametrize("method", ["lagrange", "newton_euler", "dae"])
def test_baumgarte_terms_a_light_tip_and_a_singular_state_solve_as_the_kernel_solves(method):
    """Baumgarte's terms on a pinned chain's rows; a tip a million times lighter (the equilibrated fallback);
    NaN states (a singular system: NaN unknowns, an infinite condition)."""
    chain, compiled, theta, omega = _states("four-bar", method, samples=30)
    params = chain.params()
    for x_pair in zip(*_solve_both(compiled, theta, omega, params, alpha=5.0, beta=7.0), strict=True):
        _equal(*x_pair)
    light = params.copy()
    light[8] *= 1e-6  # m_3 of [L1..3, d1..3, m1..3, I1..3, g, pin_x, pin_y, damping]
    light[11] *= 1e-6
    (x, cond), (x_kernel, cond_kernel) = _solve_both(compiled, theta, omega, light)
    _equal(x, x_kernel)
    _equal(cond, cond_kernel)
    broken = theta.copy()
    broken[::3, 1] = np.nan
    (x, cond), (x_kernel, cond_kernel) = _solve_both(compiled, broken, omega, params)
    _equal(x, x_kernel)
    _equal(cond, cond_kernel)
    assert np.isnan(x[0]).all() and np.isinf(cond[0])


def test_a_wrong_array_is_refused_before_any_pointer_is_handed_over():
    chain, compiled, theta, omega = _states("triple-a", "lagrange", samples=5)
    x = np.empty((5, compiled.n_unknowns))
    with pytest.raises(ValueError, match="C-contiguous"):
        native_samples.solve_states(compiled.assemble_function, compiled.layout, theta, omega, chain.params(), 0.0,
                                    0.0, x, np.empty(4))
    with pytest.raises(ValueError, match="C-contiguous"):
        native_samples.solve_states(compiled.assemble_function, compiled.layout, np.asfortranarray(theta[:, :2]),
                                    omega, chain.params(), 0.0, 0.0, x, np.empty(5))


@pytest.mark.parametrize("command", [
    ["simulate", "--preset", "triple-a", "--method", "lagrange"],
    ["simulate", "--preset", "triple-a", "--method", "newton_euler"],
    ["simulate", "--preset", "triple-a", "--method", "dae"],
    ["simulate", "--preset", "four-bar"],  # its default: held by projection onto the pin
    ["simulate", "--preset", "slider-crank"],  # a general mechanism's default: projection, weighted
    ["mechanism", "--preset", "jansen-leg", "--t-end", "2"],  # driven: position analysis by the IR projection
], ids=["lagrange", "newton_euler", "dae", "four-bar", "slider-crank", "jansen-leg-driven"])
def test_an_empty_cache_run_compiles_no_numba_kernel(command, tmp_path):
    """The first run of an installation (a fresh cache folder) integrates with the IR drivers (stabilised or
    not), projects and computes its samples with IR: numba writes no kernel into the cache and the "compiling
    ... once" line (said before any numba compilation) is not printed."""
    cache = tmp_path / "cache"
    env = dict(os.environ, LINKAGE_LAB_CACHE=str(cache))
    result = subprocess.run([sys.executable, "-m", "physics", *command], capture_output=True, text=True, timeout=300,
                            env=env, cwd=Path(__file__).resolve().parents[2])
    assert result.returncode == 0, result.stderr
    if command[0] == "simulate":
        assert result.stdout.count("\n") > 200  # the CSV of its 201 samples
    assert "compiling" not in result.stderr
    kernels = [path.name for path in (cache / "numba").rglob("*") if path.is_file()]
    assert kernels == []
