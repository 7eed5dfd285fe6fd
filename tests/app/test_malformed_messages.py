"""A hostile client's messages never kill a session or print a traceback (app/viser_compat.py, guard_messages, app/session.py).

Sent through a raw websocket client (app/wsclient.py) as a script in a page could: messages that do not
decode, an unknown type, a missing field, a control id that is a list, NaN or infinity for the integer
"Bars (chain)" slider (the ``chain`` preset's), a value outside a dropdown's options (the Plot dropdown's killed
the session on every frame; the free-body diagram's Body menu, the chain panel's Report tab Bar menu, raised). Each is refused quietly: at most one line in the server's log, no
traceback, and the session goes on (its frames keep coming and Reset works)."""

from __future__ import annotations

import math

import pytest

from app import viser_compat
from app.wsclient import encode, gui_update_message
from conftest import wait_until


def _malformed(session) -> dict[str, bytes]:
    links = viser_compat.control_id(session._knob_handles["links"])  # the "Bars (chain)" slider
    return {
        "not msgpack": b"\x00\x01garbage",
        "not a table": encode([1, 2, 3]),
        "unknown type": encode({"type": "NoSuchMessage", "x": 1}),
        "missing field": encode({"type": "GuiUpdateMessage", "uuid": links}),
        "id is a list": encode({"type": "GuiUpdateMessage", "uuid": [1, 2], "updates": {"value": 1}}),
        "unknown id": gui_update_message("no-such-control", 1),
        "NaN bars": gui_update_message(links, math.nan),
        "infinite bars": gui_update_message(links, math.inf),
        "values a list": encode({"type": "GuiUpdateMessage", "uuid": links, "updates": [1]}),
    }


def _frames_go_on(client, session) -> bool:
    sent = session.frames_sent
    return wait_until(lambda: session.frames_sent > sent + 5, timeout=60)


@pytest.mark.parametrize("kind", ["not msgpack", "not a table", "unknown type", "missing field", "id is a list",
                                  "unknown id", "NaN bars", "infinite bars", "values a list"])
def test_a_malformed_message_is_dropped_quietly_and_the_session_goes_on(connect, capfd, kind):
    client, session = connect()
    session.set_mechanism("chain")  # the preset whose panel has the "Bars (chain)" slider
    assert session.player.wait_idle(60)
    capfd.readouterr()
    n, dropped = session.params.n, viser_compat.dropped_messages
    client.send(_malformed(session)[kind])
    client.send(_malformed(session)[kind])  # twice: still at most one line for the kind
    assert _frames_go_on(client, session), "the session stopped sending frames"
    assert not session.closed and session.player.alive and session.player.error is None
    assert session.params.n == n
    err = capfd.readouterr().err
    assert "Traceback" not in err and "Task exception" not in err, err[-3000:]
    assert len([line for line in err.splitlines() if line.strip()]) <= 1, err
    if kind not in ("unknown id", "values a list"):  # viser ignores an unknown id; a bad table gets a notice
        assert viser_compat.dropped_messages >= dropped + 2


def test_a_value_outside_the_plot_dropdown_is_refused_and_the_plot_stays(connect, capfd):
    client, session = connect()
    plot = session.plot_choice
    angles = "Angles θ(t)"
    client.send_value(viser_compat.control_id(plot), angles)
    assert wait_until(lambda: session.plot_kind == "angles", timeout=30)
    titles: list[str] = []
    show = session.show_notice
    session.show_notice = lambda title, body, **kw: (titles.append(f"{title}: {body}"), show(title, body, **kw))
    client.send_value(viser_compat.control_id(plot), "Energy; DROP TABLE")
    assert wait_until(lambda: titles, timeout=30)
    assert "plot = 'Energy; DROP TABLE': allowed Energy, Angles θ(t), Phase portrait (θ, ω)" in titles[0], titles
    assert wait_until(lambda: plot.value == angles, timeout=30), plot.value  # put back on the plot shown
    assert session.plot_kind == "angles"
    assert _frames_go_on(client, session) and session.player.error is None
    session.guard(session.reset)
    assert session.player.wait_idle(60) and _frames_go_on(client, session)
    err = capfd.readouterr().err
    assert "Traceback" not in err and "tuple.index" not in err, err[-3000:]


def test_the_free_body_body_menu_refuses_a_body_it_does_not_offer(connect, capfd):
    client, session = connect()
    titles: list[str] = []
    show = session.show_notice
    session.show_notice = lambda title, body, **kw: (titles.append(f"{title}: {body}"), show(title, body, **kw))
    bar_menu = session.body_menu  # the free-body diagram's Body menu (the chain panel's Report tab Bar menu)
    assert list(bar_menu.options) == ["bar1", "bar2", "bar3"], bar_menu.options
    for count, value in enumerate(("0", "99", "1.5", "x"), start=1):
        # one at a time: viser's callbacks read the control's value when they run, not the message's
        client.send_value(viser_compat.control_id(bar_menu), value)
        assert wait_until(lambda count=count: len(titles) >= count, timeout=30), titles
        assert f"body = '{value}': allowed values bar1, bar2, bar3" in titles[-1], titles
    assert all(title.startswith("Not applied: body = ") for title in titles), titles
    assert bar_menu.value in bar_menu.options
    assert _frames_go_on(client, session) and session.player.error is None
    assert "Traceback" not in capfd.readouterr().err
