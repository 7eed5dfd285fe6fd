"""Control values no browser sends (a hostile client's) are refused before viser casts them: a notice, nothing
applied, no traceback on the server, the session keeps going; values a browser does send still arrive.

viser casts an incoming value with the type of the control's value (``float("abc")``) on its event loop; before
app/viser_compat.check_gui_updates, a string or null sent to a slider ended in a traceback there."""

from __future__ import annotations

import pytest

from app import viser_compat
from app.server import LabServer
from app.viser_compat import SHOWN_VALUE_CHARS, update_problem
from app.wsclient import send_values
from conftest import BrowserStandIn, wait_until

HOSTILE = ("abc", None, [1, 2], {"a": 1}, "1e999", True, "<b>x</b>")


@pytest.mark.parametrize(
    "current, updates, problem",
    [
        (1.0, {"value": 2}, None),
        (1.0, {"value": 2.5}, None),
        (1.0, {"value": "abc"}, "'abc' is not a number"),
        (1.0, {"value": None}, "None is not a number"),
        (1.0, {"value": True}, "True is not a number"),
        (1, {"value": [1]}, "[1] is not a number"),
        (True, {"value": 1}, "1 is not true or false"),
        (True, {"value": False}, None),
        ("dae", {"value": "lagrange"}, None),
        ("dae", {"value": 3}, "3 is not text"),
        ((1.0, 2.0), {"value": [3, 4.5]}, None),
        ((1.0, 2.0), {"value": [3]}, "[3] is not a list of 2 values"),
        ((1.0, 2.0), {"value": ["a", 1]}, "['a', 1] is not a list of 2 values"),
        (1.0, {"value": 1.0, "disabled": False}, "a browser sets only a control's value (got ['disabled', 'value'])"),
        (1.0, {"visible": False}, "a browser sets only a control's value (got ['visible'])"),
        (1.0, "value", "a browser sets only a control's value (got 'value')"),
        (1.0, {"value": "x" * 1000}, "'" + "x" * (SHOWN_VALUE_CHARS - 2) + "… is not a number"),
    ],
)
def test_what_a_browser_can_send_for_each_kind_of_control(current, updates, problem):
    assert update_problem(current, updates) == problem


def _numeric_sliders(session):
    """Every numeric slider of the panel a browser can move: the generated knobs' (the chain's numbers, its start,
    the run's settings) and the display numbers' (speed, trace length, arrow scale)."""
    sliders = [*session._knob_handles.values(), *(number.slider for number in session.numbers.controls.values())]
    return [slider for slider in sliders if not slider.disabled]


def _assert_refused_quietly(session, capfd, titles, before):
    assert titles and set(titles) == {"Not applied"}, titles
    assert session.params == before, "a refused value changed the parameters"
    assert not session.closed and session.player.alive
    err = capfd.readouterr().err
    assert "Traceback" not in err and "Task exception" not in err, err[-2000:]


def test_own_session_refuses_what_no_browser_sends_and_applies_what_one_does(connect, capfd):
    client, session = connect()
    titles: list[str] = []
    show = session.show_notice
    session.show_notice = lambda title, body, **kw: (titles.append(title), show(title, body, **kw))
    before = session.params
    sliders = _numeric_sliders(session)
    assert len(sliders) >= 10
    dropdowns = [session.method, session.integrator]
    for slider in sliders:
        for value in HOSTILE:
            client.send_value(viser_compat.control_id(slider), value)
    for dropdown in dropdowns:
        for value in (3, None, ["dae"], True):
            client.send_value(viser_compat.control_id(dropdown), value)
    expected = len(sliders) * len(HOSTILE) + len(dropdowns) * 4
    assert wait_until(lambda: len(titles) >= expected, timeout=30), (len(titles), expected)
    _assert_refused_quietly(session, capfd, titles, before)
    # what a browser does send still arrives: a number for the gravity slider
    gravity = session._knob_handles["g"]
    client.send_value(viser_compat.control_id(gravity), 2.5)
    assert wait_until(lambda: session.params.chain.g == pytest.approx(2.5), timeout=30), session.params.chain.g


def test_shared_mode_refuses_a_hostile_clients_values_before_viser_casts_them(capfd):
    server = LabServer(port=0, warm=False, shared=True, preset="triple-a")
    try:
        session = server.shared_session
        assert session.player.wait_idle(60)
        watcher = BrowserStandIn(server.url)
        titles: list[str] = []
        show = session.show_notice
        session.show_notice = lambda title, body, **kw: (titles.append(title), show(title, body, **kw))
        before = session.params
        sliders = _numeric_sliders(session)
        # sent as the presenter: a viewer's values would not even reach the checks (tests/app/test_presenter.py)
        send_values(server.presenter_url, [(viser_compat.control_id(s), v) for s in sliders for v in HOSTILE],
                    pause=0.002)
        assert wait_until(lambda: len(titles) >= len(sliders) * len(HOSTILE), timeout=30), len(titles)
        _assert_refused_quietly(session, capfd, titles, before)
        t0 = session.snapshot()["time"]
        assert wait_until(lambda: session.snapshot()["time"] > t0 + 0.2, timeout=30), "the shared session stopped"
        watcher.close()
    finally:
        server.stop()
