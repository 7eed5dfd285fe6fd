"""Typed values on a live session: parsed by the project, checked by the models, one notice, never a dead session.

The boxes are driven by assigning ``box.value`` on the server, which runs the same callback as a keystroke in
the browser; the value is applied once typing pauses (app/number_inputs.py).
"""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.number_inputs import shown
from conftest import BrowserStandIn, wait_until


def type_into(session, name: str, text: str) -> None:
    session.typed_box(name).value = text
    assert wait_until(lambda: not session.typing(), timeout=10)


def sliders(session) -> dict:
    """Every slider of the panel with a typed box, by its name: the generated controls (the chain's numbers, its
    start, the run's settings) and the Display tab's numbers."""
    # the generated controls' sliders; a closed chain's assembled angles are shown greyed, with no box
    out = {name: handle for name, handle in session._knob_handles.items() if not handle.disabled}  # noqa: SLF001
    out.update({name: number.slider for name, number in session.numbers.controls.items()})
    return out


def assert_alive(session) -> None:
    assert not session.closed and session.player.alive
    assert session.notice is None or not session.notice.startswith("Session paused"), session.notice


# name, a good text, what it means in SI, a refused text, words the notice must hold
FIELDS = [
    ("I1", "1e-3", lambda p: p.I[0], 1e-3, "-1e-3", ["I1 (kg·m²) = -0.001", "allowed range 0 to 1e+12"]),
    ("m2", "2", lambda p: p.m[1], 2.0, "-2", ["m2 (kg) = -2", "allowed range 0 to 1e+06"]),
    ("L3", "0.8", lambda p: p.L[2], 0.8, "abc", ["L3 = 'abc'", "not a number", "in m"]),
    ("d1", "0.2", lambda p: p.d[0], 0.2, "5", ["d1 (m) = 5", "allowed range 0 to 1"]),
    ("g", "1e1", lambda p: p.g, 10.0, "", ["g: the box is empty", "m/s²"]),
    ("theta2", "30", lambda p: p.theta0[1], math.radians(30), "NaN", ["theta2", "finite"]),
    ("rtol", "1e-7", lambda p: p.tolerance, 1e-7, "1", ["rtol = 1", "allowed range 1e-14 to 0.1"]),
    ("damping", "0.1", lambda p: p.damping, 0.1, "-1", ["damping (N·m·s) = -1", "allowed range 0 to 1000"]),
]


def test_every_box_applies_a_good_value_and_refuses_a_bad_one_naming_field_and_range(connect):
    _, session = connect()
    for name, good, read, expected, bad, words in FIELDS:
        type_into(session, name, good)
        assert read(session.params) == pytest.approx(expected, rel=1e-12), name
        assert session.typed_box(name).value == shown(name, read(session.params))
        type_into(session, name, bad)
        assert read(session.params) == pytest.approx(expected, rel=1e-12), f"{name}: a refused value was applied"
        assert session.notice is not None and session.notice.startswith("Not applied"), (name, session.notice)
        for word in words:
            assert word in session.notice, (name, word, session.notice)
        # the box shows the value in force again, not what was typed
        assert session.typed_box(name).value == shown(name, read(session.params))
        assert_alive(session)
    session.play()
    t0 = session.snapshot()["time"]
    assert wait_until(lambda: session.snapshot()["time"] > t0 + 0.2)  # still running


def test_a_slider_and_its_box_show_the_same_value(connect):
    _, session = connect()
    mass = session._knob_handles["m1"]  # noqa: SLF001 - bar 1's mass slider
    mass.value = 2.5
    assert session.params.m[0] == 2.5
    assert session.typed_box("m1").value == "2.5"
    type_into(session, "m1", "4.75")  # beyond the slider's step grid, inside the model's bounds
    assert mass.value == pytest.approx(4.75)
    type_into(session, "g", "50")  # beyond the slider's useful range: the slider widens to show it
    gravity = session._knob_handles["g"]  # noqa: SLF001
    assert session.params.g == 50.0 and gravity.value == 50.0 and gravity.max >= 50


