"""The IR drivers specialised for one system (physics.codegen.specialised_ir: the system's layout a constant
table, its generated functions external symbols, LLVM's O2 pipeline) give the numba kernel's very bits, as the
generic IR drivers do: every sample, the status, the counts and where the run stopped. A compiled system
switches to them at once when their machine code is cached, else from its second run in a process on (compiled
in a background thread by default)."""

from __future__ import annotations

import numpy as np
import pytest

import physics
from physics.codegen import cache, load_compiled, native_integrators, specialised_ir
from physics.codegen.ir_shapes import samples_scratch_length
from physics.kernels import explicit_rk
from physics.kernels.constants import STATUS_NOT_FINITE, STATUS_OK, STATUS_SINGULAR
from physics.kernels.layout import LAYOUT_CONSTRAINTS


@pytest.fixture(autouse=True)
def _specialise_in_the_call(monkeypatch):
    """Specialised functions made in the call that asks (not in a background thread), so a test knows when."""
    monkeypatch.setattr(cache, "SPECIALISE_IN_BACKGROUND", False)


KERNELS = {"RK45": explicit_rk.integrate_rk45, "DOP853": explicit_rk.integrate_dop853}
G_INDEX = -4  # chain.params(): [L.., d.., m.., I.., g, pin_x, pin_y, damping]


def _system(preset: str, method: str, links: int | None = None):
    chosen = physics.get_preset(preset, links)
    compiled = load_compiled(method, chosen.chain.n, chosen.chain.pinned)
    y0 = np.concatenate([chosen.theta0, chosen.omega0]).astype(float)
    return compiled, y0, chosen.chain.params()


def _specialised(compiled, integrator: str):
    """The system's specialised driver, made directly (not by the second-run rule)."""
    compiled._functions.setdefault("specialised calls", {})[integrator] = 1
    driver = compiled.specialised_driver(integrator)
    if driver is None:  # not cached: the second run makes it
        driver = compiled.specialised_driver(integrator)
    assert driver is not None
    return driver


def _both(compiled, integrator, y0, t_end, t_eval, params, rtol, atol, max_steps=1_000_000):
    layout = compiled.integration_layout
    results = []
    for run in ("specialised", "kernel"):
        y_out = np.full((t_eval.size, y0.size), 7.0)  # anything but NaN: the run must write every row
        arguments = (layout, y0, 0.0, t_end, t_eval, params, rtol, atol, 0.0, 0.0, False, max_steps, y_out,
                     np.empty(0))
        if run == "specialised":
            result = native_integrators.integrate(integrator, compiled.assemble_function, *arguments,
                                                  driver=_specialised(compiled, integrator))
        else:
            result = KERNELS[integrator](compiled.assemble_function, *arguments)
            result = (int(result[0]), int(result[1]), int(result[2]), float(result[3]), int(result[4]))
        results += [result, y_out]
    return tuple(results)


def _assert_identical(ours, our_samples, kernel, kernel_samples):
    assert ours == kernel
    assert np.array_equal(our_samples, kernel_samples, equal_nan=True), float(
        np.nanmax(np.abs(our_samples - kernel_samples)))


@pytest.mark.parametrize("integrator, rtol, atol, t_end", [("RK45", 1e-6, 1e-6, 20.0), ("DOP853", 1e-10, 1e-12, 10.0)])
@pytest.mark.parametrize("preset", ["triple-a", "triple-c", "four-bar"])
@pytest.mark.parametrize("method", ["lagrange", "newton_euler", "dae"])
def test_the_specialised_driver_gives_the_kernels_bits(method, preset, integrator, rtol, atol, t_end):
    """Open and pinned chains (the four-bar: two constraint rows judged by the geometric test), every
    formulation: Lagrange's L D L^T, Newton-Euler's pivoted LU, the DAE's fused rhs."""
    compiled, y0, params = _system(preset, method)
    t_eval = np.linspace(0.0, t_end, 200)
    ours, our_samples, kernel, kernel_samples = _both(compiled, integrator, y0, t_end, t_eval, params, rtol, atol)
    _assert_identical(ours, our_samples, kernel, kernel_samples)
    assert ours[0] == STATUS_OK and ours[4] == 200 and ours[1] > 50


def test_a_longer_chain_gives_the_kernels_bits():
    compiled, y0, params = _system("chain", "lagrange", 6)
    t_eval = np.linspace(0.0, 5.0, 101)
    results = _both(compiled, "RK45", y0, 5.0, t_eval, params, 1e-8, 1e-10)
    _assert_identical(*results)
    assert results[0][0] == STATUS_OK


@pytest.mark.parametrize("method", ["lagrange", "dae"])
def test_a_blow_up_gives_the_kernels_status(method):
    """Overflowing accelerations: NOT_FINITE at the same step; a NaN start: singular, as the kernel says."""
    compiled, y0, params = _system("triple-a", method)
    huge = params.copy()
    huge[G_INDEX] = 1e306
    t_eval = np.linspace(0.0, 5.0, 51)
    results = _both(compiled, "RK45", y0, 5.0, t_eval, huge, 1e-6, 1e-9)
    _assert_identical(*results)
    assert results[0][0] == STATUS_NOT_FINITE
    start = y0.copy()
    start[1] = np.nan
    results = _both(compiled, "RK45", start, 5.0, t_eval, params, 1e-6, 1e-9)
    _assert_identical(*results)
    assert results[0][0] == STATUS_SINGULAR


