"""What the command line loads before a chain's run starts its clock (physics/long_run.py): the system the run
will integrate (physics/simulate/chain_system.py), the chain written as a mechanism. The chain's own generated
system is never used by a run, and loading it cost a new 10-link chain's first Lagrange run a whole derivation
and compilation (BENCHMARKS.md, "A chain preset's whole process on the mechanism engine")."""

from __future__ import annotations

import importlib
import sys

import pytest

import physics
from physics import Settings, get_preset
from physics import codegen as codegen_module
from physics.codegen import cache as cache_module

from .chain_formulas import assert_run_follows_chain_formulas

long_run = importlib.import_module("physics.long_run")


def _refuse_the_chains_own_system(monkeypatch) -> None:
    def refused(*_arguments, **_keywords):
        raise AssertionError("the chain's own generated system was loaded by a run")

    for module in (cache_module, codegen_module, physics):
        monkeypatch.setattr(module, "load_compiled", refused)


@pytest.mark.parametrize("method", ["newton_euler", "lagrange", "dae"])
def test_the_command_line_never_loads_the_chains_own_system(method, monkeypatch):
    preset = get_preset("four-bar")
    settings = Settings(method=method, t_end=0.5, samples=6)
    with monkeypatch.context() as refusing:
        _refuse_the_chains_own_system(refusing)
        got = long_run.simulate_in_segments(preset.chain, preset.theta0, preset.omega0, settings)
    assert got.status == 0
    assert_run_follows_chain_formulas(preset.chain, settings, got)  # the chain's formulas: the test's oracle


def test_warm_warms_the_routes_systems_never_the_chains_own(monkeypatch, capsys):
    """``python -m physics warm`` loads, runs and batch-steps the system a chain's run takes: the chain written as
    a mechanism (its coordinates in the tree's order, its parameter vector)."""
    from physics.cli import main  # noqa: PLC0415  (the command line: only this test needs it)

    _refuse_the_chains_own_system(monkeypatch)
    # the command's own module must not hold the chain's loader either (it did before warm took chain_system)
    assert not hasattr(sys.modules[main.__module__], "load_compiled")
    assert main(["warm", "--links", "2"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split(":")[0] for line in lines] == ["newton_euler n=2 open", "lagrange n=2 open", "dae n=2 open"]
