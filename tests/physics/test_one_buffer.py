"""A compiled RK45/DOP853 chain run in one buffer (physics.codegen.native_run: the driver and the samples' pass
in one array, the samples' pass in one native call, the Trajectory made by Trajectory.of_chain) gives every
field of the Trajectory that the path through build_trajectory gives, bit for bit: with the generic functions
(a system's first run) and the specialised ones, open and pinned chains, stabilised or not, and a run that
stops early."""

from __future__ import annotations

import numpy as np
import pytest

import physics
from physics.codegen import cache, load_compiled, native_samples, specialised_ir
from physics.kernels import observables
from physics.simulate import on_mechanism
from physics.simulate.prepared import chain_arrays
from physics.simulate.trajectory import Trajectory

run_module = __import__("physics.simulate.run", fromlist=["ONE_BUFFER"])


@pytest.fixture(autouse=True)
def _specialise_in_the_call(monkeypatch):
    """Specialised functions made in the call that asks (not in a background thread), so a test knows when; and
    the chain's own kernels, whose one buffer these tests inspect (physics.simulate takes the mechanism engine by
    default)."""
    monkeypatch.setattr(cache, "SPECIALISE_IN_BACKGROUND", False)
    monkeypatch.setattr(on_mechanism, "ENABLED", False)


def _fields(run: Trajectory) -> dict:
    return dict(run.__dict__)


def _assert_same_run(ours: Trajectory, theirs: Trajectory) -> None:
    mine, other = _fields(ours), _fields(theirs)
    assert list(mine) == list(other)  # the same fields, set in the same order
    for name, value in mine.items():
        if isinstance(value, np.ndarray):
            assert isinstance(other[name], np.ndarray), name
            assert value.shape == other[name].shape and value.dtype == other[name].dtype, name
            assert np.array_equal(value, other[name], equal_nan=True), name
        else:
            assert value == other[name], name


def _both(monkeypatch, preset: str, settings: physics.Settings) -> tuple[Trajectory, Trajectory]:
    chosen = physics.get_preset(preset)
    runs = []
    for one_buffer in (True, False):
        monkeypatch.setattr(run_module, "ONE_BUFFER", one_buffer)
        runs.append(physics.simulate(chosen.chain, chosen.theta0, chosen.omega0, settings))
    return runs[0], runs[1]


CASES = [
    ("triple-c", "RK45", "none", 20.0, 200),
    ("triple-a", "DOP853", "none", 5.0, 101),
    ("four-bar", "RK45", "projection", 3.0, 61),
    ("four-bar", "DOP853", "baumgarte", 3.0, 61),
]


@pytest.mark.parametrize("preset, integrator, stabilization, t_end, samples", CASES)
@pytest.mark.parametrize("method", ["lagrange", "newton_euler", "dae"])
def test_a_run_in_one_buffer_is_the_build_trajectory_run(monkeypatch, method, preset, integrator, stabilization,
                                                         t_end, samples):
    """Every field, the first run (generic driver and samples' pass) and later runs (specialised ones)."""
    cache.clear_memory_cache()
    monkeypatch.setattr("physics.codegen.native_integrators.specialised_cached", lambda *arguments: False)
    settings = physics.Settings(method=method, integrator=integrator, rtol=1e-6, atol=1e-6, t_end=t_end,
                                samples=samples, stabilization=stabilization)
    for _ in range(3):  # generic, then specialised from the second run of each
        _assert_same_run(*_both(monkeypatch, preset, settings))
    compiled = load_compiled(method, physics.get_preset(preset).chain.n, physics.get_preset(preset).chain.pinned)
    assert f"run functions {integrator}" in compiled._functions  # the last runs took the specialised ones


def test_a_run_that_stops_early_keeps_its_finite_rows_in_both_paths(monkeypatch):
    """A run that runs out of steps: the same status, message, counts and rows (fewer than asked for)."""
    settings = physics.Settings(method="lagrange", integrator="RK45", rtol=1e-6, atol=1e-6, t_end=20.0,
                                samples=200, max_steps=40)
    ours, theirs = _both(monkeypatch, "triple-c", settings)
    assert not ours.success and 0 < ours.t.shape[0] < 200
    _assert_same_run(ours, theirs)


