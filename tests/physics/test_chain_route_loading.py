"""What the command line loads before a chain's run starts its clock (physics/long_run.py): the system the run
will integrate, on the route the switch chooses (physics/simulate/on_mechanism.py). On the mechanism engine that
is the chain written as a mechanism; the chain's own generated system is never used there, and loading it cost a
new structure's first run a whole derivation and compilation (docs/architecture.md, "The chain on the mechanism
engine")."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

from physics import Settings, get_preset
from physics.simulate import on_mechanism

long_run = importlib.import_module("physics.long_run")


@pytest.fixture
def switch():
    """The switch as the test sets it, put back afterwards (tests/conftest.py may have set it for the session)."""
    kept = on_mechanism.ENABLED
    yield
    on_mechanism.ENABLED = kept


@pytest.mark.parametrize("method", ["newton_euler", "lagrange", "dae"])
def test_on_the_mechanism_engine_the_command_line_loads_the_routes_system_only(method, switch, monkeypatch):
    preset = get_preset("four-bar")
    settings = Settings(method=method, t_end=0.5, samples=6)
    on_mechanism.ENABLED = False
    expected = long_run.simulate_in_segments(preset.chain, preset.theta0, preset.omega0, settings)

    def refused(*_arguments):
        raise AssertionError("the chain's own generated system was loaded for a run on the mechanism engine")

    routes: list[tuple] = []
    load_route = on_mechanism.load_route
    monkeypatch.setattr(long_run, "load_compiled", refused)

    def recorded(*arguments) -> None:
        routes.append(arguments)
        load_route(*arguments)

    monkeypatch.setattr(on_mechanism, "load_route", recorded)
    on_mechanism.ENABLED = True
    got = long_run.simulate_in_segments(preset.chain, preset.theta0, preset.omega0, settings)
    assert routes == [(preset.chain, method, settings.damping)]
    assert got.status == expected.status
    np.testing.assert_allclose(got.theta, expected.theta, rtol=1e-11, atol=1e-11)


def test_with_the_switch_off_the_command_line_loads_the_chains_system(switch, monkeypatch):
    preset = get_preset("triple-a")
    settings = Settings(method="lagrange", t_end=0.5, samples=6)
    loaded: list[tuple] = []
    load_compiled = long_run.load_compiled

    def recorded(*arguments):
        loaded.append(arguments)
        return load_compiled(*arguments)

    monkeypatch.setattr(long_run, "load_compiled", recorded)
    monkeypatch.setattr(on_mechanism, "load_route", lambda *_arguments: pytest.fail("the route was loaded"))
    on_mechanism.ENABLED = False
    long_run.simulate_in_segments(preset.chain, preset.theta0, preset.omega0, settings)
    assert loaded == [("lagrange", 3, False)]
