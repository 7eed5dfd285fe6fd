"""A design's share link in Chromium (app/design_view.py, issue 27): the Design tab's "Link to this design" shows a
link; a new page opened at it designs the same design in a session of its own, its panel stating the same
topology; a page opened with a hostile ``sketch=`` value shows one notice naming ``sketch``."""

from __future__ import annotations

import time
import urllib.parse

import pytest

from app import snapshot as snap
from physics.mechanism.design import Design

from .conftest import SERVER_TIMEOUT_S, AppPage, wait_until

pytestmark = pytest.mark.browser

VIEWPORT = {"width": 1400, "height": 850}


# Every notification the page ever shows, recorded as it appears: a link's notice is sent as the session starts
# and closes by itself after NOTICE_SECONDS, which on a loaded machine can pass before the page is drawn.
RECORD_NOTIFICATIONS = """
window.__linkageLabNotifications = [];
new MutationObserver(() => {
  for (const root of document.querySelectorAll(".mantine-Notification-root")) {
    if (root.dataset.linkageLabSeen) continue;
    const text = root.innerText.trim();
    if (!text) continue;
    root.dataset.linkageLabSeen = "1";
    window.__linkageLabNotifications.push(text);
  }
}).observe(document, {childList: true, subtree: true, characterData: true});
"""


def notifications_seen(page: AppPage) -> list[str]:
    return page.page.evaluate("() => window.__linkageLabNotifications || []")


def open_link(lab, href: str) -> AppPage:
    """A new page (own context, so its own session) at the server's ``href`` (``/?sketch=...``), drawn; every
    notification it shows is recorded (:func:`notifications_seen`)."""
    before = set(lab.server.sessions)
    context = lab.browser.new_context(viewport=VIEWPORT, device_scale_factor=1)
    context.add_init_script(RECORD_NOTIFICATIONS)
    page = context.new_page()
    page.set_default_timeout(snap.PAGE_TIMEOUT_S * 1000)
    query = href.removeprefix("/").removeprefix("?")
    page.goto(f"{snap.page_url(lab.port)}&{query}")
    deadline = time.monotonic() + SERVER_TIMEOUT_S
    while not (new := set(lab.server.sessions) - before):
        assert time.monotonic() < deadline, "the server made no session for the new page"
        time.sleep(0.05)
    (client_id,) = new
    app_page = AppPage(page=page, client_id=client_id, lab=lab)
    lab.pages.append(app_page)
    snap.wait_until_drawn(page)
    return app_page


def four_bar(view) -> None:
    view.add_ground("O2", (0.0, 0.0))
    view.add_ground("O4", (0.4, 0.0))
    view.add_bar("crank", ("A0", (0.0, 0.0)), ("A", (0.1, 0.0)))
    view.add_bar("coupler", ("A", (0.1, 0.0)), ("B", (0.45, 0.25)))
    view.add_bar("rocker", ("B", (0.45, 0.25)), ("B0", (0.4, 0.0)))
    for name, a, b in (("O2p", "ground.O2", "crank.A0"), ("Ap", "crank.A", "coupler.A"),
                       ("Bp", "coupler.B", "rocker.B"), ("O4p", "rocker.B0", "ground.O4")):
        view.add_pin(name, a, b)
    view.add_motor("O2p", speed=3.0)
    view.set_trace("coupler.B")


def test_the_link_to_a_design_opens_it_designing_in_a_new_page(start_lab):
    lab = start_lab(preset="crank-rocker")
    app = lab.open_page(viewport=VIEWPORT)
    view = app.session.design_view
    four_bar(view)
    built = view.design
    app.open_tab("Design")
    app.page.get_by_role("button", name="Link to this design", exact=True).click()
    link = app.page.get_by_role("link", name="Open this design")
    link.wait_for(timeout=SERVER_TIMEOUT_S * 1000)
    href = link.get_attribute("href")
    assert href is not None and urllib.parse.urlsplit(href).query.startswith("sketch="), href

    opened = open_link(lab, href)
    other = opened.session
    assert other is not app.session
    wait_until(lambda: other.design_view.on and other.design_view.design == built, message="the design opened")
    opened.open_tab("Design")
    opened.page.get_by_text("3 bodies, 4 joints, 1 loop: mobility 1", exact=False).wait_for(
        timeout=SERVER_TIMEOUT_S * 1000)
    assert opened.page.get_by_text("driven by 1 motor", exact=False).count() > 0
    assert other.design_view.curve is not None, "the traced point's coupler curve drawn"
    assert other.notices.serial == 0, other.notices.text  # nothing refused


def test_a_page_opened_with_a_broken_design_link_says_so_once_naming_sketch(start_lab):
    lab = start_lab(preset="crank-rocker")
    opened = open_link(lab, "/?sketch=" + "eJz" + "A" * 50)
    wait_until(lambda: [text for text in notifications_seen(opened) if "sketch" in text], message="the link's notice")
    time.sleep(1.0)  # a second one, if any, would follow at once
    texts = [text for text in notifications_seen(opened) if "sketch" in text]
    assert len(texts) == 1 and "Not applied from the link" in texts[0], notifications_seen(opened)
    # and the status line keeps it after the notification has closed
    opened.page.get_by_text("Not applied from the link: sketch:", exact=False).first.wait_for()
    assert opened.session.design_view.design == Design()
