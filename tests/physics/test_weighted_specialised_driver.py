"""A maximal mechanism's run integrates with its projection weights in the layout (``LAYOUT_WEIGHTS``). That
layout is now the system's own (``CompiledSystem.weighted_layout``, one array per offset), so the run takes a
driver specialised for it (the weights' offset folded in with the sizes) instead of the generic O0 one: the
same IR without fast-math, so the same bits. Here: the specialised driver against numba's kernel on the weighted
layout with projection, and whole runs (an open tree, a closed loop with a motor, a six-bar) with and without it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from physics.codegen import cache, native_integrators
from physics.codegen.cache import CompiledSystem
from physics.kernels import explicit_rk
from physics.kernels.layout import LAYOUT_WEIGHTS
from physics.mechanism import MECHANISM_PRESETS, engine
from physics.mechanism.files import load_mechanism
from physics.mechanism.prepared import prepared
from physics.mechanism.simulate import simulate_mechanism

TRIPLE_FILE = Path(__file__).resolve().parents[2] / "docs" / "examples" / "triple-pendulum.json"
KERNELS = {"RK45": explicit_rk.integrate_rk45, "DOP853": explicit_rk.integrate_dop853}


@pytest.fixture(autouse=True)
def _specialise_in_the_call(monkeypatch):
    """Specialised functions made in the call that asks (not in a background thread), so a test knows when."""
    monkeypatch.setattr(cache, "SPECIALISE_IN_BACKGROUND", False)


def _mechanism(name: str):
    return load_mechanism(TRIPLE_FILE) if name == "triple-file" else MECHANISM_PRESETS[name]()


def _compiled(mechanism):
    pieces = prepared(mechanism)
    return engine.compiled_system(mechanism, "dae", pieces.structure_key), pieces


def test_the_weighted_layout_is_the_systems_own_and_keyed_by_its_offset():
    mechanism = _mechanism("triple-file")
    compiled, pieces = _compiled(mechanism)
    params, layout = engine.run_parameters(mechanism, compiled, 0.0, pieces.projection_weights)
    again = engine.run_parameters(mechanism, compiled, 0.0, pieces.projection_weights)[1]
    assert layout is again and layout is not compiled.integration_layout
    assert int(layout[LAYOUT_WEIGHTS]) == params.size - pieces.projection_weights.size
    assert compiled.is_own_integration_layout(layout) and compiled.is_own_integration_layout(
        compiled.integration_layout)
    unchanged = np.delete(np.arange(layout.size), LAYOUT_WEIGHTS)
    assert np.array_equal(layout[unchanged], compiled.integration_layout[unchanged])
    stranger = layout.copy()
    assert not compiled.is_own_integration_layout(stranger)
    with pytest.raises(ValueError, match="layout"):
        compiled.specialised_driver("DOP853", stranger)
    driven = engine.run_parameters(mechanism, compiled, 0.0, pieces.projection_weights, integrating=False)[1]
    assert driven is not layout and not compiled.is_own_integration_layout(driven)


@pytest.mark.parametrize("name", ["triple-file", "slider-crank", "watt-six-bar"])
@pytest.mark.parametrize("integrator", ["RK45", "DOP853"])
def test_the_weighted_specialised_driver_gives_the_kernels_bits(name, integrator):
    mechanism = _mechanism(name)
    compiled, pieces = _compiled(mechanism)
    params, layout = engine.run_parameters(mechanism, compiled, 0.0, pieces.projection_weights)
    compiled.count_integration(integrator, layout, 1000, 1.0)  # a run of 1e9 s would evaluate 1e12: worth it
    driver = compiled.specialised_driver(integrator, layout, 1e9)
    assert driver is not None
    assert driver is not compiled.specialised_driver(integrator)  # the unweighted system's is another
    run = simulate_mechanism(mechanism, 0.01, 2)  # the assembled start
    y0 = np.ascontiguousarray(np.concatenate([run.q[0], run.qdot[0]]))
    t_eval = np.linspace(0.0, 3.0, 61)
    results = []
    for which in ("specialised", "kernel"):
        y_out = np.full((t_eval.size, y0.size), 7.0)
        arguments = (layout, y0, 0.0, 3.0, t_eval, params, 1e-9, 1e-9, 0.0, 0.0, True, 1_000_000, y_out,
                     np.empty(0))
        if which == "specialised":
            result = native_integrators.integrate(integrator, compiled.assemble_function, *arguments, driver=driver)
        else:
            result = KERNELS[integrator](compiled.assemble_function, *arguments)
            result = (int(result[0]), int(result[1]), int(result[2]), float(result[3]), int(result[4]))
        results.append((result, y_out))
    (ours, our_samples), (kernel, kernel_samples) = results
    assert ours == kernel and ours[0] == 0 and ours[4] == t_eval.size
    assert np.array_equal(our_samples, kernel_samples)


FIELDS = ("t", "q", "qdot", "kinetic", "potential", "energy", "residual", "trace_xy")


def _forget(compiled) -> None:
    """The system as a new process finds it: no weighted driver made, no work counted."""
    compiled._functions.pop("specialised calls", None)
    for key in [key for key in compiled._functions
                if str(key).startswith(("specialised DOP853 weights", "work DOP853 weights"))]:
        compiled._functions.pop(key)


@pytest.mark.parametrize("name", ["triple-file", "slider-crank", "stephenson-six-bar"])
def test_a_run_with_the_weighted_specialised_driver_is_the_generic_runs(name, monkeypatch):
    """Whole runs (DOP853 1e-10 with projection, the mechanism command's settings): first with the generic
    driver (the specialised one refused), then the system's runs with any run judged worth compiling for: the
    first (no work counted yet) keeps the generic driver, the next make and take the specialised one."""
    mechanism = _mechanism(name)
    compiled, _ = _compiled(mechanism)
    _forget(compiled)
    monkeypatch.setattr(cache, "SPECIALISE_WEIGHTED_RHS", 1)
    taken = []
    original = CompiledSystem.specialised_driver

    def spy(self, method, layout=None, span=None):
        driver = original(self, method, layout, span)
        taken.append(driver is not None)
        return driver

    with monkeypatch.context() as patch:
        patch.setattr(CompiledSystem, "specialised_driver", lambda self, method, layout=None, span=None: None)
        generic = simulate_mechanism(mechanism, 4.0, 41)
    _forget(compiled)  # its work not counted either
    monkeypatch.setattr(CompiledSystem, "specialised_driver", spy)
    monkeypatch.setattr(native_integrators, "specialised_cached", lambda *arguments: False)
    runs = [simulate_mechanism(mechanism, 4.0, 41) for _ in range(3)]
    assert taken == [False, True, True]
    for run in runs:
        assert (run.status, run.n_steps, run.n_rhs) == (generic.status, generic.n_steps, generic.n_rhs)
        for field in FIELDS:
            assert np.array_equal(getattr(run, field), getattr(generic, field)), field
        assert np.array_equal(np.asarray(run.reaction_rows), np.asarray(generic.reaction_rows))


def test_the_weighted_driver_is_compiled_only_for_a_run_long_enough_to_pay(monkeypatch):
    """Not cached: short runs (4 s of the triple pendulum file, about 1,000 right-hand sides each) keep the
    generic driver however many there are; a run whose span at this process's rate so far comes to
    SPECIALISE_WEIGHTED_RHS or more makes the specialised one (the same bits as a generic run of it)."""
    monkeypatch.setattr(native_integrators, "specialised_cached", lambda *arguments: False)
    mechanism = _mechanism("triple-file")
    compiled, _ = _compiled(mechanism)
    _forget(compiled)
    key = None
    for _ in range(3):
        run = simulate_mechanism(mechanism, 4.0, 41)
        key = next(key for key in compiled._functions if str(key).startswith("work DOP853 weights"))
        assert not any(str(name).startswith("specialised DOP853 weights") for name in compiled._functions)
    rhs, seconds = compiled._functions[key]
    assert rhs == 3 * run.n_rhs and seconds == pytest.approx(12.0)  # the three runs' counts, added up
    span = cache.SPECIALISE_WEIGHTED_RHS / (rhs / seconds) * 1.05  # just long enough by this rate
    with monkeypatch.context() as patch:
        patch.setattr(CompiledSystem, "specialised_driver", lambda self, method, layout=None, span=None: None)
        generic = simulate_mechanism(mechanism, span, 11)
    _forget(compiled)
    compiled._functions[key] = (rhs, seconds)
    long = simulate_mechanism(mechanism, span, 11)
    assert any(str(name).startswith("specialised DOP853 weights") for name in compiled._functions)
    assert (long.n_steps, long.n_rhs) == (generic.n_steps, generic.n_rhs)
    assert np.array_equal(long.q, generic.q) and np.array_equal(long.qdot, generic.qdot)
