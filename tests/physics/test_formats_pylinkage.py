"""pylinkage's JSON both ways, checked with pylinkage itself (the optional extra `pylinkage`; CI installs it with
the test extra): a four-bar and a slider-crank made and saved by pylinkage are read by `python -m physics export
--pylinkage` and follow pylinkage's own `step()` positions over a crank turn; ours written by `--format
pylinkage` are read back by pylinkage, whose `step()` follows our position analysis."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from physics.cli import main
from physics.mechanism import MECHANISM_PRESETS
from physics.mechanism.assembly import track
from physics.mechanism.constraints import Constraints
from physics.mechanism.files import load_mechanism
from physics.mechanism.pylinkage_format import LINE_DENSITY, STEP_SECONDS

pylinkage_mechanism = pytest.importorskip(
    "pylinkage.mechanism", reason="pylinkage is not installed (pip install -e '.[pylinkage]'; CI installs it)")

AGREEMENT = 1e-9  # m: both sides solve the same closed-form dyads (measured: 4e-13 m and below)


def point_path(mechanism, reference: str, times) -> np.ndarray:
    """Where ``body.point`` is at each time, from our position analysis (the branch followed from the sketch)."""
    body, point = reference.split(".")
    constraints = Constraints(mechanism)
    k = [b.name for b in mechanism.bodies].index(body)
    return np.array([constraints.body_point(q, k, mechanism.body(body).points[point]) for q in track(mechanism, times)])


def pylinkage_four_bar(initial_angle: float = 0.4):
    """A crank-rocker (crank 0.1, coupler 0.35, rocker 0.25, ground 0.3 m) with a coupler point, built with
    pylinkage's low-level API: ground joints, revolute joints, a tracker, a driver link."""
    made = pylinkage_mechanism.fourbar(crank=0.1, coupler=0.35, rocker=0.25, ground=0.3, initial_angle=initial_angle)
    position = {joint.id: joint.position for joint in made.joints}
    o1 = pylinkage_mechanism.GroundJoint("O1", position=position["crank.motor_ground.A"])
    o2 = pylinkage_mechanism.GroundJoint("O2", position=position["ground.D_rocker.1"])
    a = pylinkage_mechanism.RevoluteJoint("A", position=position["coupler.0_crank.tip"])
    b = pylinkage_mechanism.RevoluteJoint("B", position=position["coupler.1_rocker.0"])
    tracker = pylinkage_mechanism.TrackerJoint("P", position=(0.0, 0.0), ref_joint1_id="A", ref_joint2_id="B",
                                               distance=0.2, angle=0.5)
    tracker.update_position(a.position, b.position)
    ground = pylinkage_mechanism.GroundLink("ground", joints=[o1, o2])
    crank = pylinkage_mechanism.DriverLink("crank", joints=[o1, a], motor_joint=o1, angular_velocity=math.tau / 100,
                                           initial_angle=initial_angle)
    coupler = pylinkage_mechanism.Link("coupler", joints=[a, b])
    rocker = pylinkage_mechanism.Link("rocker", joints=[b, o2])
    return pylinkage_mechanism.Mechanism(name="four-bar", joints=[o1, o2, a, b, tracker],
                                         links=[ground, crank, coupler, rocker], ground=ground)


def import_through_cli(made, tmp_path, capsys):
    """pylinkage's own file of ``made``, read by `python -m physics export --pylinkage` into our TOML."""
    source = tmp_path / "made.pylinkage.json"
    pylinkage_mechanism.mechanism_to_json(made, source)
    out = tmp_path / "made.toml"
    assert main(["export", "--pylinkage", str(source), "--format", "toml", "--out", str(out)]) == 0
    notes = capsys.readouterr().err
    assert notes.count("1 kg/m") == 1  # the density note, printed once
    return load_mechanism(out)


