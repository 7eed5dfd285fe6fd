"""A chain hosted as a mechanism hands out the chain's own downloads and snapshot (app/chain_contract.py).

Each case runs one chain twice over 2 s (DOP853, rtol = atol = 1e-10): the chain route (``physics.simulate``,
its Trajectory stored as app/runs.py's ``chunk_dict`` stores it) and the same chain as a mechanism
(``chain_mechanism`` through ``MechanismSpec.simulate``/``chunk``, stored in its own ring as the player stores a
chunk). The mechanism's stored samples, mapped by ``chain_history``, must give the chain route's export columns:
the same names in the same order, the same CSV header byte for byte, the same file names, and the same numbers
to the runs' agreement (angles 1e-7, reactions 1e-6 of the column's size).
"""

from __future__ import annotations

import functools
import io
import json
import math
import threading
from types import SimpleNamespace

import numpy as np
import pytest

import physics
from app import chain_contract, export, readout
from app.buffers import TrajectoryRing
from app.mechanism_runs import MechanismSettings, MechanismSpec
from app.overlays import energy_scale, relative_drift
from app.parameters import METHOD_LABELS, SessionParameters, settings_data
from app.player import SAMPLE_DT
from app.runs import Run, chunk_dict, com_ratio
from physics import Settings
from physics.mechanism.chains import chain_mechanism, chain_state
from physics.model import validated

T_END = 2.0
SAMPLES = int(round(T_END / SAMPLE_DT)) + 1  # the player's sample grid
RTOL = 1e-10
# (preset, method, damping, sketch): "start" draws the chain at its start angles, "down" hanging straight down
CASES = [(preset, method, 0.0, "start") for preset in ("triple-a", "double", "four-bar")
         for method in ("dae", "lagrange", "newton_euler")]
CASES += [
    ("four-bar", "reduced", 0.0, "start"),  # the one chain of mobility 1
    ("triple-a", "dae", 0.05, "down"),  # damped pins, and bars turned from a sketch that is not the start
    ("four-bar", "lagrange", 0.05, "start"),
]


@functools.lru_cache(maxsize=None)
def routes(preset: str, method: str, damping: float = 0.0, sketch_at: str = "start"):
    """``(params, sketch, chain history, mechanism spec, mechanism ring)`` of one case (both routes run once)."""
    params = SessionParameters.from_preset(preset, method=method)
    settings = validated(Settings, **{**settings_data(params.settings), "rtol": RTOL, "atol": RTOL,
                                      "integrator": "DOP853", "t_end": T_END, "samples": SAMPLES,
                                      "damping": damping})
    params = params.replaced(settings=settings)
    trajectory = physics.simulate(params.chain, params.theta0, params.omega0, settings)
    assert trajectory.status == 0, trajectory.message
    chain_ring = TrajectoryRing(params.n, params.pinned, SAMPLES, SAMPLE_DT)
    chain_ring.append(chunk_dict(trajectory, params.n, params.pinned))
    chain = chain_ring.window(0, len(chain_ring) - 1)

    # the chain drawn at its start, as a hosting session draws it, or hanging down (an open chain only)
    sketch = params.theta0 if sketch_at == "start" else np.zeros(params.n)
    mechanism = chain_mechanism(params.chain, sketch, params.damping)
    spec = MechanismSpec("main", mechanism, MechanismSettings(method=method, rtol=RTOL, integrator="DOP853",
                                                              t_end=T_END, samples=SAMPLES))
    q0, qdot0 = chain_state(params.chain, sketch, params.theta0, params.omega0)
    chunk = spec.simulate(mechanism, q0, qdot0, spec.settings)
    assert chunk.status == 0, chunk.message
    ring = spec.new_ring(SAMPLES, SAMPLE_DT)
    ring.append(spec.chunk(chunk))
    return params, sketch, chain, spec, ring


def mapped(preset: str, method: str, damping: float = 0.0, sketch_at: str = "start") -> dict[str, np.ndarray]:
    params, sketch, _, spec, ring = routes(preset, method, damping, sketch_at)
    return chain_contract.chain_history(ring.window(0, len(ring) - 1), params, sketch, spec.row_names)


def tolerance(name: str, chain_column: np.ndarray, params: SessionParameters) -> float:
    """How far the two routes' column ``name`` may be apart; every export column must be named here."""
    if name == "t":
        return 0.0
    if name.startswith(("theta", "omega")):
        return 1e-7
    if name.startswith(("tip_", "trace_")):
        return 1e-7 * max(1.0, float(np.sum(params.L)))
    if name in ("kinetic", "potential", "energy"):
        return 1e-7 * max(1.0, float(np.sum(params.m) * params.g * np.sum(params.L)))
    if name.startswith("R"):  # R0x .. R(n-1)y, RHx, RHy: relative to the column's size
        return 1e-6 * max(1.0, float(np.max(np.abs(chain_column))))
    if name.startswith("constraint_"):  # the loop's gap: held by both routes far below the positions' tolerance
        return 1e-9
    raise AssertionError(f"export column {name!r} has no tolerance in this test: classify it")


