"""Share links: a query sets up a session through the command layer (bad values: one notice naming each, the rest
applied), and the link for the current setup gives the same setup back."""

from __future__ import annotations

import math
import urllib.parse

import pytest

from app import commands, share
from app.commands import CONTROL
from app.parameters import SessionParameters
from app.wsclient import BackgroundClient
from conftest import wait_until


def _path(query: str) -> str:
    return share.SETUP_PATH + urllib.parse.quote(query.lstrip("?"), safe="")


def _connect_with(lab, query: str):
    before = set(lab.sessions)
    url = lab.url + _path(query)
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
        for words in ("0 <= L1 <= 1000 m", "m2 = 'abc'", "unknown parameter '<b>x</b>'", "theta1 = 1e999: must be a finite number",
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
