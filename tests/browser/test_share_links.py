"""Share links in a real page: the address's query sets up the session, and the panel's link for the current
setup opens a session with the same setup (app/share.py)."""

from __future__ import annotations

import math
import time

import pytest

from app import snapshot as snap

from .conftest import SERVER_TIMEOUT_S, AppPage, wait_until

pytestmark = pytest.mark.browser


def _open(lab, query: str) -> AppPage:
    before = set(lab.server.sessions)
    page = lab.browser.new_context(viewport=snap.VIEWPORT, device_scale_factor=1).new_page()
    page.goto(f"http://127.0.0.1:{lab.port}/{query}&fixedDpr=1&hideViserLogo")
    deadline = time.monotonic() + SERVER_TIMEOUT_S
    while not set(lab.server.sessions) - before and time.monotonic() < deadline:
        time.sleep(0.02)
    (client_id,) = set(lab.server.sessions) - before
    app = AppPage(page=page, client_id=client_id, lab=lab)
    lab.pages.append(app)
    snap.wait_until_drawn(page)
    return app


def test_a_share_link_sets_up_the_session_and_the_panel_gives_it_back(start_lab):
    lab = start_lab(preset="triple-a")
    app = _open(lab, "?preset=double&L1=1.5&theta1=60&method=dae")
    p = app.session.params
    assert p.preset == "double" and p.method == "dae" and p.L[0] == 1.5
    assert p.theta0[0] == pytest.approx(math.radians(60))
    assert app.session.notice is None

    app.session.set("g", "3.5", "control")
    app.open_tab("Export")
    app.page.get_by_role("button", name="Link to this setup").click()
    link = app.page.get_by_role("link", name="Open this setup")
    link.wait_for()
    href = link.get_attribute("href")
    assert href.startswith("/?preset=double") and "g=3.5" in href and "L1=1.5" in href  # the root address

    other = _open(lab, href.removeprefix("/"))
    wait_until(lambda: other.session.params.g == 3.5, message="the link's gravity applied")
    q = other.session.params
    assert (q.preset, q.method, q.L, q.theta0[0]) == (p.preset, p.method, p.L, pytest.approx(p.theta0[0]))