def test_the_specialised_text_holds_no_address():
    """The machine-code cache keys the module by its text: an address in it would make every process's text
    new (and the cache never hit). The symbols carry the system's digest; the loading process binds them."""
    compiled, _, _ = _system("triple-a", "dae")
    layout = compiled.integration_layout
    shape = [1 if slot in specialised_ir.ADDRESS_SLOTS and value else int(value) for slot, value in enumerate(layout)]
    text = specialised_ir.specialised_ir("RK45", shape, "0123abcd")
    assert text == specialised_ir.specialised_ir("RK45", shape, "0123abcd")
    for slot in specialised_ir.ADDRESS_SLOTS:
        if layout[slot]:
            assert str(int(layout[slot])) not in text
            assert f"linkage_lab_0123abcd_slot{slot}" in text
    assert str(int(compiled.assemble_function)) not in text
    with pytest.raises(ValueError, match="method"):
        specialised_ir.specialised_ir("RK23", shape, "0123abcd")


def test_a_system_switches_to_the_specialised_driver_at_its_second_run(monkeypatch):
    """Not cached: the first run keeps the generic driver (no O2 compilation for a one-off run), the second
    makes the specialised one, and both runs give the same bits."""
    cache.clear_memory_cache()
    monkeypatch.setattr(native_integrators, "specialised_cached", lambda *arguments: False)
    compiled, y0, params = _system("triple-c", "newton_euler")
    t_eval = np.linspace(0.0, 20.0, 200)
    outputs = []
    for _ in range(2):
        y_out = np.empty((200, 6))
        result = compiled.integrate_rk45(y0, 0.0, 20.0, t_eval, params, 1e-6, 1e-6, 0.0, 0.0, False, 100_000, y_out,
                                         np.empty(0))
        outputs.append((result, y_out))
        made = "specialised RK45" in compiled._functions
        assert made == (len(outputs) == 2)
    assert outputs[0][0] == outputs[1][0] and np.array_equal(outputs[0][1], outputs[1][1])


@pytest.mark.parametrize("preset", ["triple-a", "four-bar"])
@pytest.mark.parametrize("method", ["lagrange", "newton_euler", "dae"])
def test_the_specialised_samples_solve_gives_the_kernels_bits(method, preset):
    """The samples' solve specialised for the system: every unknown and condition estimate as numba's
    solve_states, open and pinned chains, with and without Baumgarte terms."""
    from physics.kernels import system  # noqa: PLC0415

    chosen = physics.get_preset(preset)
    run = physics.simulate(chosen.chain, chosen.theta0, chosen.omega0,
                           physics.Settings(method=method, t_end=3.0, samples=61, stabilization="none"))
    compiled = load_compiled(method, chosen.chain.n, chosen.chain.pinned)
    compiled._functions.setdefault("specialised calls", {})["samples"] = 1
    solve = compiled.samples_solve() or compiled.samples_solve()
    assert solve is not None
    theta, omega, params = np.ascontiguousarray(run.theta), np.ascontiguousarray(run.omega), chosen.chain.params()
    rows, n, k = theta.shape[0], chosen.chain.n, compiled.n_unknowns
    scratch = np.empty(samples_scratch_length(n, k, int(compiled.layout[LAYOUT_CONSTRAINTS])))
    for alpha, beta in ((0.0, 0.0), (5.0, 20.0)):
        ours_x, ours_cond = np.full((rows, k), 7.0), np.full(rows, 7.0)
        solve.solve(int(compiled.assemble_function), compiled.layout.ctypes.data, rows, theta.ctypes.data,
                    omega.ctypes.data, params.ctypes.data, alpha, beta, ours_x.ctypes.data, ours_cond.ctypes.data,
                    scratch.ctypes.data)
        x, cond = np.empty_like(ours_x), np.empty_like(ours_cond)
        system.solve_states(compiled.assemble_function, compiled.layout, theta, omega, params, alpha, beta, x, cond)
        _assert_identical(None, ours_x, None, x)
        _assert_identical(None, ours_cond, None, cond)


def test_the_specialised_driver_is_compiled_in_the_background(monkeypatch):
    """By default the second run does not wait for the O2 compilation: it takes the generic driver while a
    thread compiles, and a run after the thread is done takes the specialised one (the same bits)."""
    import threading  # noqa: PLC0415

    cache.clear_memory_cache()
    monkeypatch.setattr(cache, "SPECIALISE_IN_BACKGROUND", True)
    monkeypatch.setattr(native_integrators, "specialised_cached", lambda *arguments: False)
    compiled, y0, params = _system("triple-c", "lagrange")
    t_eval = np.linspace(0.0, 20.0, 200)
    outputs = []
    for _ in range(2):
        y_out = np.empty((200, 6))
        result = compiled.integrate_rk45(y0, 0.0, 20.0, t_eval, params, 1e-6, 1e-6, 0.0, 0.0, False, 100_000, y_out,
                                         np.empty(0))
        outputs.append((result, y_out))
    for thread in threading.enumerate():
        if thread.name == "specialise RK45":
            thread.join()
    assert "specialised RK45" in compiled._functions
    y_out = np.empty((200, 6))
    result = compiled.integrate_rk45(y0, 0.0, 20.0, t_eval, params, 1e-6, 1e-6, 0.0, 0.0, False, 100_000, y_out,
                                     np.empty(0))
    assert all(earlier == result and np.array_equal(samples, y_out) for earlier, samples in outputs)
