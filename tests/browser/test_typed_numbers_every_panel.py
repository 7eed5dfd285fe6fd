"""Typed numbers in every box of both panels, in a real page (issue 24).

The mechanism panel's number boxes were the browser's own (beside each slider), which read ``2.5e1`` as 2.51
and ``1,5`` as 15. Now every number of both panels has a box whose text the server reads: this test types, as a
person does, ``2.5e1``, ``1e-3``, ``-0``, ``1_000`` and ``1,5`` into every enabled box of the chain panel (every
tab, every folder) and of a mechanism panel, and checks after each that the value in force is the number as
written, or that it was refused with one notice naming the field and its range (``1,5``: always refused, "not a
number"). The slider's own box only shows the value: it cannot be typed into.
"""

from __future__ import annotations

import re

from app import snapshot as snap

from .conftest import wait_until

TEXTS = ("2.5e1", "1e-3", "-0", "1_000", "1,5")
CHAIN_TABS = ("Mechanism", "Simulation", "Display")


def _read_as_written(text: str) -> str:
    """How the box shows the number ``text`` means when it is applied (the server's format)."""
    return f"{float(text):.6g}"


def _box_input(page, label: str):
    element = page.page.locator(snap.CONTROL_PANEL).locator(
        "label", has_text=re.compile(f"^{re.escape(label)}$")).first
    return element, element.locator("xpath=ancestor::*[.//input][1]").locator("input").first


def _make_visible(page, label_element) -> bool:
    """Open the folders around ``label_element`` (folded ones hide their rows); True when it shows."""
    for _ in range(3):
        if label_element.is_visible():
            return True
        folders = label_element.locator("xpath=ancestor::div[contains(@class, 'mantine-Paper-root')]")
        for k in range(folders.count() - 1, -1, -1):
            heading = folders.nth(k).locator(":scope > .mantine-Paper-root").first
            if heading.count() and heading.is_visible():
                heading.click()
                if label_element.is_visible():
                    return True
    return label_element.is_visible()


def _refusals(page) -> list[str]:
    return [text for text in page.notification_texts() if "Not applied" in text]


def _type_every_text(page, session, label: str, field: str, server_box, commits, restore) -> list[str]:
    """Type each of TEXTS into the box ``label`` (``field``: the name a refusal must give; ``commits()``: how
    many typed values the panel has applied or refused); returns what each did ("applied" or the notice)."""
    element, box = _box_input(page, label)
    box.scroll_into_view_if_needed()
    outcomes = []
    for text in TEXTS:
        before = server_box().value
        session.notices.clear()
        done = commits()
        unchanged = before == text  # the box shows this text already (a side effect of another box): not sent
        box.fill(text)
        try:
            wait_until(lambda: (commits() > done or unchanged) and box.input_value() == server_box().value,
                       message=f"{label}: {text!r} to be applied or refused and the box to show the value in force")
        except AssertionError as error:
            raise AssertionError(f"{error} (commits {commits() - done}, page {box.input_value()!r}, server "
                                 f"{server_box().value!r}, notice {session.notices.text!r})") from None
        notice = session.notices.text
        shown = server_box().value
        if notice is None or not notice.startswith("Not applied"):  # applied (the run may stop on it: a notice)
            assert text != "1,5", f"{label}: '1,5' was applied as {shown}"
            assert shown == _read_as_written(text), f"{label}: typed {text!r}, in force {shown}"
            outcomes.append("applied")
            if shown != before:
                restore(before)
                wait_until(lambda: box.input_value() == before, message=f"{label}: the value put back")
            if session.player.runs and session.player.runs[0].failed is not None:
                session.reset()  # a value that stops the run (a huge g) was applied: start again
        else:
            assert notice.startswith("Not applied") and field in notice, (label, text, notice)
            # what is allowed: a range ("0 <= d1 <= 1 m", "allowed range 0 to 30") or the condition refused
            # ("give bar 1 a positive I1"); a decimal comma is no number at all
            allowed = ("<", "allowed", "positive", "finite")
            assert ("not a number" in notice) if text == "1,5" else any(word in notice for word in allowed), (
                label, text, notice)
            assert shown == before, f"{label}: refused {text!r} but the value in force changed to {shown}"
            wait_until(lambda: any(field in refusal for refusal in _refusals(page)),
                       message=f"{label}: the notice for {text!r} in the page")
            # one notice: the one before it (another field's) is replaced, not piled up (it may take a moment to
            # fade out of the page)
            wait_until(lambda: len(_refusals(page)) == 1, timeout_s=10,
                       message=f"{label}: one notice for {text!r}, not {_refusals(page)}")
            outcomes.append(notice)
        assert not session.closed and session.player.alive
    return outcomes


def test_every_box_of_the_chain_panel_reads_typed_numbers_as_written(start_lab):
    lab = start_lab(preset="single")
    page = lab.open_page()
    session = page.session
    numbers = session.controls.numbers
    done: dict[str, list[str]] = {}
    for tab in CHAIN_TABS:
        page.open_tab(tab)
        for name, control in numbers.controls.items():
            label = control.box.label
            element, box = _box_input(page, label)
            if name in done or not _make_visible(page, element):
                continue
            if box.is_disabled():
                done[name] = ["disabled"]
                continue
            done[name] = _type_every_text(
                page, session, label, name, lambda name=name: numbers.controls[name].box,
                lambda: numbers.commits, lambda text, name=name: session.set_typed(name, text))
    hidden = {name for name, control in numbers.controls.items() if not control.box.visible}  # not for this
    # preset's settings (a fixed step for an adaptive integrator): a person cannot type into them either
    assert set(done) | hidden == set(numbers.controls), f"boxes never reached: {set(numbers.controls) - set(done)}"
    typed = [name for name, outcomes in done.items() if outcomes != ["disabled"]]
    assert len(typed) >= 10, done
    assert any("applied" in done[name] for name in typed)  # some texts are numbers these fields take

    page.open_tab("Mechanism")
    slider_box = page.slider("gravity g (m/s²)").locator("xpath=..").locator("input").last
    assert not slider_box.is_editable(), "the slider's own box still takes typing (it reads 2.5e1 as 2.51)"


def test_every_box_of_the_mechanism_panel_reads_typed_numbers_as_written(start_lab):
    from app.mechanism_edits import knobs
    from app.mechanism_session import MechanismSession

    lab = start_lab(preset="crank-rocker")
    page = lab.open_page()
    session = page.session
    assert isinstance(session, MechanismSession)
    done: dict[str, list[str]] = {}
    for knob in knobs(session.mechanism, session.reference):
        label = f"type {knob.label}"
        element, _ = _box_input(page, label)
        assert _make_visible(page, element), f"{label} is not in the panel"
        done[knob.name] = _type_every_text(
            page, session, label, knob.label, lambda name=knob.name: session.typed_box(name),
            lambda: session.typed_commits, lambda text, name=knob.name: session.set_typed(name, text))
    assert {"g", "speed:O2", "mass:crank"} <= set(done)
    assert done["g"][0] == "applied" and session.mechanism.g != 2.51  # 2.5e1 is 25, applied, then put back
    assert "applied" in done["speed:O2"]

    slider_box = page.slider("g (m/s²)").locator("xpath=..").locator("input").last
    assert not slider_box.is_editable(), "the slider's own box still takes typing (it reads 2.5e1 as 2.51)"
