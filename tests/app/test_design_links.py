"""A design's share link (app/design_view.py, issue 27): ``?sketch=`` carries the whole design compressed (its
mechanism file's JSON, zlib, base64url) and a page opened with it designs that design. A design too long for a
link is one notice suggesting Save; a malformed, oversized or decompression-bomb value is one notice naming
``sketch``, never a traceback, nothing evaluated; in a lecture the presenter's link opens the design for everyone,
a viewer's is not applied, and the link never carries the presenter's secret."""

from __future__ import annotations

import base64
import json
import random
import urllib.parse
import zlib

import pytest
import viser

from app.design_view import MAX_SKETCH_BYTES, MAX_SKETCH_CHARS, design_from_sketch, sketch_from, sketch_of
from app.server import LabServer
from app.session import MECHANISM_PRESETS, Session
from app.share import SETUP_PATH, setup_from_path
from conftest import BrowserStandIn, wait_until
from physics import LinkageError
from physics.mechanism.design import Design, design_from_mechanism
from physics.mechanism.writer import to_document


@pytest.fixture
def session(in_process):
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    opened = Session(server, MECHANISM_PRESETS["crank-rocker"](), label="crank-rocker", shared=True, autoplay=False)
    assert opened.player.wait_idle(120), "the first start was not shown"
    yield opened
    opened.close(clean=True)
    server.stop()


def four_bar() -> Design:
    """A crank-rocker as a designer builds it, with a motor, a traced point and one body's own mass."""
    design = (Design().add_ground("O2", (0.0, 0.0)).add_ground("O4", (0.4, 0.0))
              .add_bar("crank", ("A0", (0.0, 0.0)), ("A", (0.1, 0.0)))
              .add_bar("coupler", ("A", (0.1, 0.0)), ("B", (0.45, 0.25)))
              .add_bar("rocker", ("B", (0.45, 0.25)), ("B0", (0.4, 0.0))))
    for name, a, b in (("O2p", "ground.O2", "crank.A0"), ("Ap", "crank.A", "coupler.A"),
                       ("Bp", "coupler.B", "rocker.B"), ("O4p", "rocker.B0", "ground.O4")):
        design = design.add_pin(name, a, b)
    return design.add_motor("O2p", speed=3.0).set_trace("coupler.B").set_mass("coupler", 0.7, 0.011)


def packed(data: bytes) -> str:
    return base64.urlsafe_b64encode(zlib.compress(data, 9)).rstrip(b"=").decode()


def too_long_design() -> Design:
    """24 plates of 16 random points: their coordinates do not compress into a link."""
    rng = random.Random(1)
    design = Design()
    for k in range(24):
        design = design.add_plate(f"p{k}", [(f"P{j}", (round(rng.uniform(-1, 1), 9), round(rng.uniform(-1, 1), 9)))
                                            for j in range(16)])
    return design.add_pin("j", "p0.P0", "p1.P0")


def test_a_design_and_every_preset_opened_as_a_design_come_back_whole_from_their_link():
    design = four_bar()
    value = sketch_of(design)
    assert set(value) <= set("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_")
    assert design_from_sketch(value) == design
    for name, make in MECHANISM_PRESETS.items():
        opened = design_from_mechanism(make())
        value = sketch_of(opened)
        assert len(value) <= MAX_SKETCH_CHARS, name
        assert design_from_sketch(value) == opened, name


def test_a_design_too_long_for_a_link_is_one_notice_suggesting_save(session):
    view = session.design_view
    view.open_design(too_long_design())
    serial = session.notices.serial
    session.guard(view.show_link)
    assert session.notices.serial == serial + 1
    assert f"at most {MAX_SKETCH_CHARS}" in session.notices.text and "save the design" in session.notices.text
    assert "sketch=" not in view.link_line.content


def test_an_incomplete_design_has_no_link_and_says_what_is_missing(session):
    view = session.design_view
    view.add_ground("O2", (0.0, 0.0))
    session.guard(view.show_link)
    assert "add a bar or a plate first" in session.notices.text


HOSTILE = {
    "empty": "",
    "not base64url": "abc+/def",
    "a script": "<script>alert(1)</script>",
    "cut short base64": "A" * 5,
    "not compressed": base64.urlsafe_b64encode(b"hello world, not zlib").rstrip(b"=").decode(),
    "cut short compressed data": packed(json.dumps(to_document(four_bar().to_mechanism())).encode())[:120],
    "a decompression bomb": packed(b" " * (MAX_SKETCH_BYTES + 10)),
    "a bomb of json": packed(b"[" + b"0," * (4 * MAX_SKETCH_BYTES) + b"0]"),
    "nested too deeply": packed(b"[" * 200_000),
    "not json": packed(b"__import__('os').system('echo pwned')"),
    "json not a mechanism": packed(b'{"name": "x", "bodies": "__import__(\'os\')"}'),
    "a list": packed(b"[1, 2, 3]"),
    "over the length": "A" * (MAX_SKETCH_CHARS + 1),
    "a mechanism with an infinite coordinate": packed(json.dumps(to_document(four_bar().to_mechanism()))
                                                      .replace("0.45", "1e999").encode()),
    "a ground point named by a lone surrogate": packed(json.dumps(
        {**(document := to_document(four_bar().to_mechanism())), "ground": {**document["ground"], "G\ud800": [1, 1]}}
    ).encode()),
}


