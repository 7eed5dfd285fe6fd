"""The observables' function specialised for a plan's structure (physics/codegen/mechanism_observables_ir.py
``specialised_observables_ir``: the generic function inlined with the plan's sizes and indices as constant tables)
gives the generic function's bits: every Trajectory field of a chain's run with it in the one native call (and in
the samples' solve when a reader asks for the reactions) equals the same run with the generic function, byte for
byte; it is compiled only from a structure's second request (a
one-off run compiles nothing), one structure's machine code serves every set of its parameters, and its cache key
names the structure."""

from __future__ import annotations

import numpy as np
import pytest

from physics import Settings, get_preset, simulate
from physics.codegen import cache, machine_code, mechanism_observables
from physics.simulate import mechanism_route

from .test_route_call_cache import _assert_same
from .test_solved_when_read import every_field  # every Trajectory field, compared byte for byte


@pytest.fixture(autouse=True)
def _specialise_in_the_call(monkeypatch):
    monkeypatch.setattr(cache, "SPECIALISE_IN_BACKGROUND", False)




def _kept_run(chain):
    """The run shape (physics.codegen.mechanism_run._Run) of ``chain``'s remembered call."""
    calls = [call for call in mechanism_route._calls.values() if call.route.chain is chain]
    assert calls, "the call is remembered once the system's specialised functions are in place"
    return calls[-1].shape


@pytest.mark.parametrize("preset", ["triple-c", "four-bar"])
@pytest.mark.parametrize("method", ["lagrange", "newton_euler", "dae"])
@pytest.mark.parametrize("extra", [{}, {"damping": 0.3}, {"trace": {"bar": 2, "along": 0.3, "across": 0.2}},
                                   {"integrator": "DOP853", "samples": 7}, {"max_steps": 2}])
def test_the_specialised_observables_give_the_generic_bits(monkeypatch, preset, method, extra):
    chosen = get_preset(preset)
    settings = Settings(**{"method": method, "integrator": "RK45", "rtol": 1e-6, "atol": 1e-6, "t_end": 2.0,
                           "samples": 41, **extra})
    theta0, omega0 = np.asarray(chosen.theta0, float), np.asarray(chosen.omega0, float)
    for _ in range(3):  # the structure asked for twice: compiled (or loaded), in place by the third run
        specialised = every_field(simulate(chosen.chain, theta0, omega0, settings))  # (the samples solved too)
    kept = _kept_run(chosen.chain)
    # the run's plan (points and energies) and its samples' solve's (every reaction row), each specialised
    assert len(kept._observables_specialised) == 2
    assert all(made is not None for made in kept._observables_specialised.values())
    monkeypatch.setattr(mechanism_observables, "SPECIALISE_OBSERVABLES", False)
    monkeypatch.setattr(kept, "_observables_specialised", {})
    generic = every_field(simulate(chosen.chain, theta0, omega0, settings))
    assert list(kept._observables_specialised.values()) == [None, None]
    _assert_same(specialised, generic)


def test_a_structure_is_compiled_from_its_second_request_and_shared_by_its_parameters(monkeypatch):
    monkeypatch.setattr(mechanism_observables, "_specialised", {})
    monkeypatch.setattr(mechanism_observables, "_asked", {})
    monkeypatch.setattr(machine_code, "is_cached", lambda key, variant: False)
    chosen = get_preset("triple-c")
    route = mechanism_route.chain_route(chosen.chain, "lagrange", 0.0)
    plan = mechanism_route._chain_plan(chosen.chain, Settings(method="lagrange"), route)
    assert mechanism_observables.specialised_observables(plan) is None  # a one-off run compiles nothing
    made = mechanism_observables.specialised_observables(plan)
    assert made is not None
    heavier = chosen.chain.model_copy(update={"bars": [bar.model_copy(update={"m": 2.5 * bar.m})
                                                       for bar in chosen.chain.bars]})
    heavier_route = mechanism_route.chain_route(heavier, "lagrange", 0.0)
    heavier_plan = mechanism_route._chain_plan(heavier, Settings(method="lagrange"), heavier_route)
    assert heavier_plan.constants.tobytes() != plan.constants.tobytes()
    assert mechanism_observables.specialised_observables(heavier_plan) is made  # the structure's code


def test_the_cache_key_names_the_structure_and_the_sources():
    chosen = get_preset("triple-c")
    keys = set()
    for method in ("lagrange", "dae"):
        route = mechanism_route.chain_route(chosen.chain, method, 0.0)
        plan = mechanism_route._chain_plan(chosen.chain, Settings(method=method), route)
        key = mechanism_observables.specialised_key(plan)
        assert machine_code.sources_digest() in key
        keys.add(key)
    assert len(keys) == 2
