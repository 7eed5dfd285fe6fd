"""The command layer (app/commands.py): every field applied through the models, refused with its name and range.

No server here: edits are applied to ``SessionParameters`` directly, as a session does. The session-level half
(typed boxes, notices, a session that stays alive) is in test_typed_values.py.
"""

from __future__ import annotations

import inspect
import math
import os
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import physics
from app import commands
from app.commands import CONTROL, SI
from app.number_inputs import NumbersPort
from app.parameters import Display, SessionParameters
from app.session import Session

settings.register_profile("app-ci", max_examples=60, deadline=None, derandomize=True,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("app-long", max_examples=2000, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_APP_PROFILE", "app-ci"))


@pytest.fixture(scope="module")
def triple():
    return SessionParameters.from_preset("triple-a")


@pytest.fixture(scope="module")
def four_bar():
    return SessionParameters.from_preset("four-bar")


# name, value (control units), how to read it back (SI), expected SI, a refused value, words of the refusal
VALID_AND_REFUSED = [
    ("L2", "0.7", lambda p: p.L[1], 0.7, "-1", "L2 (m) = -1: allowed range 0 to 1000"),
    ("d1", "0.25", lambda p: p.d[0], 0.25, "2", "d1 (m) = 2: allowed range 0 to 1"),
    ("m3", "2.5", lambda p: p.m[2], 2.5, "-0.5", "m3 (kg) = -0.5: allowed range 0 to 1e+06"),
    ("I1", "1e-3", lambda p: p.I[0], 1e-3, "-1e-3", "I1 (kg·m²) = -0.001: allowed range 0 to 1e+12"),
    ("g", "9.81", lambda p: p.g, 9.81, "-9.81", "g (m/s²) = -9.81: allowed range 0 to 1000"),
    ("g", "9.81", lambda p: p.g, 9.81, "1e6", "g (m/s²) = 1e+06: allowed range 0 to 1000"),
    ("theta1", "45", lambda p: p.theta0[0], math.radians(45), "abc", "theta1 = 'abc': not a number"),
    ("omega2", "90", lambda p: p.omega0[1], math.radians(90), "inf", "omega2 = inf: must be a finite number"),
    ("rtol", "1e-6", lambda p: p.settings.rtol, 1e-6, "0.5", "rtol = 0.5: allowed range 1e-14 to 0.1"),
    ("step", "2.5", lambda p: p.step, 2.5e-3, "0", "step (ms) = 0: allowed range above 0 up to 1000"),
    ("baumgarte_alpha", "20", lambda p: p.baumgarte_alpha, 20.0, "1e5", "baumgarte_alpha (1/s) = 100000: allowed range 0 to 10000"),
    ("baumgarte_beta", "5", lambda p: p.baumgarte_beta, 5.0, "-1", "baumgarte_beta (1/s) = -1: allowed range 0 to 10000"),
    ("damping", "0.3", lambda p: p.damping, 0.3, "2e3", "damping (N·m·s) = 2000: allowed range 0 to 1000"),
]


@pytest.mark.parametrize("name, text, read, expected, refused, words", VALID_AND_REFUSED,
                         ids=[f"{row[0]}-{row[4]}" for row in VALID_AND_REFUSED])
def test_each_field_is_applied_and_refused_with_its_name_and_range(triple, name, text, read, expected, refused, words):
    edit = commands.apply(triple, name, text, units=CONTROL)
    assert read(edit.params) == pytest.approx(expected, rel=1e-12)
    edit.params.validate()  # the result is a valid whole, not only a valid field
    with pytest.raises(physics.LinkageError) as refusal:
        commands.apply(triple, name, refused, units=CONTROL)
    assert words in str(refusal.value)
    assert read(triple) != pytest.approx(expected) or name == "rtol"  # the original is untouched


@pytest.mark.parametrize("name, text, expected, refused, words", [
    ("speed", "2", 2.0, "100", "speed (×) = 100: allowed range 0.01 to 8"),
    ("trace_seconds", "12.5", 12.5, "-1", "trace_seconds (s) = -1: allowed range 0 to 30"),
    ("arrow_scale", "1e-2", 0.01, "0", "arrow_scale = 0: allowed range above 0 up to 10"),
])
def test_display_settings_go_through_their_model(name, text, expected, refused, words):
    display = commands.apply_display(Display(), name, text, units=CONTROL)
    assert getattr(display, name) == pytest.approx(expected)
    with pytest.raises(physics.LinkageError) as refusal:
        commands.apply_display(Display(), name, refused, units=CONTROL)
    assert words in str(refusal.value)


def test_scientific_notation_is_a_number_not_a_string_of_digits(triple):
    """What viser's number box gets wrong (1e-3 -> -13, 1e6 -> 16): parsed here, exactly."""
    assert commands.apply(triple, "I2", "1e-3", units=CONTROL).params.I[1] == 1e-3
    assert commands.apply(triple, "g", "1e1", units=CONTROL).params.g == 10.0
    assert commands.apply(triple, "g", " 2.5 ", units=CONTROL).params.g == 2.5
    minus = "\u2212"  # the minus sign a phone keyboard may type
    assert commands.apply(triple, "theta1", f"{minus}30", units=CONTROL).params.theta0[0] == pytest.approx(-math.pi / 6)


def test_empty_nan_and_words_are_refused_by_name(triple):
    for text, words in (("", "I1: the box is empty"), ("NaN", "must be a finite number"), ("abc", "not a number"),
                        ("1" * 100, "is not a number")):
        with pytest.raises(physics.LinkageError) as refusal:
            commands.apply(triple, "I1", text, units=CONTROL)
        assert words in str(refusal.value) and "I1" in str(refusal.value)


def test_units_si_and_control(triple):
    assert commands.apply(triple, "theta1", 0.5).params.theta0[0] == 0.5  # SI: radians, as --set
    assert commands.apply(triple, "theta1", 90, units=CONTROL).params.theta0[0] == pytest.approx(math.pi / 2)
    assert commands.apply(triple, "step", 0.002).params.step == 0.002
    assert commands.apply(triple, "step", 2, units=CONTROL).params.step == pytest.approx(0.002)


def test_a_longer_bar_keeps_its_centre_of_mass_and_a_shorter_one_pulls_it_in(triple):
    shorter = commands.apply(triple, "L1", 0.3)
    assert shorter.geometry and not shorter.restart
    assert shorter.params.L[0] == 0.3 and shorter.params.d[0] == 0.3
    longer = commands.apply(triple, "L1", 2.0)
    assert longer.params.d[0] == triple.d[0]


def test_a_bar_without_inertia_is_refused_naming_it(triple):
    no_inertia = commands.apply(triple, "I3", 0.0).params
    with pytest.raises(physics.LinkageError, match="bar 3"):
        commands.apply(no_inertia, "m3", 0.0)


def test_closed_loop_angles_pin_and_lengths_keep_it_closed(four_bar):
    with pytest.raises(physics.LinkageError) as refusal:
        commands.apply(four_bar, "theta1", 60, units=CONTROL)
    text = str(refusal.value)
    assert "cannot close" in text and "reachable theta1: 89.4° round to 6.0°" in text and "rad" not in text
    assert text.count("cannot close") == 1  # said once
    with pytest.raises(physics.LinkageError, match="takes only theta1"):
        commands.apply(four_bar, "theta2", 10, units=CONTROL)
    for name, value in (("theta1", math.radians(150)), ("pin_x", 1.2), ("L1", 0.2)):
        p = commands.apply(four_bar, name, value).params
        gap = physics.loop_closure.loop_residual(p.L, p.theta0, p.pin)
        assert np.hypot(*gap) < 1e-9, name


def test_pin_on_an_open_chain_is_refused(triple):
    with pytest.raises(physics.LinkageError, match="open chain"):
        commands.apply(triple, "pin_x", 1.0)


@pytest.mark.parametrize("name, good, bad", [
    ("method", "dae", "euler"),
    ("integrator", "RK45", "Bogus"),
    ("stabilization", "baumgarte", "<b>x</b>"),
    ("trace", "joint 1", "nowhere"),
])
def test_choices_offer_the_model_literals(triple, name, good, bad):
    commands.apply(triple, name, good)
    with pytest.raises(physics.LinkageError) as refusal:
        commands.apply(triple, name, bad)
    assert repr(bad) in str(refusal.value) and "allowed" in str(refusal.value)


def test_a_radau_run_switches_the_backend_back_for_a_compiled_integrator(triple):
    radau = commands.apply(triple, "integrator", "Radau").params
    assert radau.settings.backend == "scipy"
    assert commands.apply(radau, "integrator", "DOP853").params.settings.backend == "compiled"


def test_the_names_are_the_clis(triple):
    """Every name ``python -m physics --set`` accepts for a chain is a name of the command layer."""
    for name in physics.model.parameter_names(triple.n):
        commands.apply(triple, name, getattr(triple, "L")[0] if name[0] == "L" else 0.5)
    with pytest.raises(physics.LinkageError, match="unknown parameter 'nonsense'"):
        commands.apply(triple, "nonsense", 1)


NAMES = [row[0] for row in VALID_AND_REFUSED] + ["L1", "m1", "pin_x", "method", "integrator", "trace", "theta3"]
VALUES = st.one_of(
    st.text(max_size=30),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-10**30, max_value=10**30),
    st.none(), st.booleans(), st.lists(st.integers(), max_size=3),
    st.sampled_from(["1e-3", "1e6", "-0", "1e308", "1e-320", "NaN", "", " ", "0x10", "1_0", "٣"]),
)


@given(name=st.sampled_from(NAMES), value=VALUES, units=st.sampled_from([SI, CONTROL]))
def test_any_value_is_applied_validly_or_refused_with_one_line(triple, name, value, units):
    """The property of the boundary: a valid result, or one LinkageError line naming the field; nothing else."""
    try:
        edit = commands.apply(triple, name, value, units=units)
    except physics.LinkageError as error:
        text = str(error)
        assert "\n" not in text and (name in text or "traced point" in text), text
        return
    edit.params.validate()
    assert edit.params.n == triple.n


def test_the_session_offers_every_member_of_the_port_and_the_numbers_use_nothing_else():
    """The panel's numbers depend on app.number_inputs.NumbersPort, not on the session's player, scene or target."""
    members = {name for name in vars(NumbersPort) if not name.startswith("_")}
    members |= set(getattr(NumbersPort, "__annotations__", {}))
    assert {"closed", "guard", "set", "set_typed"} <= members
    instance = {"closed"}  # a plain attribute, set when a session is made
    missing = sorted(name for name in members - instance if not hasattr(Session, name))
    assert missing == []
    assert "self.closed = " in inspect.getsource(Session.__init__)
    app = Path(__file__).resolve().parents[2] / "app"
    for module in ("number_inputs.py", "panel_rows.py"):
        text = (app / module).read_text()
        assert not re.search(r"\.(params|player|target)\b", text), module


@given(name=st.one_of(st.text(max_size=12), st.integers(), st.none(), st.lists(st.text(max_size=2), max_size=2)),
       value=st.one_of(st.floats(), st.text(max_size=8)))
def test_any_name_is_a_known_field_or_one_line_saying_which_are(triple, name, value):
    try:
        edit = commands.apply(triple, name, value)
    except physics.LinkageError as error:
        assert "\n" not in str(error) and str(error)
        return
    edit.params.validate()


@pytest.mark.parametrize("value, expected", [("3", 3), (" 12 ", 12), (1, 1), ("7.0", 7), ("1e1", 10)])
def test_links_are_whole_numbers_in_range(value, expected):
    assert commands.parse_links(value) == expected


@pytest.mark.parametrize("value", ["0", "13", "3.5", "abc", "", "nan", "inf", True, None, [3]])
def test_bad_links_are_refused_with_the_field_and_the_range(value):
    with pytest.raises(physics.LinkageError, match=r"^links"):
        commands.parse_links(value)
