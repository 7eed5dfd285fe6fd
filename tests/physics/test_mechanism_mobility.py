"""Mobility stated both ways (issue 28): the linkage's own (the textbook's Grübler-Kutzbach count and the rank count),
then its motors and what they leave free. ``mobility`` and ``grubler_mobility`` of ``mechanism --json`` keep their
meaning (after the motors); ``mechanism_mobility`` and ``motors`` are the counts before them."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from physics.mechanism import MECHANISM_PRESETS
from physics.mechanism.assembly import assemble, mobility_text_for
from physics.mechanism.description import Driver


def cli(*args):
    result = subprocess.run([sys.executable, "-m", "physics", "mechanism", *args], capture_output=True, text=True,
                            timeout=300)
    assert result.returncode == 0, result.stderr
    return result.stdout


# Textbook counts written out: 3 (B - 1) - 2 J - G with the ground among the B links, J pins and sliders, G gear
# pairs (each couples two pins' angles: one more constraint).
TEXTBOOK = {"crank-rocker": 3 * 3 - 2 * 4, "jansen-leg": 3 * 7 - 2 * 10, "slider-crank": 3 * 3 - 2 * 4,
            "geared-five-bar": 3 * 4 - 2 * 5 - 1}


@pytest.mark.parametrize("name, first_line", [
    ("crank-rocker", "crank-rocker: 3 bodies, 4 joints; mobility 1 (Grübler count 1); driven by 1 motor; 0 free"),
    ("jansen-leg", "jansen-leg: 7 bodies, 10 joints; mobility 1 (Grübler count 1); driven by 1 motor; 0 free"),
    ("slider-crank", "slider-crank: 3 bodies, 4 joints; mobility 1 (Grübler count 1); no motor; 1 free"),
    ("geared-five-bar",
     "geared-five-bar: 4 bodies, 6 joints; mobility 1 (Grübler count 1); driven by 1 motor; 0 free"),
])
def test_the_text_states_the_mechanism_then_its_motors(name, first_line):
    assert cli("--preset", name).splitlines()[0] == first_line
    assert f"mobility {TEXTBOOK[name]} " in first_line


@pytest.mark.parametrize("name", sorted(TEXTBOOK))
def test_json_keeps_the_counts_after_the_motors_and_adds_those_before(name):
    report = json.loads(cli("--preset", name, "--json"))
    mechanism = MECHANISM_PRESETS[name]()
    speed_motors = sum(1 for d in mechanism.drivers if d.speed is not None)
    assert report["mechanism_mobility"] == TEXTBOOK[name]
    assert report["motors"] == len(mechanism.drivers)
    # the old keys: what the motors leave free (0 for a driven crank-rocker, as scripts expect)
    assert report["mobility"] == report["grubler_mobility"] == TEXTBOOK[name] - speed_motors
    assert report["mobility_text"].endswith(f"; {report['mobility']} free")


def test_a_torque_motor_fixes_no_coordinate():
    rocker = MECHANISM_PRESETS["crank-rocker"]()
    joint = rocker.drivers[0].joint
    driven_by_torque = rocker.model_copy(update={"drivers": [Driver(joint=joint, torque=0.5)]})
    assembled = assemble(driven_by_torque)
    assert (assembled.mobility, assembled.mechanism_mobility, assembled.torque_motors) == (1, 1, 1)
    text = assembled.mobility_text()
    assert text == "mobility 1 (Grübler count 1); driven by 1 torque motor (a torque fixes no coordinate); 1 free"
    assert mobility_text_for(driven_by_torque, assembled.mobility) == text