@pytest.mark.parametrize("what", list(HOSTILE))
def test_a_hostile_sketch_is_one_line_naming_sketch(what):
    value = HOSTILE[what]
    with pytest.raises(LinkageError, match=r"^sketch: ") as refused:
        design_from_sketch(value)
    assert "\n" not in str(refused.value) and len(str(refused.value)) < 400
    rest, design, reasons = sketch_from([("g", "9"), ("sketch", value)])
    assert rest == [("g", "9")] and design is None and reasons == [str(refused.value)]


def test_the_bomb_is_refused_without_inflating_it_whole():
    value = HOSTILE["a decompression bomb"]
    assert len(value) < 2000  # small in the link, over the bound once inflated
    with pytest.raises(LinkageError, match="decompresses to over 256 KB"):
        design_from_sketch(value)


def test_a_sketch_link_may_be_longer_than_a_presets_but_the_rest_of_it_is_bounded_as_any_link():
    value = "A" * MAX_SKETCH_CHARS
    pairs = setup_from_path(SETUP_PATH + urllib.parse.quote(f"sketch={value}&design=1", safe=""))
    assert pairs == [("sketch", value), ("design", "1")]
    with pytest.raises(LinkageError, match="at most 4000"):
        setup_from_path(SETUP_PATH + urllib.parse.quote(f"sketch=A&g={'1' * 4100}", safe=""))
    with pytest.raises(LinkageError, match="^link: "):
        setup_from_path(SETUP_PATH + "A" * 20_000)


def test_a_page_opened_with_a_design_link_designs_that_design(in_process):
    server = LabServer(port=0, warm=False, preset="crank-rocker")
    client = None
    try:
        design = four_bar()
        client = BrowserStandIn(server.url + SETUP_PATH + urllib.parse.quote(f"sketch={sketch_of(design)}", safe=""))
        assert wait_until(lambda: len(server.sessions) == 1, timeout=60)
        (session,) = server.sessions.values()
        view = session.design_view
        assert wait_until(lambda: view.on, timeout=60), "the page opens designing"
        assert view.design == design and session.camera.view == "front"
        assert session.notices.serial == 0, session.notices.text
    finally:
        if client is not None:
            client.close()
        server.stop()


def test_a_page_opened_with_a_hostile_design_link_gets_one_notice_naming_sketch(in_process):
    server = LabServer(port=0, warm=False, preset="crank-rocker")
    client = None
    try:
        client = BrowserStandIn(server.url + SETUP_PATH + urllib.parse.quote(
            f"sketch={HOSTILE['a decompression bomb']}", safe=""))
        assert wait_until(lambda: len(server.sessions) == 1, timeout=60)
        (session,) = server.sessions.values()
        assert wait_until(lambda: session.notices.serial > 0, timeout=60)
        assert session.notices.serial == 1
        assert session.notices.text.startswith("Not applied from the link: sketch: decompresses to over")
        assert session.design_view.design == Design() and not session.design_view.on
    finally:
        if client is not None:
            client.close()
        server.stop()


def test_in_a_lecture_the_presenters_design_link_opens_it_for_everyone_and_no_link_carries_the_secret(in_process):
    server = LabServer(port=0, warm=False, shared=True, preset="triple-a", autoplay=False)
    viewer = presenter = None
    try:
        session = server.shared_session
        assert session.player.wait_idle(120)
        view = session.design_view
        design = four_bar()
        query = urllib.parse.quote(f"sketch={sketch_of(design)}", safe="")
        viewer = BrowserStandIn(server.url + SETUP_PATH + query)
        told = lambda: [t for _, t in viewer.counts.notifications if t == "The presenter controls the setup"]  # noqa: E731
        assert wait_until(told, timeout=60)
        assert view.design == Design(), "a viewer's design link is not applied"
        presenter = BrowserStandIn(server.presenter_url + SETUP_PATH + query)
        assert wait_until(lambda: view.design == design and view.on, timeout=60)
        secret = server.presenter_path.removeprefix("/presenter-").removesuffix(".html")
        view.show_link()
        assert "](/?sketch=" in view.link_line.content and secret not in view.link_line.content
        assert design_from_sketch(urllib.parse.parse_qs(view.link_query()[1:])["sketch"][0]) == design
    finally:
        for client in (viewer, presenter):
            if client is not None:
                client.close()
        server.stop()


def test_in_a_lecture_the_presenters_design_1_link_opens_design_mode_for_everyone(in_process):
    """``?design=1`` on the presenter's address opens the shared session designing (it was read as a control
    name and refused); a bad value is one notice naming ``design``."""
    server = LabServer(port=0, warm=False, shared=True, preset="triple-a", autoplay=False)
    presenter = None
    try:
        session = server.shared_session
        assert session.player.wait_idle(120)
        presenter = BrowserStandIn(server.presenter_url + SETUP_PATH + "design%3D1")
        assert wait_until(lambda: session.design_view.on, timeout=60), "the presenter's design=1 opens Design mode"
        assert session.notices.text is None or not session.notices.text.startswith("Not applied"), \
            session.notices.text
        presenter.close()
        presenter = BrowserStandIn(server.presenter_url + SETUP_PATH + "design%3Dmaybe")
        assert wait_until(lambda: (session.notices.text or "").startswith("Not applied from the link: design:"),
                          timeout=60), session.notices.text
    finally:
        if presenter is not None:
            presenter.close()
        server.stop()
