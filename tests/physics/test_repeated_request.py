"""A request repeated (the same chain object, the same Settings object, the same t_start; physics/simulate/
mechanism_route.py ``_Request``): its run is prepared once (sample times, parameters, the native call's numbers) and
an open chain's Trajectory is read straight off the run's buffer. Every run it gives must be the run the path
without any remembered request gives, bit for bit, whatever changed since (the start, the bars in place, t_start
and its sign, another Settings object), and no run may share memory with the caller's arrays or another run."""

from __future__ import annotations

import numpy as np
import pytest

from physics import Settings, get_preset, simulate
from physics.codegen import cache
from physics.simulate import mechanism_route

from .test_route_call_cache import _assert_same  # the same byte-for-byte comparison


@pytest.fixture(autouse=True)
def _specialise_in_the_call(monkeypatch):
    monkeypatch.setattr(cache, "SPECIALISE_IN_BACKGROUND", False)


def _fields(run) -> dict:
    columns = {name: np.array(value) for name, value in run.columns().items()}
    extra = {"joint_reactions": np.array(run.joint_reactions), "joints": np.array(run.joints),
             "condition": np.array(run.condition), "trace_xy": np.array(run.trace_xy)}
    return {"status": run.status, "message": run.message, "n_steps": run.n_steps, "n_rhs": run.n_rhs,
            "t_reached": run.stats["t_reached"], **columns, **extra}


def _reference(monkeypatch, chain, theta0, omega0, settings, t_start=0.0) -> dict:
    """The same request by engine.integrate and the samples' functions (nothing remembered is used), read with
    this file's :func:`_fields` (more fields than test_route_call_cache's)."""
    with monkeypatch.context() as patched:
        patched.setattr(mechanism_route, "ONE_BUFFER_RUN", False)
        return _fields(simulate(chain, theta0, omega0, settings, t_start))


def _request_of(chain, settings):
    request = mechanism_route._requests.get((id(chain), id(settings)))
    return request if request is not None and request.chain is chain and request.settings is settings else None


@pytest.mark.parametrize("preset", ["triple-c", "four-bar"])
@pytest.mark.parametrize("method", ["newton_euler", "lagrange", "dae"])
def test_a_repeated_request_from_many_starts_gives_the_runs_of_the_plain_path(monkeypatch, preset, method):
    chosen = get_preset(preset)
    chain = chosen.chain.model_copy()  # its own object: no request of another test is remembered for it
    theta0, omega0 = np.asarray(chosen.theta0, float), np.asarray(chosen.omega0, float)
    settings = Settings(method=method, integrator="RK45", rtol=1e-6, atol=1e-6, t_end=2.0, samples=41)
    for _ in range(3):
        simulate(chain, theta0, omega0, settings)
    request = _request_of(chain, settings)
    assert request is not None, "the third run of one request is remembered"
    assert (request.open_chain is not None) == (not chain.pinned)
    generator = np.random.default_rng(7)
    for _ in range(4):
        if chain.pinned:  # a closed loop's start must close it: other speeds along the loop's one freedom
            omega = omega0 * generator.uniform(0.5, 2.0)
            theta = theta0
        else:
            theta = theta0 + generator.normal(scale=0.3, size=chain.n)
            omega = generator.normal(size=chain.n)
        mine = _fields(simulate(chain, theta, omega, settings))
        assert _request_of(chain, settings) is request, "the same request again: nothing made anew"
        _assert_same(mine, _reference(monkeypatch, chain, theta, omega, settings))


def test_a_request_is_not_reused_for_other_bars_another_start_time_or_another_settings_object(monkeypatch):
    chosen = get_preset("triple-c")
    chain = chosen.chain.model_copy(update={"bars": list(chosen.chain.bars)})
    theta0, omega0 = np.asarray(chosen.theta0, float), np.asarray(chosen.omega0, float)
    settings = Settings(method="lagrange", integrator="RK45", rtol=1e-6, atol=1e-6, t_end=1.0, samples=21)
    for _ in range(3):
        simulate(chain, theta0, omega0, settings)
    assert _request_of(chain, settings) is not None
    heavier = chain.bars[1].model_copy(update={"m": 3.0 * chain.bars[1].m})
    chain.bars[1] = heavier  # the same chain object, a bar replaced in place
    _assert_same(_fields(simulate(chain, theta0, omega0, settings)),
                 _reference(monkeypatch, chain, theta0, omega0, settings))
    for t_start in (0.5, -0.0, 0.0):  # -0.0 is its own sample time: t[0] keeps the sign
        for _ in range(2):
            _assert_same(_fields(simulate(chain, theta0, omega0, settings, t_start)),
                         _reference(monkeypatch, chain, theta0, omega0, settings, t_start))
    equal = Settings(**settings.model_dump())  # equal fields, another object: a request of its own
    _assert_same(_fields(simulate(chain, theta0, omega0, equal)), _fields(simulate(chain, theta0, omega0, settings)))
    damped = Settings(**{**settings.model_dump(), "damping": 0.3})
    for _ in range(3):
        _assert_same(_fields(simulate(chain, theta0, omega0, damped)),
                     _reference(monkeypatch, chain, theta0, omega0, damped))


def test_a_repeated_request_that_stops_early_or_fails_reports_as_the_plain_path(monkeypatch):
    chosen = get_preset("triple-c")
    chain = chosen.chain.model_copy()
    theta0, omega0 = np.asarray(chosen.theta0, float), np.asarray(chosen.omega0, float)
    for changes in ({"max_steps": 3}, {"samples": 2}):
        settings = Settings(**{"method": "dae", "integrator": "RK45", "rtol": 1e-6, "atol": 1e-6, "t_end": 1.0,
                               "samples": 21, **changes})
        runs = [_fields(simulate(chain, theta0, omega0, settings)) for _ in range(4)]
        assert _request_of(chain, settings) is not None
        reference = _reference(monkeypatch, chain, theta0, omega0, settings)
        for run in runs:
            _assert_same(run, reference)
        if "max_steps" in changes:
            assert reference["status"] != 0 and reference["t"].shape[0] < 21, "3 steps stop the run before its end"


def test_runs_of_a_repeated_request_share_no_memory_with_the_caller_or_each_other():
    chosen = get_preset("triple-c")
    chain = chosen.chain.model_copy()
    theta0, omega0 = np.asarray(chosen.theta0, float), np.asarray(chosen.omega0, float)
    settings = Settings(method="lagrange", integrator="RK45", rtol=1e-6, atol=1e-6, t_end=1.0, samples=21)
    for _ in range(3):
        simulate(chain, theta0, omega0, settings)
    start = np.stack([theta0, omega0], axis=1)  # strided columns as the start: read, never kept
    first = simulate(chain, start[:, 0], start[:, 1], settings)
    kept = {name: np.array(getattr(first, name)) for name in ("t", "theta", "omega", "joints", "energy")}
    start[:] = 0.0
    second = simulate(chain, theta0, omega0, settings)
    for name in ("t", "theta", "omega", "joints", "energy"):
        array = getattr(second, name)
        assert not np.shares_memory(array, getattr(first, name)), name
        assert not np.shares_memory(array, theta0) and not np.shares_memory(array, omega0), name
        array[...] = np.nan  # a reader writing into its run changes no other run
        assert np.array_equal(getattr(first, name), kept[name]), name
    third = simulate(chain, theta0, omega0, settings)
    for name, value in kept.items():
        assert np.array_equal(getattr(third, name), value), name
