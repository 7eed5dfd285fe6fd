"""The chain panel's View row and Plot menu on a general mechanism's panel, in a real page (issue 24, "One app
session"; app/panel_rows.py makes them for both panels): shown, the F key presses Front, and each plot is
chosen in the menu without an error in the page's console or its notices."""

from __future__ import annotations

from .conftest import wait_until


def test_the_mechanism_panel_has_the_view_row_and_the_plot_menu(start_lab):
    lab = start_lab(preset="slider-crank")
    page = lab.open_page(pause=False)
    errors: list[str] = []
    page.page.on("console", lambda message: errors.append(message.text) if message.type == "error" else None)
    page.page.on("pageerror", lambda error: errors.append(str(error)))
    session = page.session
    wait_until(lambda: session.player.display_time > 0.5, message="the slider-crank to run")
    session.pause()
    panel_text = page.page.inner_text("body")
    for words in ("View", "Front", "3D", "Plot", "Energy", "Constraint residual (largest |Φ(q)|)",
                  "Relative energy error since last change"):
        assert words in panel_text, words

    page.page.mouse.click(300, 400)  # the scene has the focus, as after looking around
    page.page.keyboard.press("f")
    wait_until(lambda: session.camera.view == "front", message="the F key to press Front")
    page.page.get_by_role("button", name="3D", exact=True).click()
    wait_until(lambda: session.camera.view == "3d", message="the 3D button to turn the camera back")

    page.choose("Plot", "Coordinates over time")
    wait_until(lambda: session.plot_kind == "angles" and session.coordinate_plot.points_shown > 10,
               message="the crank's angle over time to be plotted")
    wait_until(lambda: "crank: angle (°)" in page.page.inner_text("body"), message="the plot's legend in the page")
    page.choose("Plot", "Phase portrait")
    wait_until(lambda: session.plot_kind == "phase" and session.phase_image.visible, message="the phase portrait")
    page.choose("Plot", "Energy")
    wait_until(lambda: session.plot_kind == "energy", message="the energy plot again")
    page.picture("mechanism-panel-rows")
    assert not errors, errors
    assert not [text for text in page.notification_texts() if "Not applied" in text or "paused" in text]
