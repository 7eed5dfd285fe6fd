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


def test_a_general_mechanism_opens_from_its_preset_link_and_its_own_link_reopens_it(start_lab):
    """Issue 24: ``/?preset=jansen-leg`` (the page's preset link) was refused and the mechanism panel had no
    link. A link names a mechanism preset and its panel's values; the panel's link reopens the same setup."""
    from app.mechanism_edits import knobs
    from app.session import Session

    lab = start_lab(preset="triple-a")
    app = _open(lab, "?preset=jansen-leg&mass:crank=2.5e-1&speed:O=-1.2e2&method=lagrange")
    session = app.session
    assert isinstance(session, Session) and session.label == "jansen-leg"
    assert session.mechanism.body("crank").mass == 0.25 and session.settings.method == "lagrange"
    assert session.mechanism.drivers[0].speed == pytest.approx(math.radians(-120), rel=1e-12)
    assert session.notices.text is None, session.notices.text

    session.guard(lambda: session.set_typed("size:upper", "0.45"))
    session.guard(lambda: session.set_typed("g", "3.5"))
    assert session.notices.text is None, session.notices.text
    app.page.get_by_text("Export", exact=True).first.click()
    app.page.get_by_role("button", name="Link to this setup").click()
    link = app.page.get_by_role("link", name="Open this setup")
    link.wait_for()
    href = link.get_attribute("href")
    assert href.startswith("/?preset=jansen-leg") and "g=3.5" in href, href  # the root address

    other = _open(lab, href.removeprefix("/"))
    wait_until(lambda: isinstance(other.session, Session) and other.session.mechanism.g == 3.5,
               message="the link's mechanism and gravity")
    again = other.session
    assert again.label == "jansen-leg" and again.settings == session.settings
    values = {knob.name: knob.value for knob in knobs(session.mechanism, session.reference)}
    reopened = {knob.name: knob.value for knob in knobs(again.mechanism, again.reference)}
    assert reopened == pytest.approx(values, rel=1e-9), (reopened, values)
    assert values["size:upper"] == pytest.approx(0.45) and values["mass:crank"] == 0.25
    assert again.notices.text is None, again.notices.text

    # a value the link cannot apply is one notice naming it; the rest is applied
    third = _open(lab, "?preset=slider-crank&mass:rod=1,5&g=2")
    wait_until(lambda: isinstance(third.session, Session) and third.session.mechanism.g == 2.0,
               message="the link's gravity")
    assert "rod: m (kg) = '1,5': not a number" in (third.session.notices.text or ""), third.session.notices.text
