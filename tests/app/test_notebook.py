"""``app.show(run, chain)`` and ``app.show(run, mechanism)``: a run as a 3D replay in a notebook (inline) or a browser page, headless here: the page
holds the run itself (its frames, their timing, the joints' positions of its samples), whatever displays it."""

from __future__ import annotations

import base64
import logging
import re
import sys
import types
from pathlib import Path

import msgspec
import numpy as np
import pytest
import zstandard

import app
import physics
from app.mechanism_runs import centres_at, drawing, points_at
from app.notebook import replay_page
from physics import LinkageError
from physics.mechanism import MECHANISM_PRESETS
from physics.mechanism.simulate import simulate_mechanism


@pytest.fixture(scope="module")
def triple():
    preset = physics.get_preset("triple-a")
    run = physics.simulate(preset.chain, preset.theta0, preset.omega0, physics.Settings(t_end=2.0, samples=41))
    assert run.success
    return run, preset.chain


def recording(page: str) -> tuple[dict, list[bytes]]:
    """The recording a replay page carries: viser's msgpack payload and its binary buffers."""
    match = re.search(r'window\.__VISER_EMBED_DATA__="([^"]+)"', page)
    assert match, "the page carries no recorded scene"
    data = base64.b64decode(match.group(1))
    inner = zstandard.ZstdDecompressor().decompress(data[8:], max_output_size=int.from_bytes(data[:8], "little"))
    length = int.from_bytes(inner[:8], "little")
    payload = msgspec.msgpack.decode(inner[8 : 8 + length])
    buffers, offset = [], 8 + length
    for size in payload["binaryBufferLengths"]:
        offset += (8 - offset % 8) % 8
        buffers.append(inner[offset : offset + size])
        offset += size
    return payload, buffers


def sphere_frames(payload: dict, buffers: list[bytes]) -> list[tuple[float, np.ndarray]]:
    """(time, positions) of every update of the joints' and centres' batched spheres, in recording order."""
    frames = []
    for when, message in payload["messages"]:
        updates = message.get("updates", {}) if isinstance(message, dict) else {}
        if message.get("name", "").endswith("/spheres") and "batched_positions" in updates:
            reference = updates["batched_positions"]
            values = np.frombuffer(buffers[reference["__binary_index"]], dtype=reference["dtype"])
            frames.append((when, values.reshape(-1, 3).astype(float)))
    return frames


def test_the_page_holds_every_sample_of_the_run_at_its_own_pace(triple):
    run, chain = triple
    payload, buffers = recording(replay_page(run, chain))
    assert payload["durationSeconds"] == pytest.approx(run.t[-1] - run.t[0] + (run.t[1] - run.t[0]), rel=1e-6)
    frames = sphere_frames(payload, buffers)
    assert len(frames) >= len(run.t) - 1  # a frame whose spheres did not move sends nothing
    # the chain is drawn as the mechanism it is: its spheres are the drawn points, then the centres of mass
    drawn = frames[-1][1][:, [0, 2]]  # world (x, 0, y), float32 on the wire
    com = run.joints[-1][:-1] + (chain.array("d") / chain.array("L"))[:, None] * np.diff(run.joints[-1], axis=0)
    for where in [*run.joints[-1], *com]:
        assert np.min(np.linalg.norm(drawn - where, axis=1)) < 1e-5, (where, drawn)
    assert len(drawn) >= len(run.joints[-1]) + chain.n
    times = [when for when, _ in frames]
    # one frame per sample, each a sample's time after the one before (the first pose is drawn as the scene is
    # built, so its spheres may send no update of their own)
    np.testing.assert_allclose(np.diff(times), run.t[1] - run.t[0], rtol=1e-6)
    assert times[-1] - times[0] >= run.t[-2] - run.t[0] - 1e-9


def test_the_page_names_the_run():
    preset = physics.get_preset("triple-a")
    run = physics.simulate(preset.chain, preset.theta0, preset.omega0,
                           physics.Settings(t_end=0.5, samples=11, method="dae"))
    page = replay_page(run, preset.chain, title="my pendulum")
    assert "my pendulum" in msgspec.json.encode(recording(page)[0]["messages"]).decode()


def test_a_run_of_another_chain_is_refused_in_one_line(triple):
    run, _ = triple
    with pytest.raises(LinkageError, match="chain: the run has 3 bars, the chain 2"):
        replay_page(run, physics.get_preset("chain", links=2).chain)
    with pytest.raises(LinkageError, match="run: a physics.Trajectory"):
        replay_page({"t": run.t}, physics.get_preset("triple-a").chain)


def test_show_in_a_notebook_displays_the_page_inline(triple, monkeypatch):
    run, chain = triple
    shown = []
    ipython = types.ModuleType("IPython")
    core = types.ModuleType("IPython.core")
    getipython = types.ModuleType("IPython.core.getipython")
    getipython.get_ipython = lambda: object()  # a running kernel
    display = types.ModuleType("IPython.display")
    display.HTML = lambda text: ("HTML", text)
    display.display = shown.append
    for name, module in {"IPython": ipython, "IPython.core": core, "IPython.core.getipython": getipython,
                         "IPython.display": display}.items():
        monkeypatch.setitem(sys.modules, name, module)
    opened = []
    monkeypatch.setattr("webbrowser.open", opened.append)
    assert app.show(run, chain) is None
    assert not opened
    ((kind, frame),) = shown
    assert kind == "HTML" and frame.startswith("<iframe srcdoc=") and "__VISER_EMBED_DATA__" in frame