@pytest.mark.parametrize("preset,method,damping,sketch_at", CASES)
def test_every_export_column_agrees_with_the_chain_route(preset, method, damping, sketch_at):
    params, sketch, chain, _, _ = routes(preset, method, damping, sketch_at)
    assert params.damping == damping and (sketch_at == "start") == bool(np.all(sketch == params.theta0))
    ours = export.columns(mapped(preset, method, damping, sketch_at), params.method, params.pinned)
    theirs = export.columns(chain, params.method, params.pinned)
    assert list(ours) == list(theirs)
    assert len(theirs["t"]) == SAMPLES
    for name, column in theirs.items():
        gap = float(np.max(np.abs(ours[name] - column)))
        assert gap <= tolerance(name, column, params), f"{preset} {method}: column {name} differs by {gap:.3g}"
    if params.pinned:  # the reactions are of the right size, not two zeros agreeing
        assert float(np.max(np.abs(theirs["RHx"]))) > 1e-3
    if damping > 0:  # the pins' dampers take energy out of both runs alike
        assert theirs["energy"][-1] < theirs["energy"][0] - 1e-3


def player_of(runs: list[Run], display_time: float) -> SimpleNamespace:
    """The members of app/player.py's Player that app/readout.py reads."""
    return SimpleNamespace(lock=threading.Lock(), runs=runs, display_time=display_time, playing=False, speed=1.0)


@pytest.mark.parametrize("preset,method", [("triple-a", "dae"), ("four-bar", "lagrange")])
def test_downloads_are_the_chain_sessions_files(preset, method):
    params, sketch, chain, spec, ring = routes(preset, method)
    shown = 1.5  # the downloads stop at the displayed time
    player = player_of([Run(spec=spec, ring=ring, com_ratio=np.zeros(0))], shown)
    upto = int(np.searchsorted(chain["t"], shown + 1e-9))
    chain_upto = {name: values[:upto] for name, values in chain.items()}
    label = chain_contract.run_label(params)
    for kind in ("csv", "json", "setup"):
        name, ours = chain_contract.download_file(player, "main", params, sketch, spec.row_names, kind)
        their_name, theirs = readout.run_download(params, kind, lambda: chain_upto, label)
        assert name == their_name
        if kind == "setup":
            assert ours == theirs
    # the HTML replay: the chain's own replay of the mapped history (its numbers differ in the last digits)
    name, page = chain_contract.download_file(player, "main", params, sketch, spec.row_names, "html")
    assert name == readout.run_download(params, "html", lambda: chain_upto, label)[0]
    assert page.lstrip().lower().startswith(b"<!doctype html") and len(page) > 10_000
    name, csv = chain_contract.download_file(player, "main", params, sketch, spec.row_names, "csv")
    their_csv = export.to_csv(chain_upto, params)
    assert csv.split(b"\n", 1)[0] == their_csv.split(b"\n", 1)[0]
    ours_table = np.loadtxt(io.BytesIO(csv), delimiter=",", skiprows=1)
    theirs_table = np.loadtxt(io.BytesIO(their_csv), delimiter=",", skiprows=1)
    assert ours_table.shape == theirs_table.shape == (upto, len(csv.split(b"\n", 1)[0].split(b",")))
    ours_json = json.loads(chain_contract.download_file(player, "main", params, sketch, spec.row_names, "json")[1])
    theirs_json = json.loads(export.to_json(chain_upto, params, label))
    assert list(ours_json) == list(theirs_json)
    assert list(ours_json["columns"]) == list(theirs_json["columns"])
    assert {k: v for k, v in ours_json.items() if k != "columns"} == {k: v for k, v in theirs_json.items()
                                                                     if k != "columns"}


def test_run_label_is_the_chain_sessions():
    """The JSON download's ``description``, as docs/app.md words it: preset, bars, method as the menu names it,
    integrator."""
    params = SessionParameters.from_preset("four-bar", method="dae")
    assert chain_contract.run_label(params) == f"four-bar (3 bars), {METHOD_LABELS['dae']}, {params.integrator}"


