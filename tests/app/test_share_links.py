"""Share links: a query sets up a session through the command layer (bad values: one notice naming each, the rest
applied), and the link for the current setup gives the same setup back."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import urllib.parse

import pytest

from app import commands, share
from app.__main__ import read_setup
from app.commands import CONTROL
from app.parameters import SessionParameters
from app.server import LabServer
from app.wsclient import BackgroundClient
from conftest import wait_until
from physics import LinkageError


def _path(query: str) -> str:
    return share.SETUP_PATH + urllib.parse.quote(query.lstrip("?"), safe="")


def _connect_with(lab, query: str):
    before = set(lab.sessions)
    url = lab.url + (_path(query) if query else "")
    client = BackgroundClient(url)
    assert wait_until(lambda: set(lab.sessions) - before, timeout=60)
    (client_id,) = set(lab.sessions) - before
    session = lab.sessions[client_id]
    assert session.player.wait_idle(60)
    return client, session


def test_a_link_sets_up_a_session(lab):
    client, session = _connect_with(lab, "?preset=double&L1=1.5&theta1=60&method=dae&g=9.81&omega2=-30")
    try:
        p = session.params
        assert p.preset == "double" and p.method == "dae"
        assert p.L[0] == 1.5 and p.g == 9.81
        assert p.theta0[0] == pytest.approx(math.radians(60)) and p.omega0[1] == pytest.approx(math.radians(-30))
        assert session.notice is None
    finally:
        client.close()


def test_bad_values_in_a_link_give_one_notice_and_the_rest_is_applied(lab):
    query = "?preset=triple-a&L1=-2&m2=abc&g=2&<b>x</b>=1&theta1=1e999&links=3&I3=0.05"
    client, session = _connect_with(lab, query)
    try:
        p = session.params
        assert p.preset == "triple-a" and p.g == 2.0 and p.I[2] == 0.05
        assert p.L[0] == SessionParameters.from_preset("triple-a").L[0]
        notice = session.notice
        assert notice is not None and notice.startswith("Not applied from the link")
        for words in ("L1 (m) = -2: allowed range 0 to 1000", "m2 = 'abc'", "unknown parameter '<b>x</b>'", "theta1 = 1e999: must be a finite number",
                      "links: only the 'chain' mechanism"):
            assert words in notice, (words, notice)
        assert not session.closed and session.player.alive
    finally:
        client.close()


def test_an_unknown_preset_falls_back_to_the_servers_and_says_so(lab):
    client, session = _connect_with(lab, "?preset=hexapod&g=3")
    try:
        assert session.params.preset == lab.preset and session.params.g == 3.0
        assert "preset = 'hexapod': allowed" in session.notice
    finally:
        client.close()


def test_a_link_too_long_is_refused_whole():
    with pytest.raises(share.LinkageError, match="at most 4000"):
        share.setup_from_path(share.SETUP_PATH + "g=1&" * 2000)
    assert share.setup_from_path("/") is None and share.setup_from_path(None) is None


@pytest.mark.parametrize("preset, edits", [
    ("triple-a", {"L2": "0.7", "theta1": "45", "omega3": "12.5", "method": "dae", "integrator": "RK45"}),
    ("four-bar", {"theta1": "100", "m2": "2", "damping": "0.1"}),
    ("chain", {"links": "5", "d4": "0.2", "rtol": "1e-6", "g": "9.81"}),
])
def test_the_link_for_a_setup_gives_the_same_setup_back(preset, edits):
    params = SessionParameters.from_preset(preset, links=int(edits.pop("links")) if "links" in edits else None)
    for name, text in edits.items():
        params = commands.apply(params, name, text, CONTROL).params
    query = share.link_query(params)
    pairs = share.setup_from_path(share.SETUP_PATH + urllib.parse.quote(query[1:], safe=""))
    preset_back, links_back, refused = share.start_of(pairs, "single", None)
    rebuilt = SessionParameters.from_preset(preset_back, links=links_back)
    errors = share.apply_setup(pairs, lambda name, text: None)
    assert refused == [] and errors == []
    for name, text in pairs:
        if name not in share.FIRST:
            rebuilt = commands.apply(rebuilt, name, text, CONTROL).params
    assert rebuilt.preset == params.preset and rebuilt.n == params.n and rebuilt.method == params.method
    assert rebuilt.settings == params.settings
    assert rebuilt.chain == params.chain
    assert rebuilt.theta0 == pytest.approx(params.theta0, abs=1e-11)
    assert rebuilt.omega0 == pytest.approx(params.omega0, abs=1e-11)
    assert query.startswith(f"?preset={preset}")
    assert len(pairs) <= 2 + len(edits) + 2  # only what differs from the preset (closed loops: assembled angles)


# ------------------------------------------------------------------------------------------ setup files
def test_a_saved_setup_reads_back_as_the_same_setup():
    params = SessionParameters.from_preset("double")
    for name, text in {"L1": "1.25", "theta2": "-40", "method": "lagrange", "omega1": "15"}.items():
        params = commands.apply(params, name, text, CONTROL).params
    document = share.state_document(params)
    assert json.loads(document)["values"]["L1"] == 1.25
    back = share.check_setup(share.pairs_from_state(document), "single", None)
    assert back.chain == params.chain and back.settings == params.settings
    assert back.theta0 == pytest.approx(params.theta0, abs=1e-11)
    assert back.omega0 == pytest.approx(params.omega0, abs=1e-11)


@pytest.mark.parametrize("content, words", [
    (b"{not json", "not valid JSON"),
    ("{}".encode("utf-16"), "not UTF-8"),
    (b'{"linkage_lab_setup": 2, "values": {}}', "linkage_lab_setup"),
    (b'{"linkage_lab_setup": 1, "values": {"L1": true}}', "values.L1"),
    (b'{"linkage_lab_setup": 1, "values": {"L1": [1]}}', "values.L1"),
    (b'{"linkage_lab_setup": 1, "values": {}, "extra": 1}', "extra"),
    (b"[" * 100000, "at most 65536"),
    (b"[" * 30000 + b"]" * 30000, "nested too deeply"),
])
def test_a_bad_setup_file_is_one_line_naming_what_is_wrong(content, words):
    with pytest.raises(share.LinkageError) as info:
        share.pairs_from_state(content, "setup.json")
    text = str(info.value)
    assert words in text and "\n" not in text and text.startswith("setup.json"), text


def test_the_command_line_refuses_a_bad_setup_file_with_one_line(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"linkage_lab_setup": 1, "values": {"preset": "double", "L1": -1}}')
    result = subprocess.run([sys.executable, "-m", "app", "--state", str(bad), "--port", "0"],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 2
    assert result.stderr.strip() == f"linkage-lab: error: --state {bad}: L1 (m) = -1: allowed range 0 to 1000"
    missing = subprocess.run([sys.executable, "-m", "app", "--state", str(tmp_path / "none.json")],
                             capture_output=True, text=True, timeout=120)
    assert missing.returncode == 2 and "No such file" in missing.stderr and missing.stderr.count("\n") == 1


def test_every_new_session_starts_from_the_servers_setup_and_a_link_replaces_it():
    setup = share.pairs_from_state(b'{"linkage_lab_setup": 1, "values": {"preset": "double", "g": 4.5}}')
    server = LabServer(port=0, warm=False, setup=setup)
    try:
        client, session = _connect_with(server, "")
        assert session.params.preset == "double" and session.params.g == 4.5
        other, linked = _connect_with(server, "?preset=single&g=2")
        assert linked.params.preset == "single" and linked.params.g == 2.0
        client.close()
        other.close()
    finally:
        server.stop()


def test_a_setup_file_loaded_in_a_session_and_refused_to_a_viewer(connect):
    _, session = connect()
    session.upload_setup(None, "s.json", b'{"linkage_lab_setup": 1, "values": {"preset": "four-bar", "m2": 2}}')
    assert session.params.preset == "four-bar" and session.params.m[1] == 2.0
    session.is_presenter = lambda client_id: False
    try:
        with pytest.raises(share.LinkageError, match="the presenter controls this session"):
            session.upload_setup(7, "s.json", b'{"linkage_lab_setup": 1, "values": {"g": 3}}')
    finally:
        session.is_presenter = None


def test_a_setup_file_starts_from_its_preset_not_from_edits_made_before(connect):
    """A saved setup gives what was saved: a value it leaves out is the preset's, not an edit made before loading
    it (as a general mechanism's setup does); the method chosen in the panel stays unless the file names one."""
    _, session = connect()
    session.upload_setup(None, "a.json", b'{"linkage_lab_setup": 1, "values": {"preset": "double"}}')
    preset_L1, preset_g = session.params.L[0], session.params.g
    session.set("L1", "1.7", CONTROL)
    session.set("g", "3", CONTROL)
    session.set("method", "dae", CONTROL)
    assert session.params.L[0] == 1.7 and session.params.g == 3.0
    session.upload_setup(None, "b.json", b'{"linkage_lab_setup": 1, "values": {"preset": "double", "m2": 2}}')
    assert session.params.m[1] == 2.0
    assert session.params.L[0] == preset_L1 and session.params.g == preset_g  # the edits are gone
    assert session.params.method == "dae"  # the integration choice in force stays
    session.upload_setup(None, "patch.json", b'{"linkage_lab_setup": 1, "values": {"g": 5}}')
    assert session.params.g == 5.0 and session.params.m[1] == 2.0  # no preset named: a patch on what is shown


@pytest.mark.parametrize("make, needle", [
    (lambda folder: _write(folder / "big.json", b" " * 70_000), "70000 bytes, more than the 65536 allowed"),
    (lambda folder: "/dev/zero", "is a device, not a regular file"),
    (lambda folder: _fifo(folder / "pipe.json"), "is a pipe (FIFO), not a regular file"),
])
def test_a_state_file_is_read_with_a_limit_and_never_blocks(tmp_path, make, needle):
    """``--state FILE``: a 70 KB file was reported as "65537 bytes" (what was read, not its size), and /dev/zero
    or a FIFO would be read forever or block."""
    with pytest.raises(LinkageError) as error:
        read_setup(str(make(tmp_path)), "triple-a", None)
    assert needle in str(error.value)


def _write(path, data: bytes):
    path.write_bytes(data)
    return path


def _fifo(path):
    os.mkfifo(path)
    return path
