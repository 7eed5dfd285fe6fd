"""viser behind one door (app/viser_compat.py): the fast paths are on with the installed viser, and nothing else
in app/ touches viser's private parts.

If a viser upgrade moves an internal, ``test_the_fast_paths_are_on`` fails here instead of the app quietly
sending poses the slow way; widen ``TESTED_MINORS`` only after reading the new viser's internals again.
"""

from __future__ import annotations

import logging
import re
import time
from pathlib import Path

import numpy as np
import viser

from app import logs, page, viser_compat
from conftest import wait_until

APP = Path(__file__).resolve().parents[2] / "app"
PRIVATE = re.compile(r"\._(impl|messages|queue_scene_message|websock_connection|state)\b|viser\._[a-z]")


def test_the_fast_paths_are_on():
    assert viser_compat.fallbacks() == [], viser_compat.fallbacks()
    assert viser_compat.FAST_PATH and viser_compat.VERSION_TESTED, viser.__version__


def test_control_values_are_checked_before_viser_casts_them():
    """The check of app/viser_compat.check_gui_updates sits in viser's handler list (tests/app/test_hostile_updates
    shows what it refuses); with another viser shape it would return False and log why."""
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        handlers = server.gui._websock_interface._incoming_handlers[viser_compat.GuiUpdateMessage]
        assert server.gui._handle_gui_updates in handlers
        assert viser_compat.check_gui_updates(server.gui, lambda handle, problem: None)
        assert server.gui._handle_gui_updates not in handlers and len(handlers) == 1
    finally:
        server.stop()


def test_every_node_of_a_session_moves_by_the_fast_path(connect):
    _, session = connect()
    handles = [session.scene._bars, session.scene._spheres]  # noqa: SLF001 - the scene's two batched meshes
    assert len(handles) == 2 and all(viser_compat.fast_pose_available(h) for h in handles)
    assert viser_compat.connection_open(session.target)


def test_the_fast_path_sets_props_as_the_public_setters_do(connect):
    _, session = connect()
    session.pause()
    bars = session.scene._bars  # noqa: SLF001 - the scene's batched bar mesh
    positions = np.arange(3 * len(bars.batched_positions), dtype=np.float32).reshape(-1, 3)
    wxyzs = np.tile(np.array([1.0, 0.0, 0.0, 0.0], np.float32), (len(positions), 1))
    with session.player.lock:
        viser_compat.update_node_props(bars, {"batched_positions": positions, "batched_wxyzs": wxyzs})
    assert np.array_equal(bars.batched_positions, positions) and np.array_equal(bars.batched_wxyzs, wxyzs)


def test_one_frame_is_two_messages_whatever_the_number_of_bars(lab, connect):
    """Why the parts are batched (app/scene.py): a frame costs per message, so a frame of any chain is one
    message for the bars (positions and orientations together) and one for the joints and centres of mass."""
    client, session = connect()
    session.set_mechanism("chain", links=7)
    assert session.player.wait_idle(600)
    assert wait_until(lambda: client.counts.bar_updates() >= 10, timeout=60)
    recent = list(client.counts.watched)[-5:]
    assert all(set(m["updates"]) == {"batched_positions", "batched_wxyzs"} for _, m in recent), recent
    assert session.scene._bars.batched_positions.shape == (7, 3)  # noqa: SLF001 - one instance per bar
    moved = {name for name, count in client.counts.pose_updates.items() if count >= 5}
    assert moved == {"/linkage/bars", "/linkage/spheres"}, client.counts.pose_updates


def test_a_fallback_uses_the_public_setters_and_says_so_once(connect, monkeypatch, caplog):
    _, session = connect()
    session.pause()
    bars = session.scene._bars  # noqa: SLF001 - the scene's batched bar mesh
    positions = np.zeros_like(bars.batched_positions)
    monkeypatch.setattr(viser_compat, "FAST_PATH", False)
    monkeypatch.setattr(logs, "_seen", set())
    with caplog.at_level(logging.WARNING, logger="app"):
        with session.player.lock:
            viser_compat.update_node_props(bars, {"batched_positions": positions + 1.0})
            viser_compat.update_node_props(bars, {"batched_positions": positions + 2.0})
    assert np.allclose(bars.batched_positions, 2.0)
    warnings = [r for r in caplog.records if "public setters" in r.getMessage()]
    assert len(warnings) == 1, [r.getMessage() for r in caplog.records]


def test_a_closed_connection_is_seen(lab, connect):
    client, session = connect()
    target = session.target
    client.close()
    assert wait_until(lambda: session.closed or not viser_compat.connection_open(target), timeout=10)


def test_no_private_viser_access_outside_the_door():
    offenders = []
    for path in sorted(APP.glob("*.py")):
        if path.name == "viser_compat.py":
            continue
        for number, line in enumerate(path.read_text().splitlines(), start=1):
            if PRIVATE.search(line):
                offenders.append(f"{path.name}:{number}: {line.strip()}")
    assert offenders == []


def test_no_silent_except_pass_in_the_app():
    """An error the app expects is logged once (app/logs.py) or shown as a notice, never dropped."""
    silent = []
    for path in sorted(APP.glob("*.py")):
        lines = path.read_text().splitlines()
        for number, (line, following) in enumerate(zip(lines, lines[1:]), start=1):
            if re.match(r"\s*except\b.*:\s*(#.*)?$", line) and following.strip() == "pass":
                if "KeyboardInterrupt" not in line:  # Ctrl+C ends serve_forever; that is its purpose
                    silent.append(f"{path.name}:{number}: {line.strip()}")
    assert silent == []


def test_the_page_is_visers_own_with_the_loading_screen_first_in_its_body():
    folder = page.page_folder()
    assert folder is not None
    served = (folder / "index.html").read_text(encoding="utf-8")
    original = page.viser_page().read_text(encoding="utf-8")
    body = served.index("<body>") + len("<body>")
    assert served[body:].lstrip().startswith("<style>") and '<div id="linkage-lab-loading"' in served[body:]
    head = served.index("<head>") + len("<head>")
    assert served[head:].startswith(page.POLICY_META)  # the policy first, before anything it governs
    assert served.replace("\n" + page.ADDITIONS.read_text(encoding="utf-8"), "", 1).replace(
        page.POLICY_META, "", 1) == original
    assert page.READY_ID in served  # the screen waits for the session's marker
    assert (folder.stat().st_mode & 0o077) == 0  # a private folder


def test_every_frame_is_flushed_so_no_frame_waits_for_the_next_window(connect, monkeypatch):
    """Why each frame is flushed (app/session.py ``_on_frame``): viser's sender, idle after a window, otherwise looks
    again only after up to 1/60 s, and a frame drawn meanwhile meets the next one and is coalesced away."""
    _, session = connect()
    assert session.player.wait_idle(600)
    flushes = []
    monkeypatch.setattr(session.target, "flush", lambda: flushes.append(time.perf_counter()))
    sent0 = session.frames_sent
    assert wait_until(lambda: session.frames_sent - sent0 >= 20, timeout=60)
    frames = session.frames_sent - sent0
    assert len(flushes) >= frames - 1, (len(flushes), frames)
