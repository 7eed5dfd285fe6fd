"""What the command line loads before a chain's run starts its clock (physics/long_run.py): the system the run
will integrate, on the route the switch chooses (physics/simulate/chain_system.py). On the mechanism engine that
is the chain written as a mechanism; the chain's own generated system is never used there, and loading it cost a
new 10-link chain's first Lagrange run a whole derivation and compilation (BENCHMARKS.md, "A chain preset's whole
process on the mechanism engine")."""

from __future__ import annotations

import importlib
import sys

import numpy as np
import pytest

from physics import Settings, get_preset
from physics.simulate import on_mechanism
from physics.simulate.chain_system import chain_system

long_run = importlib.import_module("physics.long_run")
chain_system_module = sys.modules[chain_system.__module__]


@pytest.mark.parametrize("method", ["newton_euler", "lagrange", "dae"])
def test_on_the_mechanism_engine_the_command_line_never_loads_the_chains_own_system(method, monkeypatch):
    preset = get_preset("four-bar")
    settings = Settings(method=method, t_end=0.5, samples=6)
    monkeypatch.setattr(on_mechanism, "ENABLED", False)
    expected = long_run.simulate_in_segments(preset.chain, preset.theta0, preset.omega0, settings)

    def refused(*_arguments, **_keywords):
        raise AssertionError("the chain's own generated system was loaded for a run on the mechanism engine")

    monkeypatch.setattr(chain_system_module, "load_compiled", refused)
    monkeypatch.setattr(on_mechanism, "ENABLED", True)
    got = long_run.simulate_in_segments(preset.chain, preset.theta0, preset.omega0, settings)
    assert got.status == expected.status
    np.testing.assert_allclose(got.theta, expected.theta, rtol=1e-11, atol=1e-11)


def test_with_the_switch_off_the_command_line_loads_the_chains_system(monkeypatch):
    preset = get_preset("triple-a")
    settings = Settings(method="lagrange", t_end=0.5, samples=6)
    loaded: list[tuple] = []
    load_compiled = chain_system_module.load_compiled

    def recorded(*arguments):
        loaded.append(arguments)
        return load_compiled(*arguments)

    monkeypatch.setattr(chain_system_module, "load_compiled", recorded)
    monkeypatch.setattr(on_mechanism, "ENABLED", False)
    long_run.simulate_in_segments(preset.chain, preset.theta0, preset.omega0, settings)
    assert loaded[:1] == [("lagrange", 3, False)]


def test_warm_on_the_mechanism_engine_warms_the_routes_systems_never_the_chains_own(monkeypatch, capsys):
    """``python -m physics warm`` loads, runs and batch-steps the system a chain's run takes: on the mechanism
    engine the chain written as a mechanism (its coordinates in the tree's order, its parameter vector)."""
    from physics.cli import main  # noqa: PLC0415  (the command line: only this test needs it)

    def refused(*_arguments, **_keywords):
        raise AssertionError("the chain's own generated system was loaded by warm on the mechanism engine")

    monkeypatch.setattr(chain_system_module, "load_compiled", refused)
    # the command's own module must not hold the chain's loader either (it did before warm took chain_system)
    monkeypatch.setattr(sys.modules[main.__module__], "load_compiled", refused, raising=False)
    monkeypatch.setattr(on_mechanism, "ENABLED", True)
    assert main(["warm", "--links", "2"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split(":")[0] for line in lines] == ["newton_euler n=2 open", "lagrange n=2 open", "dae n=2 open"]
