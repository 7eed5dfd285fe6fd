"""A general mechanism's setup saved and loaded like a chain's (issue 24): the Export tab's "Save this setup
(JSON)" and "Load a setup (JSON)", ``python -m app --state FILE``, switching kinds by a setup, the presenter lock,
and bad files refused in one line."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import time

import pytest

from app import share, viser_compat
from app.__main__ import start_from_state
from app.mechanism_setups import check_mechanism_setup
from app.server import LabServer
from app.session import Session
from app.wsclient import BackgroundClient, Counts, send_messages, upload_messages
from conftest import lab_of, wait_until
from physics import LinkageError
from physics.mechanism import MECHANISM_PRESETS

slider_lab = lab_of("slider-crank")

EDITS = [  # every kind of value a slider-crank's panel has, in the panel's units, none the preset's
    ("method", "lagrange"), ("stabilization", "baumgarte"), ("baumgarte_alpha", "7.5"), ("rtol", "1e-9"),
    ("trace", "rod.A"), ("mass:crank", "0.4321"), ("inertia:rod", "0.00123"), ("size:rod", "0.25"),
    ("g", "5.5"), ("angle0:crank", "40"), ("omega0:crank", "90"),
]


# Which of the loop's joints keeps the largest gap when no pose closes it is not the physics' to say: least squares
# leaves two nearly equal gaps, and the machine's LAPACK decides which is larger (B on one machine, O4 on another).
# The refusal must name a joint of that loop.
OPEN_LOOP = re.compile(r"joint '(O2|A|B|O4)': the mechanism cannot be assembled")


def _open_rocker() -> dict:
    """A crank-rocker whose coupler is ten times too long: valid to the models, but no pose closes its loop."""
    description = MECHANISM_PRESETS["crank-rocker"]().model_dump(mode="json")
    coupler = next(body for body in description["bodies"] if body["name"] == "coupler")
    coupler["points"]["B"] = [10 * v for v in coupler["points"]["B"]]
    return description


def _setup(values: dict, mechanism: dict | None = None) -> bytes:
    document: dict = {"linkage_lab_setup": 1, "values": values}
    if mechanism is not None:
        document["mechanism"] = mechanism
    return json.dumps(document).encode()


def _state(session: Session) -> dict:
    """What a setup must restore: the mechanism, its numbers, the run's settings and the start."""
    snap = session.snapshot()
    return {"mechanism": session.label, "values": snap["values"], "start": snap["start"],
            "settings": session.settings.model_dump(), "description": session.mechanism.model_dump()}


def _same(got, expected, where: str = "") -> None:
    """Equal, numbers to 1e-9 (a setup file holds 12 significant digits)."""
    if isinstance(expected, dict):
        assert isinstance(got, dict) and got.keys() == expected.keys(), (where, got, expected)
        for key in expected:
            _same(got[key], expected[key], f"{where}.{key}")
    elif isinstance(expected, (list, tuple)):
        assert isinstance(got, (list, tuple)) and len(got) == len(expected), (where, got, expected)
        for k, (a, b) in enumerate(zip(got, expected)):
            _same(a, b, f"{where}[{k}]")
    elif isinstance(expected, float) and not isinstance(expected, bool):
        assert got == pytest.approx(expected, rel=1e-9, abs=1e-12), (where, got, expected)
    else:
        assert got == expected, (where, got, expected)


def _edited(session: Session) -> None:
    for name, text in EDITS:
        session.set_link_value(name, text)
    snap = session.snapshot()
    assert snap["values"]["mass:crank"] == 0.4321 and snap["start"]["angle0:crank"] == pytest.approx(40.0)


def _moving(session, seconds: float = 0.2) -> bool:
    """The run goes on (a first run of a structure compiles it first: on a loaded machine, a minute or more)."""
    first = session.player.display_time
    return wait_until(lambda: session.player.display_time > first + seconds, timeout=240)


def _showing(server, client_id: int, before, shows):
    """The session the browser ``client_id`` shows once ``shows(session)`` holds: ``before`` itself (the one
    session hosts a chain and a mechanism alike) or the one that replaced it, ``before`` then closed (a browser
    has one session at a time)."""
    assert wait_until(lambda: isinstance(server.sessions.get(client_id), Session)
                      and shows(server.sessions[client_id]), timeout=60)
    session = server.sessions[client_id]
    assert not session.closed and (session is before or before.closed)
    assert session.player.wait_idle(60)
    return session


