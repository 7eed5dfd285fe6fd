"""Typed numbers in every box of both panels, in a real page (issue 24).

The mechanism panel's number boxes were the browser's own (beside each slider), which read ``2.5e1`` as 2.51
and ``1,5`` as 15. Now every number of both panels has a box whose text the server reads with one reader
(:func:`app.commands.read_number`). This test finds the boxes on the page itself (every label ``type ...`` of
the control panel, tab by tab, folded folders opened), not from a list that could go stale, and types, as a
person does, ``2.5e1``, ``1e-3``, ``-0``, ``1_000`` and ``1,5`` into each. After each it checks the session's
state: the value in force is the number as written (in the box's units) and the box shows it, or the value in
force is unchanged and one notice names the field and its range (``1,5``: always refused, "not a number").
Every box the session holds must have been reached: the settings boxes that show for one integrator or
stabilisation only (tolerance or fixed step; Baumgarte gains) are reached by choosing those in the page; a
chain box may be left only when the session hides it. The slider's own box only shows the value: it cannot be
typed into.

The chain panel runs on the four-bar (a closed loop: its pin's boxes and the Baumgarte gains apply; the angles
the loop sets are disabled boxes). The mechanism panel runs on two presets: the slider-crank (a free start:
start value and speed boxes, from app/mechanism_start.py) and the geared five-bar (a motor's speed, a gear
pair's ratio and offset, from app/mechanism_edits.py); both have every body's size, mass and inertia, g and the
run's settings.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any, Callable

import pytest

from app import snapshot as snap
from physics import LinkageError

from .conftest import wait_until

TEXTS = ("2.5e1", "1e-3", "-0", "1_000", "1,5")


@dataclass
class Panel:
    """How the test reads one panel: its boxes by label (every box the session holds now), the value in force
    of each in the box's units, the server's box, and how many typed values it has applied or refused."""

    boxes: Callable[[], dict[str, str]]  # the box's label on the page -> the session's name for it
    value: Callable[[str], float]
    box: Callable[[str], Any]
    commits: Callable[[], int]


def _read_as_written(text: str) -> str:
    """How the box shows the number ``text`` means when it is applied (the server's format)."""
    return f"{float(text):.6g}"


def _panel(page):
    return page.page.locator(snap.CONTROL_PANEL)


def _box_input(page, label: str):
    element = _panel(page).locator("label", has_text=re.compile(f"^{re.escape(label)}$")).first
    return element, element.locator("xpath=ancestor::*[.//input][1]").locator("input").first


def _tabs(page) -> list[str]:
    return [text.strip() for text in _panel(page).get_by_role("tab").all_text_contents() if text.strip()]


def _open_tab(page, name: str) -> None:
    _panel(page).get_by_role("tab", name=name, exact=True).first.click()


def _box_labels(page) -> list[str]:
    """The labels of the typed boxes the page holds now (in every folder, folded or not)."""
    texts = _panel(page).locator("label").all_text_contents()
    return list(dict.fromkeys(text.strip() for text in texts if text.strip().startswith("type ")))


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


def _type_every_text(page, session, panel: Panel, label: str, name: str) -> list[str]:
    """Type each of TEXTS into the box ``label`` (the session's ``name``); returns what each did ("applied" or
    the notice). ``field``, the name a refusal must give, is the label without "type " and its unit."""
    field = re.sub(r" \([^()]*\)$", "", label.removeprefix("type "))
    element, box = _box_input(page, label)
    box.scroll_into_view_if_needed()
    outcomes = []
    for text in TEXTS:
        before, value_before = panel.box(name).value, panel.value(name)
        session.notices.clear()
        done = panel.commits()
        unchanged = before == text  # the box shows this text already (a side effect of another box): not sent
        box.fill(text)
        try:
            wait_until(lambda: (panel.commits() > done or unchanged) and box.input_value() == panel.box(name).value,
                       message=f"{label}: {text!r} to be applied or refused and the box to show the value in force")
        except AssertionError as error:
            raise AssertionError(f"{error} (commits {panel.commits() - done}, page {box.input_value()!r}, server "
                                 f"{panel.box(name).value!r}, notice {session.notices.text!r})") from None
        notice = session.notices.text
        shown, value = panel.box(name).value, panel.value(name)
        if notice is None or not notice.startswith("Not applied"):  # applied (the run may stop on it: a notice)
            assert text != "1,5", f"{label}: '1,5' was applied as {value}"
            # the session's state holds the number as written, in the box's units
            assert math.isclose(value, float(text), rel_tol=1e-9, abs_tol=1e-12), (
                f"{label}: typed {text!r}, in force {value!r}")
            assert shown == _read_as_written(text), f"{label}: typed {text!r}, the box shows {shown}"
            outcomes.append("applied")
            if value != value_before:
                try:
                    session.set_typed(name, repr(value_before))  # put back exactly (repr reads back the same float)
                except LinkageError:  # a closed loop moved on to a pose the old size cannot close: from the start
                    session.reset()
                    session.set_typed(name, repr(value_before))
                wait_until(lambda: box.input_value() == before, message=f"{label}: the value put back")
                assert panel.value(name) == value_before, f"{label}: put back as {panel.value(name)!r}"
            if session.player.runs and session.player.runs[0].failed is not None:
                _reset(page, session, panel, name, box)  # a value that stops the run (a huge g) was applied
        else:
            # the field by its label, or by its --set name (a chain's refusals are its command layer's: "g", "L1")
            assert field in notice or re.search(rf"\b{re.escape(name)}\b", notice), (label, text, notice)
            # what is allowed: a range ("d1 (m) = 5: allowed range 0 to 1", both panels) or the condition refused
            # ("give bar 1 a positive I1", "the loop cannot close there (... reachable theta1: ...)"); a decimal
            # comma is no number at all
            allowed = ("<", "allowed", "positive", "finite", "cannot")
            assert ("not a number" in notice) if text == "1,5" else any(word in notice for word in allowed), (
                label, text, notice)
            assert value == value_before, f"{label}: refused {text!r} but the value in force is now {value!r}"
            assert shown == before, f"{label}: refused {text!r} but the box shows {shown}"
            said = notice.removeprefix("Not applied: ")[:40]  # the refusal's own words, whatever names the field
            wait_until(lambda: any(field in refusal or said in refusal for refusal in _refusals(page)),
                       message=f"{label}: the notice for {text!r} in the page")
            # one notice: the one before it (another field's) is replaced, not piled up (it may take a moment to
            # fade out of the page)
            wait_until(lambda: len(_refusals(page)) == 1, timeout_s=10,
                       message=f"{label}: one notice for {text!r}, not {_refusals(page)}")
            outcomes.append(notice)
        assert not session.closed and session.player.alive
    return outcomes


def _reset(page, session, panel: Panel, name: str, box) -> None:
    """Start again after a value that stopped the run. Reset keeps the panel's controls: it built a
    mechanism's again, and a box typed into while its removal was on its way to the page was a box the server
    had dropped (CI: '1,5' after 1000 °/s stopped the geared five-bar was never applied nor refused)."""
    server_box = panel.box(name)
    session.reset()
    assert panel.box(name) is server_box, f"{name}: Reset built the box again"
    wait_until(lambda: box.input_value() == panel.box(name).value, message=f"{name}: the box after Reset")


def _type_into_every_box_shown(page, session, panel: Panel, done: dict[str, list[str]]) -> None:
    """Every tab of the panel, every typed box the page holds there that ``done`` has not: open its folders and
    type TEXTS into it (a disabled box: recorded as such). Boxes that do not show are left for the caller."""
    for tab in _tabs(page):
        _open_tab(page, tab)
        for label in _box_labels(page):
            if label in done:
                continue
            boxes = panel.boxes()
            assert label in boxes, f"a box on the page that the session does not hold: {label!r} ({tab} tab)"
            element, box = _box_input(page, label)
            if not _make_visible(page, element):
                continue
            done[label] = ["disabled"] if box.is_disabled() else _type_every_text(page, session, panel, label,
                                                                                  boxes[label])


def _type_with_each_setting_shown(page, session, panel: Panel, done: dict[str, list[str]], stabilisation_menu: str,
                                  settings) -> None:
    """Type into every box shown, once with the Baumgarte stabilisation (its gains show then) and once with a
    fixed-step integrator (its step shows then; the tolerance with an adaptive one): each chosen in the page, as
    a person does, in either panel (``settings()`` reads the choices in force)."""
    _open_tab(page, "Simulation")
    page.choose(stabilisation_menu, "baumgarte")
    wait_until(lambda: settings().stabilization == "baumgarte", message="the Baumgarte stabilisation")
    _type_into_every_box_shown(page, session, panel, done)
    _open_tab(page, "Simulation")
    page.choose("Integrator", "midpoint")
    wait_until(lambda: settings().integrator == "midpoint", message="the midpoint integrator")
    _type_into_every_box_shown(page, session, panel, done)


def test_every_box_of_the_chain_panel_reads_typed_numbers_as_written(start_lab):
    """The four-bar, a chain preset hosted by the one session (app/session.py): its knobs
    (app/chain_knobs.py), the run's settings and the Display tab's numbers."""
    lab = start_lab(preset="four-bar")  # a closed loop: its pin's boxes and the Baumgarte gains apply
    page = lab.open_page()
    session = page.session
    assert session.chain is not None
    display = session.numbers  # the Display tab's speed, trace length and arrow scale (app/panel_rows.py)

    def value(name: str) -> float:
        if name in display.controls:
            return float(getattr(session.display, name))
        return next(knob.value for knob in session.panel_knobs() if knob.name == name)

    # a closed loop's assembled angles follow it, greyed, with no box (a person cannot type into them either)
    panel = Panel(boxes=lambda: {**{f"type {knob.label}": knob.name for knob in session.panel_knobs()
                                    if not knob.follows},
                                 **{control.box.label: name for name, control in display.controls.items()}},
                  value=value, box=session.typed_box, commits=lambda: session.typed_commits + display.commits)
    done: dict[str, list[str]] = {}
    _type_with_each_setting_shown(page, session, panel, done, "Stabilisation", lambda: session.params)
    hidden = {label for label, name in panel.boxes().items() if not session.typed_box(name).visible}  # not
    # for this preset (a closed loop's driven angles): a person cannot type into them either
    assert set(done) | hidden == set(panel.boxes()), f"boxes never reached: {set(panel.boxes()) - set(done) - hidden}"
    typed = [label for label, outcomes in done.items() if outcomes != ["disabled"]]
    names = {panel.boxes()[label] for label in typed}
    assert {"L1", "d2", "m3", "I1", "theta1", "omega1", "g", "rtol", "step", "baumgarte_alpha", "baumgarte_beta",
            "pin_x", "pin_y"} <= names, names
    assert any("applied" in done[label] for label in typed)  # some texts are numbers these fields take
    g_box = "type gravity g (m/s²)"  # app/chain_knobs.py: the chain panel's slider label
    assert done[g_box][0] == done[g_box][3] == "applied"  # 25 (not 2.51) and 1000 m/s²
    assert all("not a number" in done[label][4] for label in typed)  # 1,5: refused, never 15

    _open_tab(page, "Mechanism")
    slider_box = page.slider("gravity g (m/s²)").locator("xpath=..").locator("input").last
    assert not slider_box.is_editable(), "the slider's own box still takes typing (it reads 2.5e1 as 2.51)"


@pytest.mark.parametrize("preset", ["slider-crank", "geared-five-bar"])
def test_every_box_of_the_mechanism_panel_reads_typed_numbers_as_written(start_lab, preset):
    from app.session import Session

    lab = start_lab(preset=preset)
    page = lab.open_page()
    session = page.session
    assert isinstance(session, Session)

    display = session.numbers  # the Display tab's speed, trace length and arrow scale (app/panel_rows.py)

    def value(name: str) -> float:
        if name in display.controls:
            return float(getattr(session.display, name))
        return next(knob.value for knob in session.panel_knobs() if knob.name == name)

    panel = Panel(boxes=lambda: {**{f"type {knob.label}": knob.name for knob in session.panel_knobs()},
                                 **{control.box.label: name for name, control in display.controls.items()}},
                  value=value, box=session.typed_box, commits=lambda: session.typed_commits + display.commits)
    done: dict[str, list[str]] = {}
    _type_with_each_setting_shown(page, session, panel, done, "Stabilisation", lambda: session.settings)
    assert set(done) == set(panel.boxes()), f"boxes never reached: {set(panel.boxes()) - set(done)}"
    assert "disabled" not in [outcome for outcomes in done.values() for outcome in outcomes]
    names = {panel.boxes()[label]: outcomes for label, outcomes in done.items()}
    assert {"speed", "trace_seconds", "arrow_scale"} <= set(names), names
    assert names["trace_seconds"][0] == "applied"  # 2.5e1 s: 25, as the chain panel's box reads it
    kinds = {name.partition(":")[0] for name in names if name not in display.controls}
    assert {"size", "mass", "inertia", "g", "rtol", "step", "baumgarte_alpha", "baumgarte_beta"} <= kinds, kinds
    if preset == "slider-crank":  # mobility 1, no motor: its start is set by hand
        assert session.free and {"angle0", "omega0"} & kinds and {"omega0", "vx0", "vy0"} & kinds, kinds
    else:
        assert {"ratio", "offset", "speed"} <= kinds, kinds
    # 2.5e1 is 25 (not 2.51); 1_000 is 1000, within the model's bounds as in the chain panel (beyond the slider's)
    assert names["g"][0] == names["g"][3] == "applied"
    assert names[next(name for name in names if name.startswith("mass:"))][3] == "applied"  # 1000 kg, as a chain's
    assert names["rtol"][1] == "applied"  # 1e-3 as written (the browser's box made it -13)
    assert all("not a number" in outcomes[4] for outcomes in names.values())  # 1,5: refused, never 15

    _open_tab(page, "Mechanism")
    slider_box = page.slider("g (m/s²)").locator("xpath=..").locator("input").last
    assert not slider_box.is_editable(), "the slider's own box still takes typing (it reads 2.5e1 as 2.51)"
