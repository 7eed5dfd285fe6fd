"""Lecture mode's switches that need no browser: a link's ``lecture=`` value and the ``--lecture`` flag (parsed, and
a server started with it)."""

from __future__ import annotations

from app.__main__ import build_parser
from app.server import LabServer, lecture_from
from conftest import BrowserStandIn, wait_until


def test_a_link_lecture_value_is_taken_out_of_the_setup():
    setup = [("preset", "double"), ("lecture", "1"), ("L1", "1.5")]
    rest, on, refused = lecture_from(setup, False)
    assert rest == [("preset", "double"), ("L1", "1.5")] and on and not refused
    assert lecture_from([("lecture", "0")], True)[1] is False
    assert lecture_from([("preset", "double")], True) == ([("preset", "double")], True, [])


def test_a_bad_lecture_value_is_one_reason_naming_the_field():
    rest, on, refused = lecture_from([("lecture", "maybe")], False)
    assert rest == [] and on is False
    assert refused == ["lecture: 'maybe' is not 0 or 1 (lecture=1 opens the page in lecture mode)"]


def test_the_lecture_flag():
    assert build_parser().parse_args(["--lecture"]).lecture is True
    assert build_parser().parse_args([]).lecture is False


def test_a_server_started_with_lecture_opens_every_page_in_lecture_mode(in_process):
    """``--lecture`` (``LabServer(lecture=True)``) puts every new page's session in lecture mode, without a link."""
    server = LabServer(port=0, warm=False, preset="double", lecture=True)
    client = None
    try:
        client = BrowserStandIn(server.url)
        assert wait_until(lambda: len(server.sessions) == 1, timeout=60)
        (session,) = server.sessions.values()
        assert wait_until(lambda: session.lecture, timeout=60), "the page's session is not in lecture mode"
    finally:
        if client is not None:
            client.close()
        server.stop()