# ------------------------------------------------------------------------------------------ round trips
def test_a_saved_setup_loads_back_into_another_session(slider_lab, connect):
    _, first = connect(slider_lab)
    _edited(first)
    name, content = first.download_file("setup")
    assert name == "linkage-slider-crank-setup.json"
    document = json.loads(content)
    assert document["linkage_lab_setup"] == 1 and "mechanism" not in document
    values = document["values"]
    assert values["preset"] == "slider-crank" and values["mass:crank"] == 0.4321 and values["method"] == "lagrange"
    assert values["omega0:crank"] == pytest.approx(90.0) and values["trace"] == "rod.A"
    _, second = connect(slider_lab)
    second.set_link_value("mass:piston", "0.777")  # an edit of its own: a setup starts from its preset
    second.upload_setup(None, name, content)
    _same(_state(second), _state(first))
    assert second.snapshot()["values"]["mass:piston"] == 0.3
    assert second.setup_pairs() == first.setup_pairs()
    assert second.notices.text is None or "Not applied" not in second.notices.text
    assert _moving(second)


def test_a_setup_of_a_mechanism_from_a_file_carries_its_description(slider_lab, connect):
    _, first = connect(slider_lab)
    description = MECHANISM_PRESETS["crank-rocker"]().model_copy(update={"name": "my-rocker"})
    first.load_file(None, "rocker.json", description.model_dump_json().encode())
    first.set_link_value("mass:coupler", "0.6")
    first.set_link_value("g", "3.25")
    with pytest.raises(LinkageError, match="loaded from a file"):
        first.link_query()  # a link names a preset; a setup file can carry the file
    name, content = first.download_file("setup")
    document = json.loads(content)
    assert "preset" not in document["values"] and document["values"]["g"] == 3.25
    assert document["mechanism"]["name"] == "my-rocker"
    _, second = connect(slider_lab)
    second.upload_setup(None, name, content)
    assert second.label == "my-rocker" and second.reference == first.reference
    _same({**_state(second), "mechanism": None}, {**_state(first), "mechanism": None})
    assert "my-rocker" in second.menu.options and _moving(second)


def test_a_description_named_like_a_preset_is_not_taken_for_it():
    content = _setup({"g": 4}, MECHANISM_PRESETS["slider-crank"]().model_dump(mode="json"))
    saved = share.setup_from_state(content, "s.json")
    assert saved.label == "slider-crank (file)" and saved.preset is None and saved.names_a_mechanism


# ------------------------------------------------------------------------------------------ switching kinds
def test_a_chain_setup_switches_a_mechanism_session_to_the_chain_and_back(slider_lab, connect):
    client, session = connect(slider_lab)
    client_id = next(k for k, s in slider_lab.sessions.items() if s is session)
    chain = _setup({"preset": "double", "L1": 1.5, "theta1": 60, "method": "dae"})
    session.guard(lambda: session.upload_setup(None, "double.json", chain))
    back = _showing(slider_lab, client_id, session, lambda s: s.chain is not None)
    assert back.params.preset == "double" and back.params.L[0] == 1.5 and back.menu.value == "double"
    assert back.params.method == "dae" and _moving(back)
    mechanism = _setup({"preset": "jansen-leg", "g": 4.5, "speed:O": -120})
    back.guard(lambda: back.upload_setup(None, "leg.json", mechanism))
    leg = _showing(slider_lab, client_id, back, lambda s: s.chain is None and s.label == "jansen-leg")
    assert leg.mechanism.g == 4.5 and leg.menu.value == "jansen-leg"
    assert leg.snapshot()["values"]["speed:O"] == pytest.approx(-120.0) and _moving(leg)
    description = _setup({"mass:coupler": 0.55}, MECHANISM_PRESETS["crank-rocker"]().model_dump(mode="json"))
    leg.guard(lambda: leg.choose("single"))
    chain_again = _showing(slider_lab, client_id, leg, lambda s: s.chain is not None and s.params.preset == "single")
    chain_again.guard(lambda: chain_again.upload_setup(None, "rocker-setup.json", description))
    rocker = _showing(slider_lab, client_id, chain_again,
                      lambda s: s.chain is None and s.label == "crank-rocker (file)")
    assert rocker.mechanism.body("coupler").mass == 0.55
    assert len(slider_lab.sessions) >= 1 and client_id in slider_lab.sessions


