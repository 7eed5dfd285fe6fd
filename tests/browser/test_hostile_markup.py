"""Markup and script sent as control values are shown as text and never run (issue: hostile input).

viser renders markdown with raw HTML, so a refused value quoted in a notice and copied onto the status line
could carry an ``<iframe srcdoc=...>`` or an ``onerror`` handler. In ``--shared`` mode the status line is sent
to every viewer: a hostile websocket client sends the payloads to every select control, then a second,
fresh page opens; in own-session mode the page's own session receives them. Either page must show the
payload as text, keep its title, and have no element the payload would have made.
"""

from __future__ import annotations

import time

import pytest

from app import snapshot as snap
from app import viser_compat, wsclient

MARKER = "PWNED"
PAYLOADS = (
    f'<iframe srcdoc="<script>parent.document.title=\'{MARKER}\'</script>"></iframe>',
    f'<img src=x onerror="document.title=\'{MARKER}\'">',
    f"<script>document.title='{MARKER}'</script>",
    f"[click me](javascript:document.title='{MARKER}')",
)
STATUS_WAIT_S = 20.0


def _select_controls(session) -> dict:
    # the one session's menus (app/session.py _build_panel)
    return {
        "mechanism": session.menu,
        "method": session.method,
        "integrator": session.integrator,
        "stabilization": session.stabilization,
        "trace_point": session.trace_menu,
    }


def _shared_page(lab):
    """A page watching the shared session (shared mode makes no session per page)."""
    page = snap.goto_app(lab.browser, lab.port)
    snap.wait_until_drawn(page)
    lab.opened.append(page)
    return page


def _assert_inert(page, payload: str) -> None:
    """The page shows ``payload``'s words as text and nothing in it ran or became an element."""
    deadline = time.monotonic() + STATUS_WAIT_S
    while time.monotonic() < deadline:
        if "Not applied" in page.inner_text("body"):
            break
        time.sleep(0.1)
    body = page.inner_text("body")
    assert "Not applied" in body, "the refused value produced no notice on the status line"
    assert MARKER in body, "the payload is not shown as text"
    assert page.title() != MARKER
    made = page.evaluate(
        """marker => [...document.querySelectorAll('iframe, img, script, a')]
               .filter(element => element.outerHTML.includes(marker)).map(element => element.outerHTML)""",
        MARKER,
    )
    assert made == [], f"the payload became elements: {made}"


@pytest.mark.parametrize("payload", PAYLOADS, ids=["iframe", "img-onerror", "script", "js-link"])
def test_shared_mode_shows_a_hostile_clients_markup_as_text_to_every_viewer(start_lab, payload):
    lab = start_lab(preset="triple-a", shared=True)
    session = lab.server.shared_session
    session.pause()
    viewer = _shared_page(lab)
    # viser exposes no public id for a control; the wire protocol addresses it by this uuid.
    updates = [(viser_compat.control_id(handle), payload) for handle in _select_controls(session).values()]
    wsclient.send_values(lab.server.presenter_url, updates)  # the presenter: a viewer's values are not applied
    newcomer = _shared_page(lab)  # opens after the attack: sees the status line as it now stands
    for page in (viewer, newcomer):
        _assert_inert(page, payload)
    assert session.params.method in ("newton_euler", "lagrange", "dae")  # nothing was applied


def test_own_session_shows_its_own_hostile_values_as_text(start_lab):
    lab = start_lab(preset="four-bar")
    page = lab.open_page()
    session = page.session
    setters = [lambda value, name=name: session.set(name, value)
               for name in ("method", "integrator", "stabilization", "trace")] + [session.set_mechanism]
    for payload in PAYLOADS:
        for setter in setters:
            session.guard(lambda setter=setter: setter(payload))  # what a control's callback does
            _assert_inert(page.page, payload)