def test_show_in_a_script_opens_the_page_in_a_browser(triple, monkeypatch, tmp_path):
    run, chain = triple
    monkeypatch.setitem(sys.modules, "IPython", None)  # not installed: the import fails
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    opened = []
    monkeypatch.setattr("webbrowser.open", opened.append)
    path = app.show(run, chain)
    assert opened == [f"file://{path}"]
    payload, buffers = recording(open(path, encoding="utf-8").read())
    assert len(sphere_frames(payload, buffers)) >= len(run.t) - 1


def test_the_notebook_page_runs_as_written(monkeypatch, tmp_path, capsys):
    """docs/notebooks.md's cells, in order, in one namespace, as a script would run them (no IPython)."""
    document = Path(__file__).resolve().parents[2] / "docs" / "notebooks.md"
    cells = re.findall(r"^```python\n(.*?)^```", document.read_text(encoding="utf-8"), re.MULTILINE | re.DOTALL)
    assert len(cells) >= 3
    monkeypatch.setitem(sys.modules, "IPython", None)
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    opened = []
    monkeypatch.setattr("webbrowser.open", opened.append)
    namespace: dict = {}
    notices = logging.getLogger("physics")
    level = notices.level
    try:
        for cell in cells:
            exec(compile(cell, str(document), "exec"), namespace)  # the documentation's own example code
        assert notices.getEffectiveLevel() == logging.ERROR
    finally:
        notices.setLevel(level)
    run = namespace["run"]
    assert run.success and run.t[-1] == pytest.approx(5.0)
    assert opened == [f"file://{namespace['page']}", f"file://{namespace['mechanism_page']}"]
    printed = capsys.readouterr().out
    assert printed.startswith("Trajectory(method='lagrange'") and "energy drift over 5 s" in printed
    mechanism_run = namespace["mechanism_run"]
    assert mechanism_run.success and mechanism_run.is_mechanism and mechanism_run.t[-1] == pytest.approx(2.0)
    assert f"{mechanism_run!r}\n" in printed and "bodies=3" in printed


@pytest.fixture(scope="module")
def crank_rocker():
    mechanism = MECHANISM_PRESETS["crank-rocker"]()
    run = simulate_mechanism(mechanism, 1.0, 31)
    assert run.success and run.is_mechanism
    return run, mechanism


def test_a_mechanism_run_replays_with_every_point_of_every_body(crank_rocker):
    """``app.show(run, mechanism)``: a general mechanism's run (the same Trajectory class) is drawn as the app's
    mechanism view draws it; the last frame's spheres are every drawn point, then every centre of mass."""
    run, mechanism = crank_rocker
    payload, buffers = recording(replay_page(run, mechanism))
    assert payload["durationSeconds"] == pytest.approx(run.t[-1] - run.t[0] + (run.t[1] - run.t[0]), rel=1e-6)
    frames = sphere_frames(payload, buffers)
    assert len(frames) >= len(run.t) - 1
    draw = drawing(mechanism)
    expected = np.concatenate([points_at(draw, run.q[-1]), centres_at(run.q[-1])])
    np.testing.assert_allclose(frames[-1][1][:, [0, 2]], expected, atol=1e-5)  # world (x, 0, y), float32
    assert np.max(np.abs(frames[0][1] - frames[-1][1])) > 1e-2  # the crank turns: the frames are the run's poses


def test_a_mechanism_run_needs_its_own_mechanism(crank_rocker, triple):
    run, _ = crank_rocker
    with pytest.raises(LinkageError, match=r"mechanism: the run has 3 bodies, jansen-leg \d+"):
        replay_page(run, MECHANISM_PRESETS["jansen-leg"]())
    with pytest.raises(LinkageError, match="mechanism: the physics.mechanism.Mechanism of the run"):
        replay_page(run, triple[1])
    with pytest.raises(LinkageError, match="chain: the physics.Chain of the run"):
        replay_page(triple[0], MECHANISM_PRESETS["crank-rocker"]())


def test_show_opens_a_mechanism_run_in_a_browser(crank_rocker, monkeypatch, tmp_path):
    run, mechanism = crank_rocker
    monkeypatch.setitem(sys.modules, "IPython", None)
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    opened = []
    monkeypatch.setattr("webbrowser.open", opened.append)
    path = app.show(run, mechanism, title="my crank-rocker")
    assert opened == [f"file://{path}"]
    payload, buffers = recording(open(path, encoding="utf-8").read())
    assert "my crank-rocker" in msgspec.json.encode(payload["messages"]).decode()
    assert len(sphere_frames(payload, buffers)) >= len(run.t) - 1