# ------------------------------------------------------------------------------------------ bad files
@pytest.mark.parametrize("content, words, whole", [
    (b"{nope", "not valid JSON", True),
    (_setup({"preset": "slider-crank", "mass:crank": -2}), "crank: m (kg) = -2: allowed range", False),
    (_setup({"preset": "slider-crank", "angle0:crank": 400}), "crank: start angle (°) = 400: allowed range -180 to 180",
     False),
    (_setup({"preset": "slider-crank", "g": 2000}), "g (m/s²) = 2000: allowed range 0 to 1000", False),
    (_setup({"preset": "slider-crank", "method": "euler"}), "method = 'euler': allowed values", False),
    (_setup({"preset": "walking-robot"}), "preset = 'walking-robot': allowed", True),
    (_setup({"g": 1}, {"name": "x", "bodies": "no"}), "mechanism: bodies", True),
    (_setup({"g": 1}, _open_rocker()), OPEN_LOOP, True),
    (_setup({"preset": "slider-crank"}, MECHANISM_PRESETS["crank-rocker"]().model_dump(mode="json")),
     "values.preset: a setup with its own mechanism names no preset", True),
])
def test_a_bad_setup_is_one_notice_and_the_session_goes_on(slider_lab, connect, content, words, whole):
    """A file that cannot be read, or names no mechanism there is, changes nothing; a value refused is listed in
    one notice and the rest applied, as for a chain."""
    _, session = connect(slider_lab)
    session.set_link_value("g", "6.5")
    session.guard(lambda: session.upload_setup(None, "bad.json", content))
    text = session.notices.text or ""
    said = re.search(words, text) if isinstance(words, re.Pattern) else words in text
    assert said and "\n" not in text and "Session paused" not in text, text
    assert ("Not applied from setup file 'bad.json'" in text) != whole, text
    assert not session.closed and session.player.error is None and _moving(session)
    assert (session.mechanism.g == 6.5) == whole  # refused whole: nothing changed; else the setup's preset


def test_the_pure_check_agrees_with_the_session(slider_lab, connect):
    _, session = connect(slider_lab)
    _edited(session)
    replay = check_mechanism_setup(session.setup_pairs(), MECHANISM_PRESETS["slider-crank"]())
    assert replay.mechanism == session.mechanism and replay.settings == session.settings
    assert list(replay.q0) == pytest.approx(list(session.q0), abs=1e-12)
    assert list(replay.qdot0) == pytest.approx(list(session.qdot0), abs=1e-12)


# ------------------------------------------------------------------------------------------ presenter lock
def test_a_viewer_of_a_locked_lecture_cannot_load_a_setup():
    server = LabServer(port=0, warm=False, shared=True, preset="slider-crank")
    try:
        session = server.shared_session
        assert isinstance(session, Session) and server.presenter_url is not None
        content = _setup({"preset": "slider-crank", "g": 2.5, "mass:crank": 0.4321})
        with pytest.raises(LinkageError, match="the presenter controls this session"):
            session.upload_setup(7, "s.json", content)  # not the presenter's browser
        with pytest.raises(LinkageError, match="the presenter controls this session"):
            session.upload_setup(None, "s.json", content)  # an unknown sender: fails closed
        uuid = viser_compat.control_id(session.setup_upload)
        for race in range(5):  # a viewer's upload through the button, leaving at once
            send_messages(server.url, upload_messages(uuid, "s.json", content, transfer=f"v{race}"), pause=0)
        time.sleep(1.0)
        assert server.shared_session is session and session.mechanism.g != 2.5
        send_messages(server.presenter_url, upload_messages(uuid, "s.json", content, transfer="p"), pause=0.2)
        assert wait_until(lambda: server.shared_session.mechanism.g == 2.5, timeout=60), \
            "the presenter's own upload was not applied"
        assert server.shared_session.mechanism.body("crank").mass == 0.4321
    finally:
        server.stop()


# ------------------------------------------------------------------------------------------ --state FILE
def test_state_names_its_mechanism_with_or_without_preset(tmp_path):
    path = tmp_path / "leg.json"
    path.write_bytes(_setup({"preset": "jansen-leg", "g": 4.5}))
    mechanism, label, pairs = start_from_state(str(path), "triple-a", None, None, None, from_file=False)
    assert label == "jansen-leg" and mechanism == MECHANISM_PRESETS["jansen-leg"]() and ("g", "4.5") in pairs
    slider = MECHANISM_PRESETS["slider-crank"]()
    again = start_from_state(str(path), "triple-a", None, slider, "slider-crank", from_file=False)
    assert again[1] == "jansen-leg"  # the setup's own preset wins over --preset
    plain = tmp_path / "plain.json"
    plain.write_bytes(_setup({"mass:piston": 0.4321}))  # names no mechanism: --preset's
    assert start_from_state(str(plain), "triple-a", None, slider, "slider-crank", from_file=False)[1] == "slider-crank"
    with pytest.raises(LinkageError, match="'mass:piston': not a control of"):
        start_from_state(str(plain), "triple-a", None, MECHANISM_PRESETS["jansen-leg"](), "jansen-leg", False)
    chain = tmp_path / "chain.json"
    chain.write_bytes(_setup({"preset": "double", "L1": 1.5}))
    assert start_from_state(str(chain), "triple-a", None, slider, "slider-crank", from_file=False)[0] is None
    with pytest.raises(LinkageError, match="leave out --mechanism"):
        start_from_state(str(path), "triple-a", None, slider, "rocker.json", from_file=True)


