"""Every preset after others in one page (issue 24, "Two app sessions fail at their seam").

Chains and general mechanisms run in the one session (app/session.py; a chain preset hosted), which a
menu choice keeps: the page is never handed to another session. The presets are
those of ``python -m physics presets`` (the chains' table, then the mechanisms'), each of one KIND: an open
chain, a closed chain (a pinned loop), or a mechanism of 3, 4, 5 or 7 bodies (the seam that broke: 3 bodies to
5 or 7). Every ordered pair of all presets is 272 switches, 5 to 20 s each in software rendering on 2 shared
cores: that is the long run (``LINKAGE_LAB_ALL_SWITCHES=1``, docs/reliability.md). By default the test walks
every ordered pair of KINDS (a kind to itself too, where it has two presets) and every preset at least once in
and once out: an Euler circuit of the kinds' complete directed graph, with as many loops on a kind as it needs
to visit each of its presets, taking a kind's presets in turn (37 switches; :func:`kinds_walk`). It chooses each
in the panel's Mechanism menu, as a person would, and after every switch checks that

* the page's session is the one chosen, and it plays on: simulated time advances past its start;
* no error notice (a stopped run, "Simulation stopped", a paused session, an internal error) appears, on the
  page or on the server;
* the panel holds exactly one set of controls, those of the preset shown: one tab group, each tab and each
  folder once, one Mechanism menu, one Timeline, View, Plot, Bodies and motors, Traced point and Stabilisation,
  the typed boxes of exactly this preset's knobs, none of the old chain panel's rows (its initial angles) and,
  on every later visit of a preset, exactly the controls of its first visit (nothing piles up).
"""

from __future__ import annotations

import collections
import os
import re
import time

from app import snapshot as snap
from physics import get_preset, preset_names
from physics.chain_presets import mechanism_summaries
from physics.mechanism import MECHANISM_PRESETS

from .conftest import wait_until

ERROR_TITLES = ("Simulation stopped", "Session paused", "Could not start", "internal error", "Error")
OLD_CHAIN_PANEL = ("Initial angles (degrees)", "Stabilisation (loops)")  # the chain panel's rows: never shown now
# rows the one panel has for every preset (app/session.py _build_panel): exactly one of each
BOTH = ("Timeline (s)", "View", "Plot", "Bodies and motors")
# rows of the other tabs (a page draws only the open tab's rows): exactly one of each there
IN_TABS = {"Simulation": ("Stabilisation",), "Display": ("Traced point",)}
PLAYS_ON_S = 0.3  # simulated seconds a session must advance after its switch


def preset_table() -> list[dict]:
    """The entries ``python -m physics presets`` prints (physics/cli.py, cmd_presets): chains, then mechanisms."""
    return [get_preset(name).summary() for name in preset_names()] + mechanism_summaries()


def kind_of(entry: dict) -> str:
    if entry.get("kind") == "mechanism":
        return f"mechanism of {len(entry['bodies'])} bodies"
    return "closed chain" if entry.get("pin") is not None else "open chain"


def presets_by_kind() -> dict[str, list[str]]:
    kinds: dict[str, list[str]] = {}
    for entry in preset_table():
        kinds.setdefault(kind_of(entry), []).append(entry["name"])
    return kinds


def euler_circuit(names: list[str], loops: dict[str, int] | None = None) -> list[str]:
    """A walk from ``names[0]`` that takes every ordered pair (a, b), a != b, exactly once, and ``loops[a]``
    times the pair (a, a) (Hierholzer)."""
    loops = loops or {}
    unused = {a: [a] * loops.get(a, 0) + [b for b in reversed(names) if b != a] for a in names}
    stack, walk = [names[0]], []
    while stack:
        here = stack[-1]
        if unused[here]:
            stack.append(unused[here].pop())
        else:
            walk.append(stack.pop())
    return walk[::-1]


def kinds_walk(kinds: dict[str, list[str]]) -> list[str]:
    """Presets in the order of an Euler circuit of the kinds (every ordered pair of kinds once; a kind of n >= 2
    presets also to itself, as often as it takes to be left n + 1 times), each visit of a kind taking its next
    preset in turn: every preset is entered and left, every pair of kinds switched between."""
    names = list(kinds)
    loops = {kind: max(len(presets) + 1 - (len(names) - 1), 1) for kind, presets in kinds.items()
             if len(presets) > 1}
    turn = dict.fromkeys(names, 0)
    walk = []
    for kind in euler_circuit(names, loops):
        walk.append(kinds[kind][turn[kind] % len(kinds[kind])])
        turn[kind] += 1
    return walk


def presets_to_walk() -> list[str]:
    if os.environ.get("LINKAGE_LAB_ALL_SWITCHES") == "1":
        names = [entry["name"] for entry in preset_table()]
        return euler_circuit([*MECHANISM_PRESETS, *(n for n in names if n not in MECHANISM_PRESETS)])
    return kinds_walk(presets_by_kind())


def test_the_circuit_takes_every_ordered_pair_once():
    names = ["a", "b", "c", "d"]
    walk = euler_circuit(names)
    pairs = list(zip(walk, walk[1:]))
    assert len(pairs) == len(set(pairs)) == len(names) * (len(names) - 1)


