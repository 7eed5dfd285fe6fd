"""A chain's route on the mechanism engine from its structure's record (physics/simulate/chain_record.py) is the
route derived from the chain written as a mechanism, bit for bit: the parameter vector, the observables plan's
arrays and the whole Trajectory, on every chain preset and method and on random chains (other numbers than the
record was written from) with damping and a traced point. A record not trusted (changed, cut short, another
structure, another version of its sources) is discarded with one line saying why and rebuilt, never a crash; and
a warm process on the route loads no module of the mechanism package."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from physics import Settings, get_preset, make_chain, simulate
from physics.cache_folder import tagged
from physics.model import TracePoint
from physics.simulate import chain_record, mechanism_route

METHODS = ("newton_euler", "lagrange", "dae")
PRESETS = ("single", "double", "triple-a", "triple-b", "triple-c", "four-bar", "change-point")
TRAJECTORY_FIELDS = ("t", "theta", "omega", "joints", "tip_xy", "trace_xy", "kinetic", "potential", "energy",
                     "condition", "reactions", "joint_reactions", "tip_reaction", "constraint_xy",
                     "constraint_velocity")


@pytest.fixture(autouse=True)
def _fresh_memory():
    """Every test starts with no route, plan or record in memory."""
    _forget()
    yield
    _forget()


def _forget() -> None:
    mechanism_route._routes.clear()
    mechanism_route._plans.clear()
    mechanism_route._columns.clear()
    chain_record.forget()


def _run(chain, theta0, omega0, settings, monkeypatch, use_records: bool):
    """The route (fresh from memory) and the run of ``settings``: derived, or from the record on disk."""
    _forget()
    monkeypatch.setattr(mechanism_route, "USE_RECORDS", use_records)
    trajectory = simulate(chain, theta0, omega0, settings)
    route = mechanism_route.chain_route(chain, settings.method, settings.damping)
    plan = mechanism_route._chain_plan(chain, settings, route)
    return route, plan, trajectory


def _assert_bit_for_bit(derived, recorded) -> None:
    (route_a, plan_a, run_a), (route_b, plan_b, run_b) = derived, recorded
    assert route_a._mechanism is not None and route_b._mechanism is None  # the record route built no mechanism
    np.testing.assert_array_equal(route_b.parameters, route_a.parameters)
    for name in ("order", "inverse", "joint_rows", "tip_rows", "mass_diagonal", "constant_force", "damping_matrix"):
        np.testing.assert_array_equal(getattr(route_b, name), getattr(route_a, name), err_msg=name)
    assert route_b.own_reactions == route_a.own_reactions
    assert route_b.compiled is route_a.compiled
    for name in ("shape", "indices", "constants"):
        np.testing.assert_array_equal(getattr(plan_b, name), getattr(plan_a, name), err_msg=name)
    assert (run_b.status, run_b.message, run_b.n_steps, run_b.n_rhs) == (run_a.status, run_a.message,
                                                                          run_a.n_steps, run_a.n_rhs)
    for name in TRAJECTORY_FIELDS:
        np.testing.assert_array_equal(getattr(run_b, name), getattr(run_a, name), err_msg=name)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("preset", PRESETS)
def test_a_presets_route_from_its_record_is_the_derived_route_bit_for_bit(preset, method, monkeypatch):
    loaded = get_preset(preset)
    settings = Settings(method=method, t_end=1.0, samples=11)
    derived = _run(loaded.chain, loaded.theta0, loaded.omega0, settings, monkeypatch, use_records=False)
    chain_record.save_record(derived[0].record)
    recorded = _run(loaded.chain, loaded.theta0, loaded.omega0, settings, monkeypatch, use_records=True)
    _assert_bit_for_bit(derived, recorded)


def _random_chain(rng, n: int):
    L = rng.uniform(0.3, 2.0, n)
    return make_chain(L, L * rng.uniform(0.1, 0.9, n), rng.uniform(0.2, 3.0, n), rng.uniform(0.01, 1.0, n),
                      g=float(rng.uniform(0.5, 10.0)))


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("n", [2, 4])
def test_a_random_chains_route_from_another_chains_record_is_its_derived_route(n, method, monkeypatch, rng):
    writer, chain = _random_chain(rng, n), _random_chain(rng, n)
    damping = float(rng.uniform(0.05, 0.8))
    _forget()
    monkeypatch.setattr(mechanism_route, "USE_RECORDS", False)
    chain_record.save_record(mechanism_route.chain_route(writer, method, damping).record)  # other numbers
    settings = Settings(method=method, t_end=1.0, samples=11, damping=damping,
                        trace=TracePoint(bar=n - 1, along=float(rng.uniform(0.0, 1.0)),
                                         across=float(rng.uniform(-0.5, 0.5))))
    theta0, omega0 = rng.uniform(-1.0, 1.0, n), rng.uniform(-1.0, 1.0, n)
    derived = _run(chain, theta0, omega0, settings, monkeypatch, use_records=False)
    recorded = _run(chain, theta0, omega0, settings, monkeypatch, use_records=True)
    _assert_bit_for_bit(derived, recorded)


def _write_then_forget(chain, method: str) -> chain_record.ChainRecord:
    route = mechanism_route.chain_route(chain, method, 0.0)
    assert chain_record.record_path(method, chain.n, chain.pinned).is_file()
    _forget()
    return route.record


def _assert_rebuilt(chain, method: str, caplog, reason: str) -> None:
    """The next route discards the record with one line naming ``reason``, derives the route and rewrites it."""
    route = mechanism_route.chain_route(chain, method, 0.0)
    assert route._mechanism is not None  # derived again
    err = "\n".join(record.getMessage() for record in caplog.records)
    assert "chain route record" in err and "discarded and rebuilt" in err and reason in err, err
    assert len(caplog.records) == 1 and "Traceback" not in err
    _forget()
    assert mechanism_route.chain_route(chain, method, 0.0)._mechanism is None  # the rewritten record is read


@pytest.mark.parametrize("change", ["flipped", "cut"])
def test_a_changed_record_is_discarded_and_rebuilt(change, caplog):
    chain = get_preset("four-bar").chain
    _write_then_forget(chain, "lagrange")
    path = chain_record.record_path("lagrange", chain.n, chain.pinned)
    data = bytearray(path.read_bytes())
    if change == "flipped":
        data[10] ^= 0x01
    else:
        del data[-20:]
    path.write_bytes(bytes(data))
    caplog.clear()
    _assert_rebuilt(chain, "lagrange", caplog, "MAC")


def test_a_record_of_another_structure_under_a_valid_mac_is_discarded_and_rebuilt(caplog):
    chain = get_preset("triple-a").chain
    record = _write_then_forget(chain, "dae")
    path = chain_record.record_path("dae", chain.n, chain.pinned)
    content = json.loads(record.to_json())
    content["order"] = [0] * chain.n  # not a permutation
    path.write_bytes(tagged(path.name, json.dumps(content).encode()))
    caplog.clear()
    _assert_rebuilt(chain, "dae", caplog, "order")
    content = json.loads(record.to_json())
    content["n"] = chain.n + 1
    path.write_bytes(tagged(path.name, json.dumps(content).encode()))
    _forget()
    caplog.clear()
    _assert_rebuilt(chain, "dae", caplog, "another structure")


def test_a_record_of_other_sources_is_replaced(monkeypatch):
    chain = get_preset("triple-a").chain
    _write_then_forget(chain, "newton_euler")
    old = chain_record.record_path("newton_euler", chain.n, chain.pinned)
    monkeypatch.setattr(chain_record, "_digest_memo", ["0" * 16])  # the sources changed
    route = mechanism_route.chain_route(chain, "newton_euler", 0.0)
    assert route._mechanism is not None  # not read from the stale record
    new = chain_record.record_path("newton_euler", chain.n, chain.pinned)
    assert new != old and new.is_file() and not old.exists()
    new.unlink()  # the shared test cache keeps no record of sources that do not exist


def test_the_lazy_geometry_is_the_chains_mechanism(monkeypatch):
    """A record route's mechanism, pieces and dynamics (built on demand) are the derived route's."""
    chain = get_preset("four-bar").chain
    monkeypatch.setattr(mechanism_route, "USE_RECORDS", False)
    derived = mechanism_route.chain_route(chain, "dae", 0.2)
    chain_record.save_record(derived.record)
    _forget()
    monkeypatch.setattr(mechanism_route, "USE_RECORDS", True)
    recorded = mechanism_route.chain_route(chain, "dae", 0.2)
    assert recorded._mechanism is None
    assert recorded.mechanism == derived.mechanism
    assert recorded.pieces.structure_key == derived.pieces.structure_key
    np.testing.assert_array_equal(recorded.pieces.parameters_at(0.0), recorded.parameters)
    np.testing.assert_array_equal(recorded.dynamics.mass_diagonal, derived.dynamics.mass_diagonal)


WARM_ROUTE = r"""
import contextlib, io, json, sys
from physics.cli import main
with contextlib.redirect_stdout(io.StringIO()):
    code = main(["simulate", "--preset", sys.argv[1], "--method", sys.argv[2], "--t-end", "0.5", "--samples", "3"])
