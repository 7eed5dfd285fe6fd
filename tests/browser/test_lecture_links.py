"""Links in a lecture (issue 26), in real pages: the presenter's page opened with a share link sets up the shared
session, which waits at t = 0, paused; the presenter's Export tab gives the viewers' link and this setup's link,
neither with the secret; a viewer's page opened with a link is told once that the presenter controls the setup."""

from __future__ import annotations

import time

import pytest

from app import snapshot as snap

from .conftest import AppPage, wait_until

pytestmark = pytest.mark.browser

LINK = "preset=double&L1=1.5&theta1=60&method=dae"
TOLD = "The presenter controls the setup"


def _open(lab, url: str, drawn: bool = True) -> AppPage:
    page = lab.browser.new_context(viewport=snap.VIEWPORT, device_scale_factor=1).new_page()
    page.goto(url)
    if drawn:
        snap.wait_until_drawn(page)
    lab.opened.append(page)
    return AppPage(page=page, client_id=-1, lab=lab)


def test_the_presenters_link_sets_up_the_paused_lecture_and_its_links_carry_no_secret(start_lab):
    lab = start_lab(preset="triple-a", shared=True, autoplay=False)
    session = lab.server.shared_session
    secret = lab.server.presenter_path.removeprefix("/presenter-").removesuffix(".html")
    joiner = "&" if "?" in snap.PAGE_QUERY else "?"
    presenter = _open(lab, lab.server.presenter_url + snap.PAGE_QUERY + joiner + LINK)
    wait_until(lambda: session.chain is not None and session.chain.preset == "double"
               and session.settings.method == "dae" and session.chain.chain.bars[0].L == pytest.approx(1.5),
               message="the link's setup applied to the shared session")
    assert session.player.wait_idle(120)
    time.sleep(1.0)
    assert not session.player.playing and session.snapshot()["time"] == 0.0  # waits for the presenter's Play
    wait_until(lambda: "(paused)" in presenter.page.inner_text("body"), message="the status says paused")

    presenter.open_tab("Export")
    presenter.page.get_by_text("Link to this setup").first.click()
    wait_until(lambda: presenter.page.locator("a", has_text="This setup").count() > 0, message="the setup's link")
    hrefs = presenter.page.eval_on_selector_all("a", "links => links.map(a => a.href)")
    viewers = presenter.page.locator("a", has_text="Viewers' link").first.evaluate("a => a.href")
    this_setup = presenter.page.locator("a", has_text="This setup").first.evaluate("a => a.href")
    assert viewers == lab.server.url + "/"
    assert this_setup.startswith(lab.server.url + "/?preset=double") and "method=dae" in this_setup
    for href in hrefs:
        assert secret not in href and "presenter-" not in href, href
    assert secret not in presenter.page.locator(".mantine-Notification-root").all_inner_texts().__str__()


def test_a_viewers_page_with_a_link_is_told_once_and_nothing_is_applied(start_lab):
    lab = start_lab(preset="triple-a", shared=True, autoplay=False)
    session = lab.server.shared_session
    assert session.player.wait_idle(120)
    before = session.setup_pairs()
    joiner = "&" if "?" in snap.PAGE_QUERY else "?"
    viewer = _open(lab, lab.server.url + "/" + snap.PAGE_QUERY + joiner + "preset=four-bar&method=lagrange", drawn=False)
    wait_until(lambda: viewer.page.get_by_text(TOLD).count() > 0, message="the viewer is told")
    time.sleep(1.5)
    assert viewer.page.get_by_text(TOLD).count() == 1
    assert session.setup_pairs() == before and session.label == "triple-a"