def test_the_walk_takes_every_pair_of_kinds_and_every_preset_in_and_out():
    kinds = presets_by_kind()
    table = [entry["name"] for entry in preset_table()]
    assert sorted(name for presets in kinds.values() for name in presets) == sorted(table)
    assert set(table) == set(preset_names()) | set(MECHANISM_PRESETS)
    assert {"open chain", "closed chain", "mechanism of 3 bodies", "mechanism of 5 bodies",
            "mechanism of 7 bodies"} <= set(kinds)
    walk = kinds_walk(kinds)
    kind = {name: k for k, presets in kinds.items() for name in presets}
    pairs = list(zip(walk, walk[1:]))
    assert all(a != b for a, b in pairs), "a switch to the preset shown is no switch"
    assert {a for a, _ in pairs} == {b for _, b in pairs} == set(table)  # every preset left and entered
    wanted = {(a, b) for a in kinds for b in kinds if a != b or len(kinds[a]) > 1}
    assert {(kind[a], kind[b]) for a, b in pairs} == wanted
    assert len(pairs) <= 40, len(pairs)  # the default run stays a few minutes


def _panel_labels(page) -> collections.Counter:
    """The labels, folder titles and buttons of the control panel that a person sees."""
    # a tab once opened stays in the page, hidden: only the rows drawn (the open tab's and those above the tabs) count
    texts = page.page.locator(snap.CONTROL_PANEL).evaluate(
        """panel => [...panel.querySelectorAll("label, .mantine-Paper-root > .mantine-Paper-root, button")]
               .filter(element => element.checkVisibility()).map(element => element.innerText)""")
    return collections.Counter([t.strip() for t in texts if t.strip()])


def _sets_of_controls(page) -> tuple[int, collections.Counter, collections.Counter]:
    """The panel's tab groups, and how often each tab and each folder title appears in them."""
    panel = page.page.locator(snap.CONTROL_PANEL)
    tabs = panel.get_by_role("tab").all_text_contents()
    titles = panel.locator(".mantine-Paper-root > .mantine-Paper-root").all_text_contents()
    return (panel.get_by_role("tablist").count(), collections.Counter(t.strip() for t in tabs if t.strip()),
            collections.Counter(t.strip() for t in titles if t.strip()))


def _menu_value(page) -> str | None:
    label = page.page.locator(snap.CONTROL_PANEL).locator("label", has_text=re.compile("^Mechanism$")).first
    return page.page.locator(f'[id="{label.get_attribute("for")}"]').input_value()


def _errors(page) -> list[str]:
    return [text for text in page.notification_texts() if any(word in text for word in ERROR_TITLES)]


def _session_shows(session, name: str) -> bool:
    """The one session shows ``name``: a mechanism as itself, a chain preset hosted (``chain``)."""
    if getattr(session, "closed", True):
        return False
    if name in MECHANISM_PRESETS:
        return session.chain is None and session.label == name
    return session.chain is not None and session.chain.preset == name


def test_every_preset_after_every_other_plays_on_with_one_set_of_controls(start_lab, capfd, tmp_path):
    walk = presets_to_walk()
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
        # shows the choice and its panel has the boxes of this preset's controls (a chain's: app/chain_knobs.py)
        wait_until(lambda: _menu_value(page) == name, message=f"{previous} -> {name}: the menu to show {name}")
        # a closed loop's assembled angles follow it, greyed, with no box to type into
        expected = {f"type {knob.label}" for knob in session.mechanism_tab_knobs() if not knob.follows}
        try:
            wait_until(lambda: {label for label in _panel_labels(page) if label.startswith("type ")} == expected,
                       message=f"{previous} -> {name}: the panel to show {name}'s controls")
        except AssertionError as error:
            shown = {label for label in _panel_labels(page) if label.startswith("type ")}
            raise AssertionError(f"{error}: extra {sorted(shown - expected)}, missing {sorted(expected - shown)}") from None
        groups, tabs, folders = _sets_of_controls(page)
        assert groups == 1, f"{previous} -> {name}: {groups} tab groups in the panel"
        assert tabs and max(tabs.values()) == 1, f"{previous} -> {name}: tabs {dict(tabs)}"
        assert not folders or max(folders.values()) == 1, f"{previous} -> {name}: folders {dict(folders)}"
        panel = _panel_labels(page)
        menus = page.page.locator(snap.CONTROL_PANEL).locator("label", has_text=re.compile("^Mechanism$"))
        assert menus.count() == 1, f"{previous} -> {name}: {menus.count()} Mechanism menus in the panel"
        assert not [label for label in OLD_CHAIN_PANEL if panel[label]], (
            f"{previous} -> {name}: the chain panel's rows show: {[lb for lb in OLD_CHAIN_PANEL if panel[lb]]}")
        assert all(panel[label] == 1 for label in BOTH), (
            f"{previous} -> {name}: {[(label, panel[label]) for label in BOTH]} (one of each expected)")
        for tab, rows in IN_TABS.items():
            page.open_tab(tab)
            wait_until(lambda: all(_panel_labels(page)[label] >= 1 for label in rows), timeout_s=20,
                       message=f"{previous} -> {name}: the {tab} tab to show {rows}")
            in_tab = _panel_labels(page)
            assert all(in_tab[label] == 1 for label in rows), (
                f"{previous} -> {name}: {tab} tab {[(label, in_tab[label]) for label in rows]} (one of each expected)")
        page.open_tab("Mechanism")
        wait_until(lambda: _panel_labels(page)["Bodies and motors"] == 1, timeout_s=20,
                   message=f"{previous} -> {name}: the Mechanism tab back")
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
    assert visits == len(walk) - 1
    assert set(seen) == {entry["name"] for entry in preset_table()}  # every preset entered (and so left)
    captured = capfd.readouterr()
    for problem in ("Traceback", "GuiUplotHandle", "IndexError", "expected 9 finite numbers"):
        assert problem not in captured.err, f"the server logged {problem!r}:\n{captured.err[-3000:]}"
    assert re.search(r"\S", page.page.inner_text("body"))