def test_a_pylinkage_four_bar_follows_pylinkages_own_steps(tmp_path, capsys):
    made = pylinkage_four_bar()
    period = made.get_rotation_period()
    ids = [joint.id for joint in made.joints]
    steps = np.array(list(made.step(iterations=period)), dtype=float)  # (steps, joints, 2)
    mechanism = import_through_cli(pylinkage_four_bar(), tmp_path, capsys)
    assert mechanism.trace == "coupler.P"
    assert [driver.speed for driver in mechanism.drivers] == [pytest.approx(math.tau / 100 / STEP_SECONDS)]
    times = np.arange(1, period + 1) * STEP_SECONDS  # pylinkage's step k is our time k * STEP_SECONDS
    coupler_point = point_path(mechanism, "coupler.P", times)
    assert np.max(np.linalg.norm(coupler_point - steps[:, ids.index("P")], axis=1)) < AGREEMENT
    assert np.max(np.linalg.norm(point_path(mechanism, "coupler.B", times) - steps[:, ids.index("B")], axis=1)) < AGREEMENT
    assert np.ptp(coupler_point[:, 0]) > 0.1  # a real coupler curve, not a point standing still
    # masses from the stated line density: each two-joint link a uniform bar
    for body, length in (("crank", 0.1), ("coupler", 0.35), ("rocker", 0.25)):
        assert mechanism.body(body).mass == pytest.approx(LINE_DENSITY * length, rel=1e-12)
        assert mechanism.body(body).inertia == pytest.approx(LINE_DENSITY * length**3 / 12, rel=1e-12)


def test_a_pylinkage_slider_crank_follows_pylinkages_own_steps(tmp_path, capsys):
    made = pylinkage_mechanism.slider_crank(crank=0.1, rod=0.3, initial_angle=0.5)
    ids = [joint.id for joint in made.joints]
    period = made.get_rotation_period()
    steps = np.array(list(made.step(iterations=period)), dtype=float)
    mechanism = import_through_cli(pylinkage_mechanism.slider_crank(crank=0.1, rod=0.3, initial_angle=0.5),
                                   tmp_path, capsys)
    times = np.arange(1, period + 1) * STEP_SECONDS
    piston = point_path(mechanism, "rod.rod_1", times)  # pylinkage's prismatic joint "rod.1", on the rod
    assert np.max(np.linalg.norm(piston - steps[:, ids.index("rod.1")], axis=1)) < AGREEMENT
    assert np.ptp(piston[:, 0]) == pytest.approx(0.2, rel=1e-3)  # the stroke, twice the crank
    assert np.max(np.abs(piston[:, 1])) < 1e-12  # on the slot


@pytest.mark.parametrize("preset, traced", [("crank-rocker", "coupler.P"), ("jansen-leg", "foot.F"),
                                            ("chebyshev-lambda", "coupler.P")])
def test_ours_read_back_by_pylinkage_follows_our_position_analysis(preset, traced, tmp_path, capsys):
    out = tmp_path / f"{preset}.json"
    assert main(["export", "--preset", preset, "--format", "pylinkage", "--out", str(out)]) == 0
    assert "no masses" in capsys.readouterr().err
    read = pylinkage_mechanism.mechanism_from_json(out)
    mechanism = MECHANISM_PRESETS[preset]()
    assert len(read.links) == len(mechanism.bodies) + 1  # every body, and the ground
    period = round(math.tau / abs(mechanism.drivers[0].speed) / STEP_SECONDS)
    ids = [joint.id for joint in read.joints]
    steps = np.array(list(read.step(iterations=period)), dtype=float)
    ours = point_path(mechanism, traced, np.arange(1, period + 1) * STEP_SECONDS)
    theirs = steps[:, ids.index(traced.split(".")[1])]  # a point no pin uses: a tracker named after it
    assert np.max(np.linalg.norm(ours - theirs, axis=1)) < AGREEMENT
    assert np.ptp(ours[:, 0]) > 0.1


def test_a_round_trip_through_pylinkage_keeps_the_geometry_and_the_motor(tmp_path, capsys):
    out = tmp_path / "cr.json"
    assert main(["export", "--preset", "crank-rocker", "--format", "pylinkage", "--out", str(out)]) == 0
    again = tmp_path / "cr.pylinkage.json"
    pylinkage_mechanism.mechanism_to_json(pylinkage_mechanism.mechanism_from_json(out), again)  # saved by pylinkage
    back_file = tmp_path / "cr.toml"
    assert main(["export", "--pylinkage", str(again), "--format", "toml", "--out", str(back_file)]) == 0
    back, original = load_mechanism(back_file), MECHANISM_PRESETS["crank-rocker"]()
    assert back.drivers[0].speed == pytest.approx(original.drivers[0].speed, rel=1e-12)
    assert back.trace == original.trace
    for body in original.bodies:
        for name, xy in body.points.items():
            assert back.body(body.name).points[name] == pytest.approx(xy, abs=1e-12)
    assert json.loads(out.read_text())["links"][1]["type"] == "driver"
