"""Keyboard shortcuts and dark mode in a real page (static/page.html): Space play/pause, R reset, S step, F front
view, each pressing the panel's own button; keys typed into a box stay the box's; dark mode when the browser
prefers it."""

from __future__ import annotations

import pytest

from app import snapshot as snap

from .conftest import wait_until

pytestmark = pytest.mark.browser


def test_space_r_s_and_f_drive_the_session(start_lab):
    lab = start_lab(preset="triple-a")
    app = lab.open_page()  # paused
    session = app.session
    keyboard = app.page.keyboard
    app.page.mouse.click(300, 400)  # the scene has the focus, as after looking around
    session.pause()  # the first start may still have been on its way when the page was opened
    app.page.get_by_text("(paused)").first.wait_for()

    keyboard.press(" ")
    wait_until(lambda: session.player.playing, message="Space plays")
    wait_until(lambda: session.snapshot()["time"] > 0.3, message="time goes on")
    app.page.get_by_text("(playing)").first.wait_for()  # what a person sees before pressing again
    keyboard.press(" ")
    wait_until(lambda: not session.player.playing, message="Space pauses")

    t = session.snapshot()["time"]
    keyboard.press("s")
    wait_until(lambda: session.snapshot()["time"] > t, message="S steps")
    assert not session.player.playing

    keyboard.press("r")
    wait_until(lambda: session.snapshot()["time"] == 0.0, message="R resets")

    assert session.camera.view == "3d"
    keyboard.press("f")
    wait_until(lambda: session.camera.view == "front", message="F shows the front view")


def test_a_key_typed_into_a_box_is_the_boxs(start_lab):
    lab = start_lab(preset="triple-a")
    app = lab.open_page()
    session = app.session
    session.pause()
    app.page.get_by_text("(paused)").first.wait_for()
    app.open_tab("Mechanism")
    box = app.page.get_by_role("textbox").first
    box.click()
    for key in (" ", "f", "s"):
        box.press(key)
    app.page.wait_for_timeout(1000)
    assert not session.player.playing and session.camera.view == "3d"


def test_dark_mode_follows_the_browser(start_lab):
    lab = start_lab(preset="single")
    pages = {}
    for scheme in ("dark", "light"):
        page = lab.browser.new_context(viewport=snap.VIEWPORT, color_scheme=scheme).new_page()
        page.goto(snap.page_url(lab.port))
        snap.wait_until_drawn(page)
        lab.opened.append(page)
        pages[scheme] = page.evaluate("document.documentElement.getAttribute('data-mantine-color-scheme')")
    assert pages == {"dark": "dark", "light": "light"}
