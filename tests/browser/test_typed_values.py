"""A value typed into a box in a real page reaches the models exactly as typed (issues 13 and 14).

viser's own number box (beside each slider) lets the browser parse the text, and Mantine drops the exponent:
``1e-3`` arrived as ``-13``. The paired text box sends the raw text; the server parses it. This test types into
bar 1's inertia box as a person would, then checks the server's value, the box, and the notice for nonsense.
"""

from __future__ import annotations

import re

from .conftest import wait_until

BOX = "type bar 1: inertia I (kg·m²)"  # the one session's box beside knob I1 (app/chain_knobs.py)
FOLDER = "Bodies and motors"


def _box(app):
    label = app.folder(FOLDER).locator("label", has_text=re.compile(f"^{re.escape(BOX)}$")).first
    # viser gives a text box no id of its own: the input in the label's own row
    box = label.locator("xpath=ancestor::*[.//input][1]").locator("input").first
    box.scroll_into_view_if_needed()
    return box


def test_typing_scientific_notation_and_nonsense_into_the_inertia_box(start_lab):
    lab = start_lab(preset="triple-a")
    app = lab.open_page()
    session = app.session
    app.open_tab("Mechanism")
    box = _box(app)
    assert float(box.input_value()) == session.params.I[0]

    box.fill("1e-3")
    wait_until(lambda: session.params.I[0] == 1e-3, message="I1 = 1e-3 on the server")
    wait_until(lambda: box.input_value() == "0.001", message="the box to show the value in force")
    assert session.notice is None

    box.fill("abc")
    wait_until(lambda: session.notice is not None, message="a notice for 'abc'")
    assert session.notice.startswith("Not applied") and "I1 = 'abc'" in session.notice and "kg·m²" in session.notice
    app.page.locator(".mantine-Notification-root", has_text="I1 = 'abc'").first.wait_for()
    notices = [text for text in app.notification_texts() if "Not applied" in text]
    assert len(notices) == 1, notices
    wait_until(lambda: box.input_value() == "0.001", message="the box to show the value in force again")
    assert session.params.I[0] == 1e-3
    assert not session.closed and session.player.alive
