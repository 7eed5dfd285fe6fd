"""Reference pictures of parts of the control panel (not of the scene): made here for the tests and for
regenerate_references.py alike, so both take the same picture the same way.

``report-tab``: the Report tab of preset triple-a, opened as a person would, its contents (the one session's
seed report: the first figure with its verdict; the free-body diagram and rest positions are in its Display tab)
at the panel's own width.
"""

from __future__ import annotations

import time
from typing import Any

from app import snapshot as snap

PANEL_PICTURES = ("report-tab",)
# Tall enough that the whole tab shows without scrolling the panel.
PANEL_VIEWPORT = {"width": 960, "height": 2000}
REPORT_IMAGE = 'img[alt^="Figure 9"]'


def open_report_tab(page: Any) -> None:
    """Click the Report tab and wait until its figure is loaded."""
    page.get_by_role("tab", name="Report", exact=True).click()
    image = page.locator(REPORT_IMAGE).first
    image.wait_for(state="visible")
    page.wait_for_function(f"() => document.querySelector('{REPORT_IMAGE}').complete")


def tab_content(page: Any) -> Any:
    """The open Report tab's contents: the innermost scroll area holding its figure."""
    return page.locator(".mantine-ScrollArea-root", has=page.locator(REPORT_IMAGE)).last


def tab_clip(page: Any) -> dict:
    box = tab_content(page).bounding_box()
    assert box is not None, "the Report tab is not open"
    return {"x": box["x"], "y": box["y"], "width": box["width"], "height": box["height"]}


def report_tab_png(browser: Any) -> bytes:
    """The picture of the Report tab (the session paused at once, so nothing on the page moves)."""
    from app.server import LabServer

    server = LabServer(host="127.0.0.1", port=0, preset="triple-a", warm=False)
    page = None
    try:
        before = set(server.sessions)
        page = snap.goto_app(browser, server.port, viewport=PANEL_VIEWPORT)
        deadline = time.monotonic() + snap.PAGE_TIMEOUT_S
        while not set(server.sessions) - before and time.monotonic() < deadline:
            time.sleep(0.02)
        (client_id,) = set(server.sessions) - before
        server.session_for(client_id).pause()
        snap.wait_until_drawn(page)
        open_report_tab(page)
        return snap.settled_screenshot(page, clip=tab_clip(page))
    finally:
        if page is not None:
            # an open page keeps drawing (and reconnecting) in software WebGL: a core busy for the rest of the suite
            page.context.close()
        server.stop()


def panel_png(name: str, browser: Any) -> bytes:
    """The panel picture called ``name`` (one of :data:`PANEL_PICTURES`)."""
    makers = {"report-tab": report_tab_png}
    return makers[name](browser)