def test_trajectory_of_chain_is_the_dataclass_init():
    """Trajectory.of_chain makes the object Trajectory(...) makes: the same entries in the same order, the
    left-out fields the same empty arrays."""
    rows, n = 7, 3
    rng = np.random.default_rng(3)
    arrays = {name: rng.standard_normal(shape) for name, shape in (
        ("t", (rows,)), ("trace_xy", (rows, 2)), ("kinetic", (rows,)), ("potential", (rows,)), ("energy", (rows,)),
        ("condition", (rows,)), ("theta", (rows, n)), ("omega", (rows, n)), ("joints", (rows, n + 1, 2)),
        ("tip_xy", (rows, 2)), ("reactions", (rows, 0, 2)), ("tip_reaction", (rows, 0)),
        ("constraint_xy", (rows, 0)), ("constraint_velocity", (rows, 0)), ("joint_reactions", (rows, n, 2)))}
    for explicit in (False, True):
        ours = Trajectory.of_chain("dae", "RK45", arrays["t"], arrays["trace_xy"], arrays["kinetic"],
                                   arrays["potential"], arrays["energy"], arrays["condition"], arrays["theta"],
                                   arrays["omega"], arrays["joints"], arrays["tip_xy"], arrays["reactions"],
                                   arrays["tip_reaction"], arrays["constraint_xy"], arrays["constraint_velocity"],
                                   arrays["joint_reactions"], explicit)
        theirs = Trajectory(method="dae", integrator="RK45", trace_is_explicit=explicit, **arrays)
        _assert_same_run(ours, theirs)
        assert ours.stats is not theirs.stats and ours.q is not theirs.q


@pytest.mark.parametrize("preset", ["triple-a", "four-bar"])
@pytest.mark.parametrize("specialised", [False, True])
def test_the_samples_pass_adds_the_energies_and_takes_the_accelerations(preset, specialised):
    """trajectory_samples' energy is kinetic + potential, its accelerations and pin force the unknowns' columns
    (np.take), generic and specialised, and the kernels' positions and energies."""
    chosen = physics.get_preset(preset)
    chain = chosen.chain
    run = physics.simulate(chain, chosen.theta0, chosen.omega0,
                           physics.Settings(method="dae", t_end=2.0, samples=41, stabilization="none"))
    compiled = load_compiled("dae", chain.n, chain.pinned)
    functions = None
    if specialised:
        compiled._functions.setdefault("specialised calls", {})["samples"] = 1
        functions = compiled.samples_solve() or compiled.samples_solve()
        assert functions is not None
    bars, params = chain_arrays(chain), chain.params()
    tip_index = compiled.tip_reaction_index if chain.pinned else ()
    y = np.concatenate([run.theta, run.omega], axis=1)
    ours = native_samples.trajectory_samples(compiled.assemble_function, compiled.layout, y, params, 0.0, 0.0,
                                             bars.bars, bars.g, 1, 0.4, 0.1, compiled.theta_ddot_index, tip_index,
                                             functions)
    assert np.array_equal(ours.energy, ours.kinetic + ours.potential)
    assert np.array_equal(ours.theta_ddot, np.take(ours.x, compiled.theta_ddot_index, axis=1))
    if chain.pinned:
        assert np.array_equal(ours.tip_reaction, np.take(ours.x, compiled.tip_reaction_index, axis=1))
    rows = y.shape[0]
    observed = (np.empty((rows, chain.n + 1, 2)), np.empty((rows, 2)), np.empty(rows), np.empty(rows),
                np.empty((rows, 2)))
    observables.chain_observables(np.ascontiguousarray(run.theta), np.ascontiguousarray(run.omega), bars.L, bars.d,
                                  bars.m, bars.I, bars.g, 1, 0.4, 0.1, *observed)
    for mine, theirs in zip((ours.joints, ours.trace_xy, ours.kinetic, ours.potential, ours.tip_velocity), observed,
                            strict=True):
        assert np.array_equal(mine, theirs)


def test_the_specialised_samples_text_is_the_same_and_holds_no_address():
    """The machine-code cache keys the specialised samples' module (solve and whole pass) by its text."""
    compiled = load_compiled("dae", 3, True)
    layout = compiled.layout
    shape = [1 if slot in specialised_ir.ADDRESS_SLOTS and value else int(value) for slot, value in enumerate(layout)]
    text = specialised_ir.specialised_samples_ir(shape, "0123abcd")
    assert text == specialised_ir.specialised_samples_ir(shape, "0123abcd")
    assert "samples_pass_specialised" in text and "solve_states_specialised" in text
    for slot in specialised_ir.ADDRESS_SLOTS:
        if layout[slot]:
            assert str(int(layout[slot])) not in text
    assert str(int(compiled.assemble_function)) not in text
