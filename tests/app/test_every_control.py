"""A Hypothesis property over every control of both kinds of session: any value a client sends is applied
or refused in one notice line; the session never dies, pauses on an internal error, or logs a traceback.

Each value goes the way a browser's does on viser 1.1 (``_gui_api._handle_gui_updates``): the app's check in
front of viser (:func:`app.viser_compat.update_problem`), viser's cast to the type of the control's value, the
value stored, then every callback of the control (called here in order rather than in viser's thread pool, so
that an example is finished when its assertions run). Controls with a value only: buttons (their value is
always a click) and upload buttons (tests/app/test_security.py) are not drawn.

Seeded (``derandomize``) with a modest count in CI; ``LINKAGE_LAB_CONTROL_EXAMPLES=10000`` for the long run
(docs/reliability.md gives the command).
"""

from __future__ import annotations

import math
import os
import sys
import traceback

import pytest
import viser
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.server import LabServer
from app.session import Session
from app.viser_compat import update_problem
from conftest import BrowserStandIn, wait_until

EXAMPLES = int(os.environ.get("LINKAGE_LAB_CONTROL_EXAMPLES", "40"))
EDIT_LOG = os.environ.get("LINKAGE_LAB_CONTROL_LOG")  # a file: every example's edit appended (to replay a long run)
FATAL = ("Session paused", "Simulation stopped", "Could not start")


def fatal(note: str) -> bool:
    """A notice that means the session died or stopped for a reason of ours. A run that stops because the motion
    reached a singular position is not one: random edits can leave a change-point linkage (a four-bar whose links
    line up on its path, as the change-point preset does on purpose), and the run then stops saying so, the
    session alive and Reset starting again (the long run found one: pin x = 0 after earlier edits)."""
    if note.startswith("Simulation stopped") and ("singular" in note or "too stiff to play" in note):
        return False  # a physical reason, named with its fix (a motion too stiff for an explicit integrator)
    return note.startswith(FATAL)


def state_of(session) -> str:
    """The session's whole setup as a share link's query (a failure found by a long run can be replayed by
    opening it)."""
    try:
        query = session.link_query()
    except Exception as error:  # noqa: BLE001 - a failure's message must not fail itself
        query = f"(no setup: {type(error).__name__}: {error})"
    return f"setup: {query}"


def busy(session, note: str = "") -> str:
    """Why a session is not idle, for a failure's message: what the player was asked and where its thread is
    (a hang must say where it hangs; the long run found one it could not replay)."""
    player = session.player
    frame = sys._current_frames().get(player._thread.ident)  # the test reads the player's thread
    where = "".join(traceback.format_stack(frame)[-12:]) if frame is not None else "(thread gone)"
    return (f"{note}\n{type(session).__name__} not idle: pending={player._pending is not None} "
            f"restarting={player._restarting} restart_time={player._restart_time} "
            f"notice={session.notices.text!r}\n{state_of(session)}\nplayer thread:\n{where}")


def _controls(session) -> list:
    """Every control of the session that carries a value (see the module's docstring)."""
    handles = session.target.gui._gui_input_handle_from_uuid.values()  # the test reads viser's registry
    return sorted((h for h in handles if not isinstance(h, (viser.GuiButtonHandle, viser.GuiUploadButtonHandle))
                   and not h._impl.removed), key=lambda h: h._impl.uuid)


def deliver(session, handle, value) -> str | None:
    """What viser does with a browser's update of ``handle`` to ``value``; the refusal's reason if refused."""
    impl = handle._impl
    problem = update_problem(impl.value, {"value": value})
    if problem is not None:
        session._refuse_update(handle, problem)
        return problem
    current = impl.value
    cast = tuple(type(current[0])(v) for v in value) if isinstance(current, tuple) else type(current)(value)
    if cast == current:
        return None
    impl.value = cast
    for callback in list(impl.update_cb):
        callback(viser.GuiEvent(session.target, session.target.client_id, handle))
    return None


ANYTHING = st.one_of(
    st.none(), st.booleans(), st.text(max_size=12), st.lists(st.integers(), max_size=3),
    st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**30, 10**30),
    st.sampled_from([5e-324, -5e-324, 1e300, -1e300, 1e-300, 0, -0.0, "1e999", "", "<b>x</b>"]),
)
# How a value is made for the control drawn, independent of the session's state (Hypothesis must be able to
# draw the same data again): its own option, a number within its range, just outside it, or anything at all.
PICKS = st.tuples(st.sampled_from(["own", "inside", "outside", "anything"]), st.integers(0, 10**6),
                  st.floats(0.0, 1.0), ANYTHING)


def value_for(handle, pick):
    """A value a hostile client might send to ``handle``: its own options and range, their neighbours, and
    anything else msgpack carries."""
    how, index, fraction, anything = pick
    options = tuple(getattr(handle, "options", ()) or ())
    if how == "own" and options:
        return options[index % len(options)]
    if how in ("own", "inside", "outside") and isinstance(handle, viser.GuiSliderHandle):
        low, high = float(handle.min), float(handle.max)
        if how == "outside":
            return (low - 1.0 - fraction) if index % 2 else (high + 1.0 + fraction)
        return low + fraction * (high - low)
    return anything