print(json.dumps({"code": code, "modules": sorted(sys.modules)}))
"""


@pytest.mark.parametrize(("preset", "method"), [("triple-a", "lagrange"), ("four-bar", "dae"),
                                                ("four-bar", "newton_euler")])
def test_a_warm_route_process_loads_no_mechanism_module(preset, method):
    arguments = [sys.executable, "-c", WARM_ROUTE, preset, method]
    subprocess.run(arguments, capture_output=True, timeout=600, check=True)  # fills the cache
    result = subprocess.run(arguments, capture_output=True, text=True, timeout=600, check=True)
    report = json.loads(result.stdout.strip().splitlines()[-1])
    assert report["code"] == 0
    loaded = sorted(name for name in report["modules"] if name.startswith("physics.mechanism"))
    assert not loaded, loaded
    assert "physics.simulate.chain_record" in report["modules"]  # the run took the route, from its record


def test_a_record_whose_generated_system_is_gone_derives_the_route_again():
    """A record naming a generated system the cache folder does not hold (its code's digest changed, or a file
    removed): the route is derived (the system with it) and the record rewritten, never a crash."""
    chain = get_preset("triple-a").chain
    record = _write_then_forget(chain, "lagrange")
    path = chain_record.record_path("lagrange", chain.n, chain.pinned)
    content = json.loads(record.to_json())
    content["compiled_key"] = "lagrange-mechanism-absolute-0000000000000000"
    path.write_bytes(tagged(path.name, json.dumps(content).encode()))
    route = mechanism_route.chain_route(chain, "lagrange", 0.0)
    assert route._mechanism is not None and route.record.compiled_key == record.compiled_key
    _forget()
    assert chain_record.load_record("lagrange", chain.n, chain.pinned).compiled_key == record.compiled_key
