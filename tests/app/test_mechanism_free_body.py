"""The free-body view of a general mechanism (issue 24): every load on the chosen body at the displayed state,
drawn with the chain's arrows; the loads balance the body's motion (Newton's and Euler's laws)."""

from __future__ import annotations

import numpy as np

from app.session import Session
from conftest import lab_of, wait_until
from physics.mechanism.statics import evaluate, free_body

rocker_lab = lab_of("crank-rocker")


def test_the_drawn_loads_are_the_bodys_and_balance_its_motion(rocker_lab, connect):
    _, session = connect(rocker_lab)
    assert isinstance(session, Session)
    assert list(session.body_menu.options) == [body.name for body in session.mechanism.bodies]
    session.guard(lambda: session.set_free_body_body("coupler"))
    session.guard(lambda: session.set_free_body(True))
    view = session.free_body
    assert wait_until(lambda: view.shown_bar == 2 and view.visible() and view.loads is not None, timeout=60)
    loads = view.loads
    assert loads is not None and loads.body == "coupler"
    # a coupler has two pins and its weight: three arrows, labelled with their values, no couple
    assert sorted(f.kind for f in view.shown) == ["gravity", "pin", "pin"]
    assert len(view.labels()) == 3 and all(label.endswith(" N") for label in view.labels())
    balance = loads.as_dict()["balance"]
    weight = loads.mass * session.mechanism.g
    assert balance["force_gap"] < 1e-6 * weight and balance["moment_gap"] < 1e-6 * weight
    # the state drawn is the run's at the sample shown; the loads are physics' own at that state
    ring = session.player.runs[0].ring
    i = ring.index_at(loads.time)
    again = free_body(session.mechanism, evaluate(session.mechanism, ring.get("q", i), ring.get("qdot", i), "dae",
                                                  loads.time), "coupler")
    for drawn, expected in zip(view.shown, [load for load in again.loads if load.at is not None]):
        assert drawn.name == expected.name
        assert np.allclose(drawn.force, expected.force, rtol=1e-9, atol=1e-9 * weight)


def test_a_motors_couple_is_listed_and_the_view_goes_off(rocker_lab, connect):
    _, session = connect(rocker_lab)
    session.guard(lambda: session.set_free_body_body("crank"))
    session.guard(lambda: session.set_free_body(True))
    assert wait_until(lambda: "motor O2" in session.couples.content and "N·m" in session.couples.content,
                      timeout=60)
    assert session.snapshot()["free_body"]["body"] == "crank"
    session.guard(lambda: session.set_free_body_body("no-such-body"))
    assert "body = 'no-such-body': allowed" in (session.notices.text or "")
    session.guard(lambda: session.set_free_body(False))
    assert wait_until(lambda: not session.free_body.visible(), timeout=30)
    assert session.couples.content == "" and session.snapshot()["free_body"] is None


def test_a_sample_shown_again_is_not_solved_again(rocker_lab, connect):
    """Paused, the same sample is shown frame after frame: its diagram stays, computed once (no solve per frame
    on the player's thread)."""
    _, session = connect(rocker_lab)
    session.guard(lambda: session.set_free_body_body("coupler"))
    session.guard(lambda: session.set_free_body(True))
    view = session.free_body
    assert wait_until(lambda: view.visible() and view.loads is not None, timeout=60)
    session.guard(session.pause)
    assert wait_until(lambda: not session.player.playing, timeout=30)
    # a frame on its way when the pause came may still draw the next sample: let it land first
    paused_at = session.frames_sent
    assert wait_until(lambda: session.frames_sent >= paused_at + 2, timeout=60), "no frames while paused"
    frames, solves, shown_t = session.frames_sent, view.solves, view.shown_t
    assert wait_until(lambda: session.frames_sent >= frames + 10, timeout=60), "no frames while paused"
    assert view.shown_t == shown_t and view.visible()
    assert view.solves == solves  # ten frames of the same sample: not one more solve
    session.guard(session.play)
    assert wait_until(lambda: view.solves >= solves + 3 and view.shown_t != shown_t, timeout=60)