def test_the_same_refusal_is_one_notification_not_a_pile(connect):
    client, session = connect()
    before = len(client.counts.notifications)
    for _ in range(8):  # a slider dragged through a refused range sends one value per step
        session.guard(lambda: session.set("m1", -1.0))
    assert wait_until(lambda: len(client.counts.notifications) > before, timeout=10)
    assert len(session.notices._handles) == 1
    shown_titles = [title for _, title in client.counts.notifications[before:]]
    assert shown_titles.count("Not applied") == 1, shown_titles


@settings(max_examples=25, deadline=None, derandomize=True)
@given(name=st.sampled_from(["I1", "g", "theta1", "rtol", "step", "speed", "trace_seconds", "arrow_scale", "L2"]),
       text=st.one_of(st.text(max_size=20), st.floats().map(repr), st.sampled_from(["1e-3", "1e6", "-0", "1e999"])))
def test_generated_text_in_a_box_never_pauses_or_kills_the_session(session_for_fuzz, name, text):
    session = session_for_fuzz
    session.guard(lambda: session.set_typed(name, text))
    assert_alive(session)
    session.params.validate()


@pytest.fixture(scope="module")
def session_for_fuzz(lab):
    """One session for all generated examples (a fixture per example would open a browser each time)."""
    before = set(lab.sessions)
    client = BrowserStandIn(lab.url)
    assert wait_until(lambda: set(lab.sessions) - before, timeout=30)
    (client_id,) = set(lab.sessions) - before
    session = lab.sessions[client_id]
    assert session.player.wait_idle(60)
    session.pause()
    yield session
    client.close()


HOSTILE_NUMBERS = (float("nan"), float("inf"), float("-inf"), 1e308, -1e308)
HOSTILE_TEXTS = ("abc", "", "NaN", "1e999", "<img src=x onerror=alert(1)>", "[1, 2]", "None", "0x1p3")


def test_hostile_values_on_every_control_give_notices_and_never_pause_the_session(connect):
    """What a hostile websocket client can make viser hand to the callbacks (viser casts a slider's value to
    float, a box's or a dropdown's to str): every one is refused with a notice, the session keeps going."""
    _, session = connect()
    titles: list[str] = []
    show = session.show_notice
    session.show_notice = lambda title, body, **kw: (titles.append(title), show(title, body, **kw))
    for name, slider in list(sliders(session).items()):
        if slider.disabled:
            continue
        for value in HOSTILE_NUMBERS:
            slider.value = value
        for text in HOSTILE_TEXTS:
            session.guard(lambda name=name, text=text: session.set_typed(name, text))  # what the box's pause runs
    session.transport.value = "Bogus"
    session.analysis.count_dropdown.value = "bogus"
    for dropdown in (session.method, session.integrator, session.stabilization, session.trace_menu, session.menu,
                     session.plot_choice, session.body_menu):
        dropdown.value = "<b>bogus</b>"
    # "Simulation stopped": a value the models accept (L, g, omega have no upper bound) but no run survives;
    # that run stops with a notice saying why. Never "Session paused" (an error of the app itself).
    assert titles and "Not applied" in titles and set(titles) <= {"Not applied", "Simulation stopped"}, titles
    assert_alive(session)
    session.params.validate()
    session.set_mechanism("triple-a")  # a fresh start after the barrage
    session.play()
    t0 = session.snapshot()["time"]
    assert wait_until(lambda: session.snapshot()["time"] > t0 + 0.2)


def test_every_number_of_the_panel_names_its_unit(connect):
    _, session = connect()
    session.set_mechanism("four-bar")  # a closed loop: the pin's controls too
    dimensionless = {"rtol", "arrow_scale"}
    units = ("(m)", "(kg)", "(kg·m²)", "(m/s²)", "(°", "(ms", "(s)", "(N·m·s)", "(1/s)", "(×)")
    numbers = sliders(session)
    assert {"g", "I1", "theta1", "pin_x", "step", "speed"} <= set(numbers)
    for name, slider in numbers.items():
        if name in dimensionless:
            continue
        box = session.typed_box(name)
        assert any(unit in slider.label for unit in units), (name, slider.label)
        assert any(unit in box.label for unit in units), (name, box.label)
