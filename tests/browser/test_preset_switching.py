"""Every preset after every other in one page (issue 24, "Two app sessions fail at their seam").

Chains and general mechanisms run as two kinds of session that hand the page to each other. This test walks one
route through every ordered pair of presets (an Euler circuit of the complete directed graph: chain to chain,
chain to mechanism, mechanism to chain, mechanism to mechanism, 3 bodies to 5 or 7 and back) in one browser,
choosing each in the panel's Mechanism menu as a person would, and after every switch checks that

* the page's session is the one chosen, and it plays on: simulated time advances past its start;
* no error notice (a stopped run, a paused session, an internal error) appears, on the page or on the server;
* the panel holds the controls of the session shown, once: one Mechanism menu, one Timeline, none of the other
  kind's rows (the chain's View and Plot; the mechanism's Bodies and motors) and, on every later visit of a
  preset, exactly the controls of its first visit (nothing piles up).
"""

from __future__ import annotations

import collections
import os
import re
import time

from app import snapshot as snap
from physics import preset_names
from physics.mechanism import MECHANISM_PRESETS

from .conftest import wait_until

ERROR_TITLES = ("Simulation stopped", "Session paused", "Could not start", "internal error", "Error")
CHAIN_ONLY = ("View", "Plot")
BOTH = ("Timeline (s)",)  # a row both panels have: exactly one, whichever is shown
MECHANISM_ONLY = ("Bodies and motors", "Traced point", "Stabilisation")
PLAYS_ON_S = 0.3  # simulated seconds a session must advance after its switch
# Every ordered pair of all 16 presets is 240 switches, 5 to 20 s each in software rendering: the long run
# (LINKAGE_LAB_ALL_SWITCHES=1, docs/reliability.md). By default the circuit takes every ordered pair of a set
# that holds each kind of seam: mechanisms of 3, 5 and 7 bodies, an open chain, a closed four-bar and a chain of
# another length (30 switches).
DEFAULT_PRESETS = ("slider-crank", "watt-six-bar", "jansen-leg", "triple-a", "four-bar", "double")


def presets_to_walk() -> list[str]:
    if os.environ.get("LINKAGE_LAB_ALL_SWITCHES") == "1":
        return list(MECHANISM_PRESETS) + list(preset_names())  # the mechanisms' own pairs come first
    missing = [name for name in DEFAULT_PRESETS if name not in MECHANISM_PRESETS and name not in preset_names()]
    assert not missing, missing
    return list(DEFAULT_PRESETS)


def euler_circuit(names: list[str]) -> list[str]:
    """A walk from ``names[0]`` that takes every ordered pair (a, b), a != b, exactly once (Hierholzer)."""
    unused = {a: [b for b in reversed(names) if b != a] for a in names}
    stack, walk = [names[0]], []
    while stack:
        here = stack[-1]
        if unused[here]:
            stack.append(unused[here].pop())
        else:
            walk.append(stack.pop())
    return walk[::-1]


def test_the_circuit_takes_every_ordered_pair_once():
    names = ["a", "b", "c", "d"]
    walk = euler_circuit(names)
    pairs = list(zip(walk, walk[1:]))
    assert len(pairs) == len(set(pairs)) == len(names) * (len(names) - 1)


def _panel_labels(page) -> collections.Counter:
    """The labels and folder titles of the control panel (every row a person sees)."""
    panel = page.page.locator(snap.CONTROL_PANEL)
    labels = panel.locator("label").all_inner_texts()
    titles = panel.locator(".mantine-Paper-root > .mantine-Paper-root").all_inner_texts()
    buttons = panel.locator("button").all_inner_texts()
    return collections.Counter([t.strip() for t in labels + titles + buttons if t.strip()])


def _menu_value(page) -> str | None:
    label = page.page.locator(snap.CONTROL_PANEL).locator("label", has_text=re.compile("^Mechanism$")).first
    return page.page.locator(f'[id="{label.get_attribute("for")}"]').input_value()


def _errors(page) -> list[str]:
    return [text for text in page.notification_texts() if any(word in text for word in ERROR_TITLES)]


