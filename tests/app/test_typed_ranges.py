"""Both panels' typed boxes take what the models allow, wider than their sliders, and refuse the rest in one
wording (issue 24, "one name per concept"): ``LABEL (UNIT) = VALUE: allowed range LOW to HIGH``."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app import commands
from app.commands import CONTROL, allowed_range
from app.mechanism_edits import (
    MAX_SIZE,
    START_TURN_TYPED,
    apply_edit,
    apply_setting,
    body_size,
    knobs,
    start_knobs,
    start_value,
)
from app.mechanism_runs import MechanismSettings
from app.mechanism_start import free_coordinates
from app.parameters import SessionParameters
from physics import LinkageError
from physics.mechanism import MECHANISM_PRESETS, Driver, assemble
from physics.mechanism.description import MAX_INERTIA


def refusal(action) -> str:
    with pytest.raises(LinkageError) as error:
        action()
    return str(error.value)


@pytest.mark.parametrize("value", ["2000", "-1"])
def test_the_same_field_is_refused_in_the_same_words_by_both_panels(value):
    chain = SessionParameters.from_preset("four-bar")
    mechanism = MECHANISM_PRESETS["crank-rocker"]()
    words = f"g (m/s²) = {float(value):g}: allowed range 0 to 1000"
    assert refusal(lambda: commands.apply(chain, "g", value, units=CONTROL)) == words
    assert refusal(lambda: apply_edit(mechanism, "g", value)) == words


def test_the_words_of_a_range():
    assert allowed_range(0.0, 1000.0) == "0 to 1000"
    assert allowed_range(0.0, 1000.0, low_open=True) == "above 0 up to 1000"
    assert allowed_range(0.0, 1.0, high_open=True) == "from 0 and below 1"
    assert allowed_range(0.0, math.inf) == "0 or more"
    assert allowed_range(-math.inf, 5.0) == "up to 5"
    assert allowed_range(-math.inf, math.inf) == "any finite number"


def test_a_chain_box_names_an_open_bound():
    chain = SessionParameters.from_preset("triple-a")
    assert refusal(lambda: commands.apply(chain, "step", "0", units=CONTROL)) == (
        "step (ms) = 0: allowed range above 0 up to 1000")
    assert refusal(lambda: commands.apply(chain, "d1", "2", units=CONTROL)) == "d1 (m) = 2: allowed range 0 to 1"


def test_a_motor_speed_beyond_its_slider_is_taken_up_to_the_model():
    mechanism = MECHANISM_PRESETS["crank-rocker"]()
    speed = next(k for k in knobs(mechanism) if k.name == "speed:O2")
    assert (speed.low, speed.high) == (-720.0, 720.0)  # the slider
    top = math.degrees(next(item.le for item in Driver.model_fields["speed"].metadata if hasattr(item, "le")))
    assert top == pytest.approx(math.degrees(1e3))
    assert speed.allowed == pytest.approx((-top, top))
    faster = apply_edit(mechanism, "speed:O2", 1500.0)  # past the slider, within what the run follows
    assert faster.drivers[0].speed == pytest.approx(math.radians(1500.0))
    assert speed.slider_bounds(1500.0)[1] == 1500.0  # the slider widens to show it, as the chain's
    assert refusal(lambda: apply_edit(mechanism, "speed:O2", 1e5)) == (
        f"motor O2: speed (°/s) = 100000: allowed range {-top:g} to {top:g}")
    # within the model but faster than the run's samples can follow: refused by the run's check, naming why
    message = refusal(lambda: apply_edit(mechanism, "speed:O2", 50000.0, sample_interval=1 / 60))
    assert message.startswith("motor O2: speed (°/s) = 50000: the mechanism cannot run") and "rad/s" in message


def test_a_torque_and_a_size_beyond_their_sliders():
    mechanism = MECHANISM_PRESETS["crank-rocker"]().model_copy()
    data = mechanism.model_dump()
    data["drivers"] = [{"joint": "O2", "torque": 0.5}]
    torqued = type(mechanism).model_validate(data)
    torque = next(k for k in knobs(torqued) if k.name == "torque:O2")
    assert torque.high < 100 and torque.allowed == (-1e6, 1e6)
    assert apply_edit(torqued, "torque:O2", 100.0).drivers[0].torque == 100.0
    assert refusal(lambda: apply_edit(torqued, "torque:O2", 2e6)) == (
        "motor O2: torque (N·m) = 2e+06: allowed range -1e+06 to 1e+06")
    pendulum = MECHANISM_PRESETS["slider-crank"]()
    size = next(k for k in knobs(pendulum) if k.name == "size:crank")
    assert size.allowed == (0.0, MAX_SIZE) and size.low_open
    assert refusal(lambda: apply_edit(pendulum, "size:crank", 0.0)) == (
        f"crank: size (m) = 0: allowed range above 0 up to {MAX_SIZE:g}")
    assert refusal(lambda: apply_edit(pendulum, "size:crank", 1e300)).endswith(f"up to {MAX_SIZE:g}")
    smaller = apply_edit(pendulum, "size:crank", 0.2 * body_size(pendulum.body("crank")))  # below the slider's 0.25x
    assert body_size(smaller.body("crank")) == pytest.approx(0.2 * body_size(pendulum.body("crank")))


def test_a_start_speed_beyond_its_slider_is_taken_and_an_angle_keeps_one_turn():
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    assembled = assemble(mechanism)
    free = free_coordinates(mechanism, assembled.q, assembled.mobility)
    start = start_knobs(mechanism, free, assembled.q, assembled.q, np.zeros_like(assembled.q))
    assert start_value(start, "omega0:crank", "3000") == pytest.approx(math.radians(3000.0))  # slider: 720
    assert next(k for k in start if k.name == "omega0:crank").allowed == START_TURN_TYPED
    assert refusal(lambda: start_value(start, "omega0:crank", 1e7)).startswith(
        "crank: start angular speed (°/s) = 1e+07: allowed range -572958 to 572958")
    assert refusal(lambda: start_value(start, "angle0:crank", 400)) == (
        "crank: start angle (°) = 400: allowed range -180 to 180")


def test_each_panel_takes_its_models_tolerance():
    chain = SessionParameters.from_preset("triple-a")
    assert commands.apply(chain, "rtol", "0.05", units=CONTROL).params.settings.rtol == 0.05  # Settings: <= 0.1
    assert refusal(lambda: apply_setting(MechanismSettings(), "rtol", 0.05)) == (
        "tolerance rtol = atol = 0.05: allowed range 1e-14 to 0.01")  # a mechanism's run: <= 1e-2 (docs)
    assert apply_setting(MechanismSettings(), "step", 500.0).step == 0.5  # beyond the slider's 100 ms
    assert refusal(lambda: apply_setting(MechanismSettings(), "step", 0.0)) == (
        "fixed step (ms) = 0: allowed range above 0 up to 1000")


def test_a_size_whose_inertia_would_pass_the_models_limit_is_refused_with_the_sizes_range():
    """A size scales its body's inertia by the size squared: past the model's inertia limit the refusal names the
    range of sizes that keeps it, not the model's own words about the inertia."""

    data = MECHANISM_PRESETS["slider-crank"]().model_dump()
    next(body for body in data["bodies"] if body["name"] == "crank")["inertia"] = 1e4  # a heavy flywheel
    mechanism = type(MECHANISM_PRESETS["slider-crank"]()).model_validate(data)
    crank = mechanism.body("crank")
    limit = body_size(crank) * math.sqrt(MAX_INERTIA / crank.inertia)
    assert limit < MAX_SIZE  # inside the size's own range: only the inertia stops it
    message = refusal(lambda: apply_edit(mechanism, "size:crank", 1.01 * limit))
    assert message.startswith(f"crank: size (m) = {1.01 * limit:g}: allowed range above 0 up to {limit:g} (its inertia")
    assert "Input should be" not in message
    bigger = apply_edit(mechanism, "size:crank", 0.99 * limit, sample_interval=None)
    assert bigger.body("crank").inertia == pytest.approx(0.99**2 * MAX_INERTIA)


def test_a_size_typed_then_typed_back_shows_the_value_it_had():
    """Two sizes in a row scale the points twice; the distance comes back within rounding. The control shows a
    size as a person reads it (12 digits), so typing the first value again shows exactly that value."""
    mechanism = MECHANISM_PRESETS["slider-crank"]()

    def shown(m):
        return next(knob.value for knob in knobs(m) if knob.name == "size:crank")

    before = shown(mechanism)
    for other in (1e-3, 25.0):
        back = apply_edit(apply_edit(mechanism, "size:crank", other), "size:crank", before)
        assert shown(back) == before
        assert body_size(back.body("crank")) == pytest.approx(before, rel=1e-12)
