"""Both panels' Method menus word a method the same way (issue 24): one labelling, ``app.parameters.method_label``.

The mechanism panel's menu showed the keys (``dae``, ``newton_euler``) while the chain panel's showed words
(``DAE``, ``Newton-Euler``). Now both show the labels; choosing a label runs that method; share links and
snapshots keep the keys (the contract of docs/app.md), and a link's key still sets the method.
"""

from __future__ import annotations

import urllib.parse

import pytest

from app.parameters import METHOD_LABELS, method_from_label, method_label
from app.session import METHODS, Session
from conftest import lab_of, wait_until

crank_lab = lab_of("slider-crank")


def _running(session, method: str) -> bool:
    return wait_until(lambda: bool(session.player.runs) and session.player.runs[0].spec.settings.method == method,
                      timeout=60)


def test_the_label_and_the_key_turn_into_each_other():
    for key in METHOD_LABELS:
        assert method_label(key) != key  # a word, not the key
        assert method_from_label(method_label(key)) == key
    assert method_from_label("no such method") == "no such method"  # left for the session to refuse


def test_both_menus_show_the_same_words_for_the_same_method(lab, crank_lab, connect):
    _, chain = connect(lab)  # a chain preset, hosted by the one session
    _, mechanism = connect(crank_lab)
    assert isinstance(chain, Session) and chain.chain is not None
    assert isinstance(mechanism, Session) and mechanism.chain is None
    chain_options = list(chain.method.options)
    assert not set(chain_options) & set(METHODS), f"keys in the chain's menu: {chain_options}"
    mechanism_options = list(mechanism.method.options)
    assert not set(mechanism_options) & set(METHODS), f"keys in the mechanism's menu: {mechanism_options}"
    # the slider-crank has mobility 1: every method, its fixed-coordinate model named for what it keeps
    assert mechanism_options == [method_label(m, chain=False) for m in METHODS]
    assert mechanism.method.value == method_label(mechanism.settings.method, chain=False)
    assert chain.method.value == method_label(chain.params.method)
    for key in ("dae", "lagrange", "newton_euler"):  # the formulations both panels offer
        assert method_label(key) in chain_options and method_label(key) in mechanism_options, key


@pytest.mark.parametrize("key", ["lagrange", "newton_euler", "reduced", "dae"])
def test_choosing_a_label_in_the_mechanism_menu_runs_that_method(crank_lab, connect, key):
    _, session = connect(crank_lab)
    session.method.value = method_label(key)  # as the browser sends it
    assert session.notices.text is None, session.notices.text
    assert session.settings.method == key
    assert _running(session, key)
    assert session.method.value == method_label(key)  # the menu shows the label in force
    # the link and the snapshot keep the key (docs/app.md)
    assert session.snapshot()["method"] == key
    query = urllib.parse.parse_qs(session.link_query())
    assert query.get("method", ["dae"]) == [key]


def test_a_link_names_the_method_by_its_key_and_the_menu_shows_its_label(crank_lab, connect):
    _, session = connect(crank_lab)
    session.guard(lambda: session.set_link_value("method", "newton_euler"))
    assert session.notices.text is None, session.notices.text
    assert session.settings.method == "newton_euler" and session.method.value == "Newton-Euler"
    assert _running(session, "newton_euler")


def test_a_value_that_is_no_label_is_refused_with_one_notice(crank_lab, connect):
    _, session = connect(crank_lab)
    before = session.settings.method
    session.guard(lambda: session.set_method(str(method_from_label("Symplectic"))))
    assert session.settings.method == before
    assert session.notices.text is not None and "method = 'Symplectic'" in session.notices.text
    assert session.method.value == method_label(before)


def test_choosing_a_label_in_the_chain_menu_runs_that_method(lab, connect):
    _, session = connect(lab)
    session.method.value = method_label("newton_euler")  # as the browser sends it
    assert session.notice is None, session.notice
    assert session.params.method == "newton_euler"
    assert _running(session, "newton_euler")
    assert session.method.value == method_label("newton_euler")  # the menu shows the label in force
