"""A lecture with --shared in real pages: the presenter's page changes the session; a viewer's page shows the
controls read-only with a line saying who controls, and even a key pressed on a viewer's slider changes nothing
(the server refuses it and puts the slider back)."""

from __future__ import annotations

import pytest

from app import snapshot as snap
from app.server import VIEWER_LINE

from .conftest import AppPage, wait_until

pytestmark = pytest.mark.browser

GRAVITY = "gravity g (m/s²)"
POINTER = "element => getComputedStyle(element).pointerEvents"


def _open(lab, url: str) -> AppPage:
    page = lab.browser.new_context(viewport=snap.VIEWPORT, device_scale_factor=1).new_page()
    page.goto(url + snap.PAGE_QUERY)
    snap.wait_until_drawn(page)
    lab.opened.append(page)
    return AppPage(page=page, client_id=-1, lab=lab)


def test_only_the_presenters_page_changes_the_shared_session(start_lab):
    lab = start_lab(preset="triple-a", shared=True)
    session = lab.server.shared_session
    session.pause()
    viewer = _open(lab, lab.server.url + "/")
    presenter = _open(lab, lab.server.presenter_url)
    g0 = session.params.chain.g

    viewer_line = VIEWER_LINE.split("**")[1]
    # the panels arrive after the first drawing: wait for them (a loaded machine), then assert
    wait_until(lambda: viewer.page.get_by_text(viewer_line).count() > 0
               and viewer.page.get_by_text(viewer_line).first.is_visible(), message="the viewer's line")
    wait_until(lambda: viewer.slider(GRAVITY).evaluate(POINTER) == "none", message="the viewer's slider locked")
    assert presenter.page.get_by_text(viewer_line).count() == 0
    assert presenter.slider(GRAVITY).evaluate(POINTER) != "none"

    viewer.press_on_slider(GRAVITY, "ArrowRight", times=4)  # the keyboard reaches a slider the mouse cannot
    wait_until(lambda: viewer.page.get_by_text("The presenter controls this session").count() > 0,
               message="the viewer is told who controls")
    wait_until(lambda: viewer.slider_value(GRAVITY) == pytest.approx(g0), message="the viewer's slider put back")
    assert session.params.chain.g == g0

    presenter.press_on_slider(GRAVITY, "ArrowRight", times=4)
    # every press is its own update: wait until the session holds the presenter's last one (under load the first
    # may be applied while the others are still on their way)
    wait_until(lambda: session.params.chain.g > g0
               and session.params.chain.g == pytest.approx(presenter.slider_value(GRAVITY)),
               message="the presenter's change applied")
    g1 = session.params.chain.g
    wait_until(lambda: viewer.slider_value(GRAVITY) == pytest.approx(g1), message="the viewer sees the new value")
