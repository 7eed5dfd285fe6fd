"""A mechanism run's samples' native calls in one buffer (physics/codegen/mechanism_samples.py, issue 24: the
chain run as a mechanism no slower than the chain engine) give every field of the run the calls one at a time
give, bit for bit: tree formulations with absolute and relative rotations, the DAE in tree and in maximal
coordinates, open trees (no held constraints) and loops (the constraint call), integrated and driven runs, with
the generic samples' solve (a system's first run) and the specialised one."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from physics.chain_presets import get_preset
from physics.codegen import cache
from physics.mechanism import MECHANISM_PRESETS, engine
from physics.mechanism.chains import chain_mechanism, chain_state
from physics.mechanism.simulate import simulate_mechanism


@pytest.fixture(autouse=True)
def _specialise_in_the_call(monkeypatch):
    """Specialised functions made in the call that asks (not in a background thread), so a test knows when."""
    monkeypatch.setattr(cache, "SPECIALISE_IN_BACKGROUND", False)


def _assert_identical(first, second) -> None:
    for field in dataclasses.fields(first):
        value, other = getattr(first, field.name), getattr(second, field.name)
        if isinstance(value, np.ndarray):
            assert value.shape == other.shape and np.array_equal(value, other, equal_nan=True), field.name
        else:
            assert value == other, field.name


def _both(monkeypatch, run):
    """``run()`` with the samples' calls one at a time, then twice in one buffer (the second run of a system
    takes its specialised samples' solve)."""
    monkeypatch.setattr(engine, "ONE_BUFFER_SAMPLES", False)
    reference = run()
    monkeypatch.setattr(engine, "ONE_BUFFER_SAMPLES", True)
    return reference, run(), run()


def _triple(method: str, rotations: str):
    preset = get_preset("triple-c")
    zero = np.zeros(preset.chain.n)
    mechanism = chain_mechanism(preset.chain, zero)
    q0, qdot0 = chain_state(preset.chain, zero, preset.theta0, preset.omega0)
    extra = {"coordinates": "tree"} if method == "dae" else {}
    return lambda: simulate_mechanism(mechanism, 20.0, 200, q0=q0, qdot0=qdot0, method=method, integrator="RK45",
                                      rtol=1e-6, atol=1e-6, rotations=rotations, **extra)


@pytest.mark.parametrize("rotations", ["absolute", "relative"])
@pytest.mark.parametrize("method", ["newton_euler", "lagrange", "dae"])
def test_seed_case_c_as_a_mechanism_is_bit_identical_in_one_buffer(monkeypatch, method, rotations):
    reference, generic, specialised = _both(monkeypatch, _triple(method, rotations))
    assert reference.n_steps == 192 or rotations == "relative"
    _assert_identical(reference, generic)
    _assert_identical(reference, specialised)
    assert specialised.reaction_rows.shape == (200, 6)


@pytest.mark.parametrize("coordinates, method", [("maximal", "dae"), ("tree", "dae"), ("maximal", "lagrange"),
                                                 ("maximal", "newton_euler")])
@pytest.mark.parametrize("name", ["slider-crank", "jansen-leg"])
def test_loops_and_driven_runs_are_bit_identical_in_one_buffer(monkeypatch, name, coordinates, method):
    mechanism = MECHANISM_PRESETS[name]()
    reference, generic, specialised = _both(monkeypatch, lambda: simulate_mechanism(
        mechanism, 0.5, 41, method=method, coordinates=coordinates, integrator="DOP853", rtol=1e-8, atol=1e-8))
    _assert_identical(reference, generic)
    _assert_identical(reference, specialised)
    assert np.all(reference.residual < 1e-6)