def chain_energy_values(run, index: int, reference: float) -> dict:
    """docs/app.md's ``energy`` keys read straight from the chain route's own ring (physics.simulate's samples,
    app/buffers.py's fields): the reference the hosted chain's mapping is checked against."""
    chain = run.spec.chain
    energy = float(run.ring.get("energy", index))
    scale = energy_scale(chain.array("m"), chain.array("L"), chain.g)
    out = {"kinetic": float(run.ring.get("kinetic", index)), "potential": float(run.ring.get("potential", index)),
           "total": energy, "reference": reference,
           "relative_drift": float(relative_drift(np.array([energy]), reference, scale)[0])}
    if chain.pinned:
        cxy = run.ring.get("constraint_xy", index)
        out["constraint_error"] = float(math.hypot(cxy[0], cxy[1]))
    return out


def assert_same_document(ours, theirs, where: str = "snapshot") -> None:
    """Same keys in the same order, same texts and flags, numbers within 1e-7."""
    if isinstance(theirs, dict):
        assert isinstance(ours, dict) and list(ours) == list(theirs), f"{where}: keys {list(ours)} != {list(theirs)}"
        for key in theirs:
            assert_same_document(ours[key], theirs[key], f"{where}.{key}")
    elif isinstance(theirs, list):
        assert isinstance(ours, list) and len(ours) == len(theirs), where
        for k, (a, b) in enumerate(zip(ours, theirs)):
            assert_same_document(a, b, f"{where}[{k}]")
    elif isinstance(theirs, float) and not isinstance(theirs, bool):
        assert isinstance(ours, float) and abs(ours - theirs) <= 1e-7, f"{where}: {ours} != {theirs}"
    else:
        assert ours == theirs, f"{where}: {ours!r} != {theirs!r}"


@pytest.mark.parametrize("preset,method", [("double", "lagrange"), ("four-bar", "dae")])
def test_snapshot_is_the_chain_sessions(preset, method):
    params, sketch, chain, spec, ring = routes(preset, method)
    shown = 1.25
    chain_spec = SimpleNamespace(label="main", settings=SimpleNamespace(method=method), chain=params.chain)
    chain_ring = TrajectoryRing(params.n, params.pinned, SAMPLES, SAMPLE_DT)
    chain_ring.append(chain)
    chain_run = Run(spec=chain_spec, ring=chain_ring, com_ratio=com_ratio(params.chain))  # type: ignore[arg-type]
    index = chain_ring.index_at(shown)
    reference = float(chain_ring.get("energy", 0))
    scene = {"root": "/linkage", "nodes": {"/linkage/bar_1": {"visible": True}}}
    common = {"session_id": "s1", "shared": False, "params": params, "compare": False, "notice": None,
              "frames_sent": lambda: 7, "scene": lambda: scene}
    theirs = readout.snapshot_document(player=player_of([chain_run], shown), sample_of=readout.ring_sample,
                                       energy=lambda runs: chain_energy_values(runs["main"], index, reference),
                                       **common)
    ours = chain_contract.snapshot(theta_sketch=sketch, energy_reference=None,
                                   player=player_of([Run(spec=spec, ring=ring, com_ratio=np.zeros(0))], shown),
                                   **common)
    assert_same_document(ours, theirs)
    assert ours["energy"]["kinetic"] > 1e-3  # the sample shown is a moving one, not a start at rest
    assert ("constraint_error" in ours["energy"]) == params.pinned


def test_joints_are_the_bodies_drawn_points():
    """The chain's joints (reached from O along the bars) are the points the mechanism's ring draws, to the
    pins' residual: O is bar1's proximal point, each joint bar k's distal one."""
    params, sketch, _, spec, ring = routes("four-bar", "dae")
    stored = ring.window(0, len(ring) - 1)
    joints = mapped("four-bar", "dae")["joints"]
    labels = spec.draw.labels
    drawn = [labels.index("bar1.P")] + [labels.index(f"bar{k}.D") for k in range(1, params.n + 1)]
    assert float(np.max(np.abs(joints - stored["joints"][:, drawn, :]))) < 1e-8


def test_a_run_of_another_chain_is_refused_by_its_pin():
    params, sketch, _, _, ring = routes("four-bar", "dae")
    _, _, _, open_spec, _ = routes("triple-a", "dae")  # the same three bars, no pin H
    with pytest.raises(ValueError, match="pin H has 0 rows"):
        chain_contract.chain_history(ring.window(0, 3), params, sketch, open_spec.row_names)
    with pytest.raises(ValueError, match="theta_sketch: expected 3 angles"):
        chain_contract.chain_history(ring.window(0, 3), params, sketch[:2], ring_names(params))


def ring_names(params: SessionParameters) -> tuple[str, ...]:
    return tuple(f"{pin}: {axis} gap" for pin in chain_contract.pin_names(params.n, params.pinned) for axis in "xy")
