"""Design mode in a lecture (``--shared`` with a presenter; app/design_view.py, issue 27), in Chromium: the
presenter's page opens the preset as a design and drags a ground pivot with the mouse; a viewer's page shows the
design's topology and sees the drawing change; the viewer's own drag of a point and click in the plane change
nothing (the server refuses them with a notice)."""

from __future__ import annotations

import numpy as np
import pytest

from app import snapshot as snap

from . import pictures
from .conftest import AppPage, wait_until

pytestmark = pytest.mark.browser


def _open(lab, url: str) -> AppPage:
    page = lab.browser.new_context(viewport=snap.VIEWPORT, device_scale_factor=1).new_page()
    page.set_default_timeout(snap.PAGE_TIMEOUT_S * 1000)
    page.goto(url + snap.PAGE_QUERY)
    snap.wait_until_drawn(page)
    lab.opened.append(page)
    return AppPage(page=page, client_id=-1, lab=lab)


def on_page(app: AppPage, xy) -> list[float]:
    (point,) = snap.project_world_points(app.page, "/linkage", [[float(xy[0]), 0.0, float(xy[1])]])
    return point


def drag(app: AppPage, from_xy, to_xy) -> None:
    mouse = app.page.mouse
    mouse.move(*on_page(app, from_xy))
    mouse.down()
    mouse.move(*on_page(app, to_xy), steps=12)
    mouse.up()


def scene_picture(app: AppPage) -> np.ndarray:
    return pictures.decode_png(app.page.screenshot())


def test_the_presenter_designs_while_a_viewer_watches_and_cannot_edit(start_lab):
    lab = start_lab(preset="crank-rocker", shared=True)
    session = lab.server.shared_session
    session.pause()
    view = session.design_view
    viewer = _open(lab, lab.server.url + "/")
    presenter = _open(lab, lab.server.presenter_url)

    presenter.open_tab("Design")
    presenter.page.get_by_role("button", name="Start from preset", exact=True).click()
    wait_until(lambda: len(view.design.bodies) == 3, message="the preset opened as a design")
    presenter.page.get_by_text("Design in the scene", exact=True).click()
    wait_until(lambda: view.on and session.camera.view == "front", message="the presenter designing")
    viewer.open_tab("Design")
    viewer.page.get_by_text("3 bodies, 4 joints, 1 loop: mobility 1", exact=False).wait_for()
    for page in (presenter, viewer):
        snap.wait_for_drawn_frames(page.page)
    presenter.page.wait_for_timeout(800)  # the camera's move to the front view arrives and is drawn
    before = scene_picture(viewer)

    # the presenter drags the second ground pivot: one edit, and the viewer's drawing changes with it
    pivot = [name for name, _ in view.design.ground][-1]
    start = view.design.point(f"ground.{pivot}")
    edits = len(view.history.done)
    drag(presenter, start, (start[0] + 0.03, start[1]))
    wait_until(lambda: len(view.history.done) == edits + 1, message="the presenter's drag applied")
    moved = view.design
    assert moved.point(f"ground.{pivot}") != start

    def viewer_changed() -> bool:
        return int(np.count_nonzero(np.any(scene_picture(viewer) != before, axis=2))) > 50

    wait_until(viewer_changed, message="the viewer's page drew the design moved")

    # the viewer drags the same pivot back, then clicks with the presenter's Ground pivot tool: nothing changes
    serial = session.notices.serial
    drag(viewer, moved.point(f"ground.{pivot}"), start)
    wait_until(lambda: session.notices.serial > serial, message="the viewer's drag refused")
    assert "presenter controls" in session.notices.text
    presenter.choose("Tool", "Ground pivot")
    wait_until(lambda: view.tool == "Ground pivot", message="the presenter's tool chosen")
    serial = session.notices.serial
    viewer.page.mouse.click(*on_page(viewer, (0.1, -0.1)))
    wait_until(lambda: session.notices.serial > serial, message="the viewer's click refused")
    assert "presenter controls" in session.notices.text
    assert view.design == moved and len(view.history.done) == edits + 1