@pytest.mark.parametrize("shared", [False, True])
def test_every_new_session_starts_from_a_mechanism_setup(tmp_path, shared):
    path = tmp_path / "setup.json"
    path.write_bytes(_setup({"mass:coupler": 0.55, "g": 3.5},
                            MECHANISM_PRESETS["crank-rocker"]().model_copy(update={"name": "rocker"}).model_dump()))
    mechanism, label, pairs = start_from_state(str(path), "triple-a", None, None, None, from_file=False)
    server = LabServer(port=0, warm=False, setup=pairs, mechanism=mechanism, mechanism_label=label, shared=shared)
    try:
        client = BackgroundClient(server.url)
        try:
            session = server.shared_session if shared else server.wait_for_sessions(1)[0]
            assert isinstance(session, Session) and session.label == "rocker"
            assert session.mechanism.g == 3.5 and session.mechanism.body("coupler").mass == 0.55
            assert _moving(session)
        finally:
            client.close()
    finally:
        server.stop()
    with pytest.raises(LinkageError, match=OPEN_LOOP):
        path.write_bytes(_setup({"g": 2}, _open_rocker()))
        start_from_state(str(path), "triple-a", None, None, None, from_file=False)


def _serve(arguments: list[str]) -> tuple[str, str, int | None]:
    """``python -m app ARGUMENTS --port 0``: its first line and what a browser's panel receives (or the error)."""
    process = subprocess.Popen([sys.executable, "-m", "app", "--port", "0", "--processes", "1", *arguments],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = process.stdout.readline() if process.stdout else ""
        if "serving at " not in line:
            process.wait(120)
            return line, process.stderr.read() if process.stderr else "", process.returncode
        counts = Counts()
        counts.payloads = []
        client = BackgroundClient(line.split("serving at ")[1].split()[0], counts)
        try:
            wait_until(lambda: any(b"0.4321" in p for p in list(counts.payloads or [])), timeout=90)
            received = b"".join(counts.payloads or []).decode("latin-1")
        finally:
            client.close()
        return line, received, None
    finally:
        if process.poll() is None:
            process.terminate()
            process.wait(60)


def test_the_command_line_starts_from_a_mechanism_setup_and_refuses_a_bad_one_in_one_line(tmp_path):
    good = tmp_path / "good.json"
    good.write_bytes(_setup({"preset": "slider-crank", "mass:crank": 0.4321}))
    line, received, code = _serve(["--state", str(good)])
    assert code is None and "serving at" in line, received
    assert "type crank: m (kg)" in received and "0.4321" in received  # the mechanism's panel, the setup's value
    for values, words in [
        ({"preset": "slider-crank", "mass:crank": -2}, "crank: m (kg) = -2: allowed range 1e-06 to"),
        ({"preset": "slider-crank", "angle0:crank": 400}, "crank: start angle (°) = 400: allowed range -180 to 180"),
        ({"preset": "slider-crank", "g": 2000}, "g (m/s²) = 2000: allowed range 0 to 1000"),
        ({"preset": "slider-crank", "method": "euler"}, "method = 'euler': allowed values dae, lagrange"),
        ({"preset": "walking-robot"}, "preset = 'walking-robot': allowed single"),
    ]:
        bad = tmp_path / "bad.json"
        bad.write_bytes(_setup(values))
        for extra in ([], ["--preset", "slider-crank"]):
            done = subprocess.run([sys.executable, "-m", "app", "--port", "0", "--state", str(bad), *extra],
                                  capture_output=True, text=True, timeout=120)
            assert done.returncode == 2, done.stderr
            lines = done.stderr.strip().splitlines()
            assert len(lines) == 1 and lines[0].startswith(f"linkage-lab: error: --state {bad}: "), done.stderr
            assert words in lines[0], lines[0]
