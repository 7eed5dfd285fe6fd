"""From the first paint a browser sees Linkage Lab's loading screen, never viser's bare developer panel; it gives
way to the panel when the session is shown, and to the "full" message for a browser turned away (app/page.py).
"""

from __future__ import annotations

import threading
import time

import pytest

from app import session as session_module
from app import snapshot as snap

pytestmark = pytest.mark.browser

COVERED = """() => {
    const screen = document.getElementById('linkage-lab-loading');
    if (!screen) return 'gone';
    const box = screen.getBoundingClientRect();
    const points = [[0.5, 0.5], [0.9, 0.1], [0.95, 0.3], [0.1, 0.1], [0.5, 0.95]];
    const all = points.every(([x, y]) =>
        screen.contains(document.elementFromPoint(x * innerWidth, y * innerHeight)));
    return all && box.width >= innerWidth && box.height >= innerHeight ? 'covered' : 'partly';
}"""


@pytest.fixture
def slow_sessions(monkeypatch):
    """Sessions that take 3 s to build (as on a busy machine or a cold cache), released by the test."""
    release = threading.Event()
    build = session_module.Session.__init__  # the one session, which every preset opens in

    def slow(self, *args, **kwargs):
        release.wait(3.0)
        build(self, *args, **kwargs)

    monkeypatch.setattr(session_module.Session, "__init__", slow)
    return release


def test_the_loading_screen_covers_the_page_until_the_panel_arrives(start_lab, slow_sessions):
    lab = start_lab(preset="triple-a")
    page = snap.goto_app(lab.browser, lab.port)
    lab.opened.append(page)
    page.wait_for_selector("#linkage-lab-loading", state="attached")
    seen = set()
    deadline = time.monotonic() + 1.5
    while time.monotonic() < deadline:  # the session is still being built: the screen covers everything
        seen.add(page.evaluate(COVERED))
        time.sleep(0.1)
    assert seen == {"covered"}, seen
    assert "Linkage Lab" in page.inner_text("#linkage-lab-loading")
    slow_sessions.set()
    snap.wait_for_panel(page)
    assert page.evaluate(COVERED) == "gone"
    assert page.get_by_text("Playback", exact=True).first.is_visible()


def test_a_browser_turned_away_sees_the_full_message_not_the_loading_screen(start_lab):
    lab = start_lab(preset="single", max_sessions=1)
    first = lab.open_page()
    assert first.session is not None
    page = snap.goto_app(lab.browser, lab.port)
    lab.opened.append(page)
    snap.wait_for_panel(page)
    assert page.get_by_text("Linkage Lab is full").first.is_visible()


def test_on_a_phone_the_panel_starts_folded_and_a_tap_opens_it(start_lab):
    lab = start_lab(preset="single")
    phone = lab.browser.new_context(viewport={"width": 390, "height": 844}, device_scale_factor=1, is_mobile=True,
                                    has_touch=True).new_page()
    lab.opened.append(phone)
    phone.goto(snap.page_url(lab.port))
    snap.wait_until_drawn(phone)
    playback = phone.get_by_text("Playback", exact=True).first
    assert not playback.is_visible(), "the panel covers the scene on a phone"
    phone.get_by_text("Linkage Lab", exact=True).first.click()
    playback.wait_for(state="visible")
    desk = snap.open_app_page(lab.browser, lab.port, {"width": 1400, "height": 850})
    lab.opened.append(desk)
    assert desk.get_by_text("Playback", exact=True).first.is_visible()  # a desk's panel stays open
    thumb = desk.locator(".mantine-Slider-thumb").first.bounding_box()
    assert thumb["width"] >= 15 and thumb["height"] >= 15, thumb  # findable (viser's own: 7 x 11 px)