@pytest.fixture(scope="module", params=["chain", "mechanism"])
def seat(request):
    """A server and one browser stand-in; the session is looked up afresh (a menu may switch its kind)."""
    server = LabServer(port=0, warm=False, preset="triple-a" if request.param == "chain" else "crank-rocker")
    client = BrowserStandIn(server.url)
    (session,) = server.wait_for_sessions(1, 60)
    assert isinstance(session, Session)  # the one session, for a chain preset too
    assert (session.chain is not None) == (request.param == "chain"), "a chain preset is hosted as a chain"
    assert session.player.wait_idle(60)
    yield server, client, next(iter(server.sessions))
    client.close()
    server.stop()


@settings(max_examples=EXAMPLES, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture,
                                 HealthCheck.data_too_large])
@given(data=st.data())
def test_any_value_to_any_control_is_applied_or_refused_and_the_session_lives(seat, capfd, data):
    server, client, client_id = seat
    session = server.sessions[client_id]
    assert session.player.wait_idle(60), busy(session, "before the example")
    controls = _controls(session)
    handle = controls[data.draw(st.integers(0, 10**6), label="control index") % len(controls)]
    label = handle.label
    value = value_for(handle, data.draw(PICKS, label="value"))
    note = f"{type(session).__name__}: {label} <- {value!r}"
    if EDIT_LOG:
        with open(EDIT_LOG, "a", encoding="utf-8") as log:
            log.write(note + "\n")
    notes: list[str] = []
    show = session.show_notice
    session.show_notice = lambda title, body, **kw: (notes.append(f"{title}: {body}"), show(title, body, **kw))
    try:
        deliver(session, handle, value)
    finally:
        session.show_notice = show
    session = server.sessions[client_id]  # the Mechanism menu may have handed the seat to the other kind
    assert not session.closed and session.player.alive, (note)
    assert session.player.wait_idle(60), busy(session, note)
    assert session.player.error is None, (note, session.player.error)
    assert not [n for n in notes if fatal(n)], (note, notes, state_of(session))
    assert all("\n" not in n.split(": ", 1)[1] for n in notes), notes  # one line each
    err = capfd.readouterr().err
    assert "Traceback" not in err, (note, err[-3000:])


def test_after_the_property_the_seat_still_animates(seat):
    server, client, client_id = seat
    session = server.sessions[client_id]
    # the preset's own values: an edit may legitimately have left a linkage its motor cannot turn (a run that
    # stops with its reason is not a dead session)
    session.guard(session.reset_to_reference)
    assert session.player.wait_idle(60)
    session.guard(session.play)
    start = session.player.display_time
    # the property may have left the playback speed at its least (0.01x): 0.05 s shown takes 5 s
    assert wait_until(lambda: session.player.display_time > start + 0.05, timeout=60), (
        "the seat stopped", type(session).__name__, session.player.playing, session.notices.text,
        [(run.failed, len(run.ring)) for run in session.player.runs])
    assert math.isfinite(session.player.display_time)


def test_every_control_of_the_panel_takes_a_value_in_range_and_refuses_a_hostile_one(seat, capfd):
    """Not a sample: each control of the seat's panel in turn (for the chain seat, every control of a hosted
    chain's panel: its bars' numbers, start, settings, menus, boxes and checkboxes), from the preset's values, is
    sent a value inside its range (a slider's middle, a checkbox flipped) and a hostile one (outside the range,
    markup for a menu or a box); each is applied or refused in one notice line, and the session lives and stays
    the same kind. Controls are told apart by kind and label (Reset builds a mechanism's controls again)."""
    server, client, client_id = seat
    session = server.sessions[client_id]
    kind = session.chain is not None

    def key(handle) -> tuple[str, str]:
        return type(handle).__name__, handle.label

    done: set[tuple[str, str]] = set()
    while True:
        session.guard(session.reset_to_reference)  # each control from the preset's values
        assert session.player.wait_idle(60), busy(session, "reset")
        left = [h for h in _controls(session) if key(h) not in done]
        if not left:
            break
        handle = left[0]
        done.add(key(handle))
        if isinstance(handle, viser.GuiSliderHandle):
            values = [float(handle.min) + 0.5 * (float(handle.max) - float(handle.min)), float(handle.max) + 1.0]
        elif isinstance(handle.value, bool):
            values = [not handle.value, handle.value]
        else:  # a menu keeps its entry (another would leave this panel); a box gets text it must refuse
            values = ["<b>bogus</b>"]
        notes: list[str] = []
        show = session.show_notice
        session.show_notice = lambda title, body, **kw: (notes.append(f"{title}: {body}"), show(title, body, **kw))
        try:
            for value in values:
                note = f"{handle.label} <- {value!r}"
                deliver(session, handle, value)
                assert session.player.wait_idle(60), busy(session, note)
                assert wait_until(lambda: not session.typing(), timeout=10), note
        finally:
            session.show_notice = show
        session = server.sessions[client_id]
        assert (session.chain is not None) == kind, (handle.label, "the seat changed kind")
        assert not session.closed and session.player.alive and session.player.error is None, handle.label
        assert not [n for n in notes if fatal(n)], (handle.label, notes, state_of(session))
        assert all("\n" not in n.split(": ", 1)[1] for n in notes), notes
    generated = {key(h) for h in session._knob_handles.values()}  # noqa: SLF001 - the generated sliders
    assert generated and generated <= done, "a generated control was not reached"
    err = capfd.readouterr().err
    assert "Traceback" not in err, err[-3000:]
