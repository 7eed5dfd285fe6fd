"""A design saved and opened again in Chromium (app/design_view.py, issue 27): the Design tab's TOML button
downloads the design as a mechanism file; after an edit, the same file chosen with "Open a design file" (a real
file chooser) gives back the design saved, and the saved file is the one the design writes."""

from __future__ import annotations

from pathlib import Path

import pytest

from physics.mechanism.design_analysis import design_from_text

from .conftest import wait_until

pytestmark = pytest.mark.browser

VIEWPORT = {"width": 1400, "height": 850}


def test_a_design_downloaded_and_uploaded_again_is_the_same_design(start_lab, tmp_path):
    lab = start_lab(preset="crank-rocker")
    app = lab.open_page(viewport=VIEWPORT)
    view = app.session.design_view
    app.open_tab("Design")
    app.page.get_by_role("button", name="Start from preset", exact=True).click()
    wait_until(lambda: len(view.design.bodies) == 3, message="the crank-rocker opened as a design")
    view.add_ground("extra", (0.2, -0.1))  # an edit of the designer's, so the design is not the preset's
    saved = view.design

    app.page.get_by_role("button", name="TOML", exact=True).click()
    link = app.page.get_by_role("link", name="crank-rocker.toml").first  # viser's download notice: its link
    link.wait_for()
    with app.page.expect_download() as download:
        link.click()
    assert download.value.suggested_filename == "crank-rocker.toml"
    path = tmp_path / download.value.suggested_filename
    download.value.save_as(path)
    content = path.read_bytes()
    assert content == view.save_file("toml")[1] and design_from_text(content.decode(), path.name) == saved

    view.delete("coupler")  # changed after saving
    assert view.design != saved
    with app.page.expect_file_chooser() as chooser:
        app.page.get_by_role("button", name="Open a design file (TOML or JSON)").click()
    chooser.value.set_files(str(Path(path)))
    wait_until(lambda: view.design == saved, message="the uploaded file opened as the design saved")
    assert app.session.notices.serial == 0, app.session.notices.text
