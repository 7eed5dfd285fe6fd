"""A chain's compiled run leaves every sample's solve to whoever reads what it gives
(physics/simulate/mechanism_route.py ``SOLVE_WHEN_READ``, ``_SolvedWhenRead``; physics/codegen/mechanism_run.py
``solve_samples``): the run integrates and computes the points and energies, and the reactions, the joint
reactions, a pinned chain's tip reaction and the condition are computed when first read, in the run's own buffer.

What must hold: every field, read, has the bits of a run that solved its samples itself (first request, repeated
request, an open chain's run read straight off its buffer, a run that stopped midway, each call native or from
Python); one solve serves every such field; nothing is solved before a reader asks; a copy (pickle: a study's
worker) carries the computed arrays; and the run's one call does skip the solve (a regression that solved anyway
would lose the speed, not the numbers)."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from physics import Settings, get_preset, simulate
from physics.codegen import cache, mechanism_run
from physics.simulate import mechanism_route
from physics.simulate.trajectory import OnRequest

from .test_route_call_cache import _assert_same

METHODS = ["lagrange", "newton_euler", "dae"]
PRESETS = [("triple-c", None), ("four-bar", None), ("chain", 7)]
SOLVED = ("_reactions_value", "_joint_reactions_value", "_tip_reaction_value", "_condition_value")
FIELDS = ("t", "theta", "omega", "joints", "tip_xy", "trace_xy", "kinetic", "potential", "energy", "reactions",
          "joint_reactions", "tip_reaction", "condition", "constraint_xy", "constraint_velocity")


@pytest.fixture(autouse=True)
def _fresh_calls(monkeypatch):
    """Specialised functions made in the call (no background thread), and no call or request remembered from
    another setting of SOLVE_WHEN_READ (a call keeps the setting it was made under)."""
    monkeypatch.setattr(cache, "SPECIALISE_IN_BACKGROUND", False)
    for remembered in (mechanism_route._calls, mechanism_route._requests, mechanism_run._runs):
        remembered.clear()
    yield
    for remembered in (mechanism_route._calls, mechanism_route._requests, mechanism_run._runs):
        remembered.clear()


def _runs(chain, theta0, omega0, settings, count: int = 3) -> list:
    """``count`` runs of one request: the first made anew, the later ones the remembered request's."""
    return [simulate(chain, theta0, omega0, settings) for _ in range(count)]


def every_field(run) -> dict:
    """Every per-sample field of a chain's run (the solve's read too) and its counts, for comparing bits."""
    return {"status": run.status, "message": run.message, "n_steps": run.n_steps, "n_rhs": run.n_rhs,
            **{name: np.array(getattr(run, name)) for name in FIELDS}}


def _assert_same_fields(mine, theirs) -> None:
    _assert_same(every_field(mine), every_field(theirs))


def _request(preset: str, links: int | None, method: str, **changes):
    chosen = get_preset(preset, links)
    settings = Settings(**{"method": method, "integrator": "RK45", "rtol": 1e-6, "atol": 1e-6, "t_end": 3.0,
                           "samples": 41, **changes})
    return chosen.chain, np.asarray(chosen.theta0, float), np.asarray(chosen.omega0, float), settings


@pytest.mark.parametrize("preset, links", PRESETS)
@pytest.mark.parametrize("method", METHODS)
def test_fields_read_later_have_the_bits_of_a_run_that_solved_every_sample(monkeypatch, preset, links, method):
    chain, theta0, omega0, settings = _request(preset, links, method)
    later = _runs(chain, theta0, omega0, settings)
    deferred = {"_joint_reactions_value", "_condition_value"} | ({"_reactions_value"} if method == "dae" else set())
    deferred |= {"_tip_reaction_value"} if chain.pinned else set()
    for run in later:  # nothing solved yet: the solve's fields wait (a method's own zero-width ones do not)
        assert {name for name in SOLVED if isinstance(run.__dict__[name], OnRequest)} == deferred
    monkeypatch.setattr(mechanism_route, "SOLVE_WHEN_READ", False)
    mechanism_route._calls.clear()
    mechanism_route._requests.clear()
    solved = _runs(chain, theta0, omega0, settings)
    assert not any(isinstance(run.__dict__[name], OnRequest) for run in solved for name in SOLVED)
    for mine, theirs in zip(later, solved, strict=True):  # the new request's path, then the remembered one's
        _assert_same_fields(mine, theirs)


