"""The page talks only to the server that served it (issue "Hostile input 3", hole 5).

viser's client connects its websocket to any address named by ``?websocket=`` and plays any recording named by
``?playbackPath=``; whatever such a server sends (``add_html`` with an ``onerror`` handler) would run with the
lab's address in the bar. A link naming another server must leave the page on its own server, the other
server must never see a connection, and the page's Content-Security-Policy must refuse a websocket to any
other address even if a script tried.
"""

from __future__ import annotations

import contextlib
import io
import time

import pytest
import viser

from app import snapshot as snap
from app.page import CONTENT_SECURITY_POLICY

from .conftest import wait_until

MARKER = "PWNED"
PAYLOAD = f'<img src=x onerror="document.title=\'{MARKER}\'">'


@pytest.fixture
def attacker():
    """A viser server that sends script-carrying HTML to every browser that connects to it."""
    with contextlib.redirect_stdout(io.StringIO()):
        server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    connected: list[int] = []

    def greet(client) -> None:
        connected.append(client.client_id)
        client.gui.add_html(PAYLOAD)

    server.on_client_connect(greet)
    yield server, connected
    with contextlib.redirect_stdout(io.StringIO()):
        server.stop()


def _open(lab, query: str):
    before = set(lab.server.sessions)
    page = lab.browser.new_context(viewport=snap.VIEWPORT, device_scale_factor=1).new_page()
    lab.opened.append(page)
    page.goto(f"http://127.0.0.1:{lab.port}/{query}")
    wait_until(lambda: set(lab.server.sessions) - before, message="a session on the lab's own server")
    snap.wait_until_drawn(page)
    return page


@pytest.mark.parametrize("key", ["websocket", "playbackPath"])
def test_a_link_naming_another_server_stays_on_its_own(start_lab, attacker, key):
    lab = start_lab(preset="single")
    other, connected = attacker
    address = (f"ws://127.0.0.1:{other.get_port()}" if key == "websocket"
               else f"http://127.0.0.1:{other.get_port()}/recording.viser")
    page = _open(lab, f"?{key}={address}&fixedDpr=1&hideViserLogo")
    time.sleep(2.0)  # the other server would have been reached long before the lab's panel was drawn
    assert connected == [], "the page connected to the other server"
    assert page.title() != MARKER
    assert key not in page.url, page.url
    assert page.evaluate("() => document.querySelectorAll('img[src=x]').length") == 0


def test_the_policy_refuses_a_websocket_to_another_server(start_lab, attacker):
    lab = start_lab(preset="single")
    other, connected = attacker
    page = _open(lab, "?fixedDpr=1&hideViserLogo")
    content = page.evaluate(
        "() => document.querySelector('meta[http-equiv=\"Content-Security-Policy\"]')?.content")
    assert content == CONTENT_SECURITY_POLICY
    outcome = page.evaluate(
        """port => new Promise(resolve => {
            document.addEventListener('securitypolicyviolation',
                                      event => resolve('refused ' + event.violatedDirective), {once: true});
            try {
                const socket = new WebSocket('ws://127.0.0.1:' + port);
                socket.onopen = () => resolve('opened');
            } catch (error) { resolve('refused ' + error.name); }
            setTimeout(() => resolve('timeout'), 10000);
        })""",
        other.get_port(),
    )
    assert outcome.startswith("refused"), outcome
    time.sleep(1.0)
    assert connected == []
    # the page's own connection is not affected: the lab's session kept drawing
    assert lab.server.sessions, "the lab's own session was lost"
