"""The chain route's one-buffer run remembers what a call needs besides the request's numbers
(physics/simulate/mechanism_route.py ``_calls``: the driver, the samples' solve, the run's shape, the plan and the
state's columns, per route, integrator, number of samples and traced point): a request that changes any number
(the chain's masses, its damping, a bar replaced, the traced point, the samples, the start, the tolerances) gives
what the path without the remembered call gives, bit for bit, and a call is remembered only once the system's
specialised functions are in place (a run takes them as soon as they are)."""

from __future__ import annotations

import numpy as np
import pytest

from physics import Settings, get_preset, simulate
from physics.codegen import cache
from physics.simulate import mechanism_route


@pytest.fixture(autouse=True)
def _specialise_in_the_call(monkeypatch):
    monkeypatch.setattr(cache, "SPECIALISE_IN_BACKGROUND", False)


def _fields(run) -> dict:
    columns = {name: np.array(value) for name, value in run.columns().items()}
    return {"status": run.status, "message": run.message, "n_steps": run.n_steps, "n_rhs": run.n_rhs,
            "t_reached": run.stats["t_reached"], **columns}


def _assert_same(mine: dict, theirs: dict) -> None:
    assert mine.keys() == theirs.keys()
    for name, value in theirs.items():
        if isinstance(value, np.ndarray):
            assert mine[name].shape == value.shape, name
            assert mine[name].tobytes() == value.tobytes(), name
        else:
            assert mine[name] == value, name


def _with(settings: Settings, changes: dict) -> Settings:
    """``settings`` with ``changes``, validated as a user's would be."""
    return Settings(**{**settings.model_dump(), **changes})


def _reference(monkeypatch, chain, theta0, omega0, settings, t_start=0.0) -> dict:
    """The same request by engine.integrate and the samples' functions (no one-buffer call, none remembered)."""
    with monkeypatch.context() as patched:
        patched.setattr(mechanism_route, "ONE_BUFFER_RUN", False)
        return _fields(simulate(chain, theta0, omega0, settings, t_start))


@pytest.mark.parametrize("preset", ["triple-a", "four-bar"])
@pytest.mark.parametrize("method", ["newton_euler", "lagrange", "dae"])
def test_a_remembered_call_never_gives_a_stale_value(monkeypatch, preset, method):
    chosen = get_preset(preset)
    chain, theta0, omega0 = chosen.chain, np.asarray(chosen.theta0, float), np.asarray(chosen.omega0, float)
    settings = Settings(method=method, integrator="RK45", rtol=1e-6, atol=1e-6, t_end=1.0, samples=21)
    for _ in range(3):  # the system's specialised functions in place, the call remembered
        simulate(chain, theta0, omega0, settings)
    assert any(call.route.chain is chain for call in mechanism_route._calls.values())
    heavier = chain.model_copy(update={"bars": [bar.model_copy(update={"m": 2.5 * bar.m}) for bar in chain.bars]})
    replaced = chain.model_copy(update={"bars": list(chain.bars)})
    replaced.bars[-1] = chain.bars[-1].model_copy(update={"I": 3.0 * chain.bars[-1].I})  # same object, a new bar
    requests = [
        (chain, settings, 0.0),
        (heavier, settings, 0.0),
        (chain, _with(settings, {"damping": 0.4}), 0.0),
        (replaced, settings, 0.0),
        (chain, _with(settings, {"trace": {"bar": 2, "along": 0.25, "across": 0.1}}), 0.0),
        (chain, _with(settings, {"samples": 34, "t_end": 1.3}), 0.0),
        (chain, _with(settings, {"rtol": 1e-9, "atol": 1e-9, "integrator": "DOP853"}), 0.0),
        (chain, _with(settings, {"max_steps": 3}), 0.0),  # stops early: fewer rows
        (chain, settings, 0.75),
        (heavier, settings, 0.0),
        (chain, settings, 0.0),
    ]
    for request_chain, request_settings, t_start in requests:
        for _ in range(2):  # the first call may remember, the second reads what was remembered
            mine = _fields(simulate(request_chain, theta0, omega0, request_settings, t_start))
            _assert_same(mine, _reference(monkeypatch, request_chain, theta0, omega0, request_settings, t_start))
    replaced.bars[-1] = chain.bars[-1]  # back to the first bar: the route (and its call) of that bar again
    _assert_same(_fields(simulate(replaced, theta0, omega0, settings)),
                 _reference(monkeypatch, chain, theta0, omega0, settings))


def test_a_call_is_remembered_only_with_the_specialised_functions(monkeypatch):
    chosen = get_preset("triple-c")
    chain = chosen.chain.model_copy()  # a chain object of its own: its route is new to this process
    theta0, omega0 = np.asarray(chosen.theta0, float), np.asarray(chosen.omega0, float)
    settings = Settings(method="lagrange", integrator="RK45", rtol=1e-6, atol=1e-6, t_end=1.0, samples=21)
    compiled = mechanism_route.chain_route(chain, "lagrange", 0.0).compiled
    with monkeypatch.context() as patched:  # no specialised driver yet: the generic one, nothing remembered
        patched.setattr(type(compiled), "specialised_driver", lambda self, method: None)
        generic = [simulate(chain, theta0, omega0, settings) for _ in range(3)]
        assert not any(call.route.chain is chain for call in mechanism_route._calls.values())
    runs = [simulate(chain, theta0, omega0, settings) for _ in range(2)]
    remembered = [call for call in mechanism_route._calls.values() if call.route.chain is chain]
    assert len(remembered) == 1
    assert remembered[0].driver is compiled.specialised_driver("RK45")
    assert remembered[0].solve is compiled.samples_solve().solve
    for run in generic[1:] + runs:
        _assert_same(_fields(run), _fields(generic[0]))


@pytest.mark.parametrize("preset", ["triple-a", "four-bar"])
@pytest.mark.parametrize("method", ["newton_euler", "lagrange", "dae"])
@pytest.mark.parametrize("extra", [{}, {"max_steps": 2}, {"integrator": "DOP853", "samples": 7},
                                   {"stabilization": "baumgarte"}, {"trace": {"bar": 2, "along": 0.3, "across": 0.2}}])
def test_the_one_native_call_is_the_calls_one_at_a_time(monkeypatch, preset, method, extra):
    """physics/codegen/mechanism_run_ir.py: the driver, the rows finite throughout, the states split, the solve, the
    kinematics, a pinned chain's matrices and the observables in one call give what the calls from Python give."""
    from physics.codegen import mechanism_run  # noqa: PLC0415

    chosen = get_preset(preset)
    settings = Settings(**{"method": method, "integrator": "RK45", "rtol": 1e-6, "atol": 1e-6, "t_end": 1.0,
                           "samples": 21, **extra})
    theta0, omega0 = np.asarray(chosen.theta0, float), np.asarray(chosen.omega0, float)
    runs = {}
    for one_call in (False, True, False, True):  # generic, then specialised functions
        monkeypatch.setattr(mechanism_run, "ONE_CALL", one_call)
        runs.setdefault(one_call, []).append(_fields(simulate(chosen.chain, theta0, omega0, settings)))
    for mine, theirs in zip(runs[True], runs[False]):
        _assert_same(mine, theirs)
    if "max_steps" in extra:  # the run stopped early: fewer rows than samples, the same count both ways
        assert runs[True][0]["t"].shape[0] < settings.samples