@pytest.mark.parametrize("method", METHODS)
def test_a_run_that_stopped_midway_reads_its_filled_rows_solved(monkeypatch, method):
    chain, theta0, omega0, settings = _request("triple-c", None, method, t_end=20.0, samples=201, max_steps=40)
    later = _runs(chain, theta0, omega0, settings, count=2)
    assert later[0].status != 0 and 0 < later[0].t.shape[0] < 201  # stopped midway, some rows filled
    monkeypatch.setattr(mechanism_route, "SOLVE_WHEN_READ", False)
    mechanism_route._calls.clear()
    mechanism_route._requests.clear()
    for mine, theirs in zip(later, _runs(chain, theta0, omega0, settings, count=2), strict=True):
        _assert_same_fields(mine, theirs)


@pytest.mark.parametrize("preset", ["triple-c", "four-bar"])
def test_each_call_from_python_solves_when_read_to_the_one_calls_bits(monkeypatch, preset):
    chain, theta0, omega0, settings = _request(preset, None, "dae")
    native = _runs(chain, theta0, omega0, settings)
    monkeypatch.setattr(mechanism_run, "ONE_CALL", False)
    mechanism_route._calls.clear()
    mechanism_route._requests.clear()
    for mine, theirs in zip(native, _runs(chain, theta0, omega0, settings), strict=True):
        _assert_same_fields(mine, theirs)


@pytest.mark.parametrize("preset", ["triple-c", "four-bar"])
def test_one_solve_serves_every_field_and_none_runs_before_a_reader_asks(monkeypatch, preset):
    chain, theta0, omega0, settings = _request(preset, None, "dae")
    calls = []
    real = mechanism_route.solve_samples

    def counting(*args):
        calls.append(args[3])  # the rows solved
        return real(*args)

    monkeypatch.setattr(mechanism_route, "solve_samples", counting)
    for run in _runs(chain, theta0, omega0, settings):
        assert calls == []
        energy = run.energy.copy()
        assert np.all(np.isfinite(run.joints)) and np.all(np.isfinite(energy))
        assert calls == []  # the points and energies need no solve
        run.reactions, run.joint_reactions, run.tip_reaction, run.condition  # noqa: B018  (read every one)
        run.joint_reactions, run.condition  # noqa: B018  (read again: kept)
        assert calls == [run.t.shape[0]]
        assert np.array_equal(run.energy, energy)  # the solve wrote nothing the run had given
        calls.clear()


def test_a_copy_carries_the_solved_fields():
    chain, theta0, omega0, settings = _request("four-bar", None, "lagrange")
    run = _runs(chain, theta0, omega0, settings, count=1)[0]
    copied = pickle.loads(pickle.dumps(run))
    assert not any(isinstance(copied.__dict__[name], OnRequest) for name in SOLVED)
    _assert_same_fields(copied, run)
    assert np.abs(copied.tip_reaction).max() > 0.0 and np.all(np.isfinite(copied.condition))


@pytest.mark.parametrize("method", METHODS)
def test_the_runs_one_call_skips_the_solve(method):
    chain, theta0, omega0, settings = _request("triple-c", None, method)
    _runs(chain, theta0, omega0, settings)
    compiled = mechanism_route.chain_route(chain, method, 0.0).compiled
    shapes = [entry for entry in mechanism_run._runs.values() if entry.compiled is compiled]
    assert shapes and all(entry.eager is not None and entry.eager.reactions == 0 for entry in shapes)
    for entry in shapes:
        for kept in entry._plans.values():
            plan = kept[3]
            assert plan[mechanism_run.PLAN_SLOTS.index("solve_samples")] == 0
            assert plan[mechanism_run.PLAN_SLOTS.index("sample")] == 0
            assert plan[mechanism_run.PLAN_SLOTS.index("matrices")] == 0