def _session_shows(session, name: str) -> bool:
    if getattr(session, "closed", True):
        return False
    if name in MECHANISM_PRESETS:
        return getattr(session, "label", None) == name
    return getattr(getattr(session, "params", None), "preset", None) == name


def test_every_preset_after_every_other_plays_on_with_one_set_of_controls(start_lab, capfd, tmp_path):
    names = presets_to_walk()
    walk = euler_circuit(names)
    lab = start_lab(preset=walk[0])
    page = lab.open_page(pause=False)
    client_id = page.client_id
    seen: dict[str, collections.Counter] = {}
    visits = 0
    for previous, name in zip(walk, walk[1:]):
        started = time.monotonic()
        page.choose("Mechanism", name)
        chosen = time.monotonic()
        wait_until(lambda: _session_shows(lab.server.session_for(client_id), name),
                   message=f"{previous} -> {name}: the page's session to show {name}")
        session = lab.server.session_for(client_id)
        if hasattr(session, "play") and not session.player.playing:
            session.play()
        start = session.player.display_time
        shown = time.monotonic()
        wait_until(lambda: session.player.display_time > start + PLAYS_ON_S or session.player.error is not None
                   or _errors(page),
                   message=f"{previous} -> {name}: simulated time to advance")
        played = time.monotonic()
        assert session.player.error is None, f"{previous} -> {name}: {session.player.error}"
        assert not _errors(page), f"{previous} -> {name}: {_errors(page)}"
        assert session.notices.text is None or not session.notices.text.startswith(ERROR_TITLES), (
            previous, name, session.notices.text)
        # the page has caught up with the switch (a busy software renderer lags behind the server): its menu
        # shows the choice and, for a mechanism, its panel has the boxes of this mechanism's controls
        wait_until(lambda: _menu_value(page) == name, message=f"{previous} -> {name}: the menu to show {name}")
        if name in MECHANISM_PRESETS:
            expected = {f"type {knob.label}" for knob in session.mechanism_tab_knobs()}
            wait_until(lambda: {label for label in _panel_labels(page) if label.startswith("type ")} == expected,
                       message=f"{previous} -> {name}: the panel to show {name}'s controls")
        panel = _panel_labels(page)
        menus = page.page.locator(snap.CONTROL_PANEL).locator("label", has_text=re.compile("^Mechanism$"))
        assert menus.count() == 1, f"{previous} -> {name}: {menus.count()} Mechanism menus in the panel"
        wrong = MECHANISM_ONLY if name not in MECHANISM_PRESETS else CHAIN_ONLY
        assert not [label for label in wrong if panel[label]], (
            f"{previous} -> {name}: the other panel's rows stay: {[label for label in wrong if panel[label]]}")
        assert all(panel[label] == 1 for label in BOTH), (
            f"{previous} -> {name}: {[(label, panel[label]) for label in BOTH]} (one of each expected)")
        if name in seen:
            try:
                wait_until(lambda: _panel_labels(page) == seen[name], timeout_s=20, message="the panel")
            except AssertionError:
                pass
            panel = _panel_labels(page)
            assert panel == seen[name], (
                f"{previous} -> {name}: the panel differs from the first visit: extra "
                f"{dict(panel - seen[name])}, missing {dict(seen[name] - panel)}")
        else:
            seen[name] = panel
        visits += 1
        with open(tmp_path / "switches.txt", "a") as log:  # how long each took, for a person watching a slow run
            print(f"{visits:3d} {previous:>20} -> {name:<20} {time.monotonic() - started:5.1f} s (menu {chosen - started:4.1f}, session "
                  f"{shown - chosen:4.1f}, playing {played - shown:4.1f})", file=log)
    assert visits == len(names) * (len(names) - 1)
    assert set(seen) == set(names)
    captured = capfd.readouterr()
    for problem in ("Traceback", "GuiUplotHandle", "IndexError", "expected 9 finite numbers"):
        assert problem not in captured.err, f"the server logged {problem!r}:\n{captured.err[-3000:]}"
    assert re.search(r"\S", page.page.inner_text("body"))
