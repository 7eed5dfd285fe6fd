"""MJCF through MuJoCo (the optional extra `mjcf`; CI installs it with the test extra): files written by `python -m
physics export --format mjcf` load in MuJoCo with our masses, centres of mass and inertias, and a 1 s MuJoCo run
puts every named point where our own run does.

Agreement: an open chain has no constraint, so MuJoCo's RK4 at 1e-4 s and our DOP853 at 1e-10 differ by
integration error only (measured 2.4e-13 m on the triple pendulum). A loop is closed in MuJoCo by a soft point
constraint whose time constant is two steps (2e-4 s here): measured over 1 s, 2.5e-10 m (the four-bar, 2 m
across, g = 1), 1.0e-7 m (the slider-crank, 0.3 m), 1.4e-7 m (the slider-crank with a torque motor and
damping), 7.4e-8 m (Watt's six-bar, 1 m); the bound is 2e-6 of the mechanism's size, a few times the worst.
MuJoCo's default constraint (0.02 s) misses by about 2e-4 m on the slider-crank, which this bound refuses.
"""

from __future__ import annotations

import numpy as np
import pytest

from physics.chain_presets import get_preset
from physics.cli import main
from physics.errors import LinkageError
from physics.mechanism import MECHANISM_PRESETS, Driver, Mechanism, Revolute
from physics.mechanism.chains import chain_mechanism
from physics.mechanism.constraints import Constraints
from physics.mechanism.mjcf import to_mjcf
from physics.mechanism.simulate import simulate_mechanism

mujoco = pytest.importorskip("mujoco", reason="MuJoCo is not installed (pip install -e '.[mjcf]'; CI installs it)")

STEP = 1e-4  # s: MuJoCo's step in these runs (the file's constraint time constant is two of them)
SAMPLES = 101  # over 1 s
OPEN_CHAIN_AGREEMENT = 1e-9  # m
LOOP_AGREEMENT = 2e-6  # of the mechanism's size


def our_points(mechanism: Mechanism) -> dict[str, np.ndarray]:
    """Every named point over 1 s of our own run (DAE, DOP853, rtol = atol = 1e-10), by ``body.point``."""
    run = simulate_mechanism(mechanism, 1.0, SAMPLES)
    constraints = Constraints(mechanism)
    return {f"{body.name}.{point}": np.array([constraints.body_point(q, k, xy) for q in run.q])
            for k, body in enumerate(mechanism.bodies) for point, xy in body.points.items()}


def mujoco_points(xml: str, step: float = STEP) -> dict[str, np.ndarray]:
    """Every site over 1 s of MuJoCo's run of ``xml`` from its reference pose at rest, as our (x, y)."""
    model = mujoco.MjModel.from_xml_string(xml)
    model.opt.timestep = step
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    per_sample = round(1.0 / (SAMPLES - 1) / step)
    found: dict[str, list] = {model.site(i).name: [] for i in range(model.nsite)}
    for sample in range(SAMPLES):
        if sample:
            mujoco.mj_step(model, data, nstep=per_sample)
        for i in range(model.nsite):
            found[model.site(i).name].append(data.site_xpos[i][[0, 2]].copy())  # MuJoCo's z is our y
    return {name: np.array(path) for name, path in found.items()}


def largest_miss(mechanism: Mechanism, xml: str) -> tuple[float, float, float]:
    """(largest distance between the two runs' points, largest travel of a point, the mechanism's size)."""
    ours, theirs = our_points(mechanism), mujoco_points(xml)
    miss = max(float(np.max(np.linalg.norm(ours[name] - theirs[name], axis=1))) for name in ours)
    travel = max(float(np.max(np.linalg.norm(path - path[0], axis=1))) for path in ours.values())
    size = float(np.max(np.ptp(np.concatenate(list(ours.values())), axis=0)))
    return miss, travel, size


def chain(name: str) -> Mechanism:
    preset = get_preset(name)
    return chain_mechanism(preset.chain, preset.theta0)


def slider_crank_with_torque(reverse_pin: bool = False) -> Mechanism:
    """The slider-crank driven by a 0.05 N m motor at O, with damping 0.002 N m s on pin A; ``reverse_pin``
    writes pin O the other way round (crank first), so the same motor is -0.05 N m on the ground."""
    base = MECHANISM_PRESETS["slider-crank"]()
    joints = []
    for joint in base.joints:
        if joint.name == "A":
            joint = joint.model_copy(update={"damping": 0.002})
        if joint.name == "O" and reverse_pin:
            joint = Revolute(name="O", a="crank.O", b="ground.O")
        joints.append(joint)
    torque = -0.05 if reverse_pin else 0.05
    return base.model_copy(update={"joints": joints, "drivers": [Driver(joint="O", torque=torque)]})


def test_the_cli_writes_a_file_mujoco_loads_with_our_masses_and_inertias(tmp_path):
    out = tmp_path / "jansen.xml"
    assert main(["export", "--preset", "jansen-leg", "--format", "mjcf", "--out", str(out)]) == 0
    model = mujoco.MjModel.from_xml_path(str(out))
    mechanism = MECHANISM_PRESETS["jansen-leg"]()
    assert model.nbody == len(mechanism.bodies) + 1  # and the world
    assert model.neq == len(mechanism.joints) - len(mechanism.bodies)  # one point constraint per loop
    for body in mechanism.bodies:
        k = model.body(body.name).id
        assert model.body_mass[k] == pytest.approx(body.mass, rel=1e-12)
        assert model.body_inertia[k][1] == pytest.approx(body.inertia, rel=1e-12)  # about MuJoCo's y, the normal
        assert model.body_inertia[k][0] + model.body_inertia[k][2] >= model.body_inertia[k][1] * (1 - 1e-12)
    # every named point where assembly puts it (the sketch here, which is exact), as a site body.point
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    for body in mechanism.bodies:
        k = model.body(body.name).id
        assert data.xipos[k][[0, 2]] == pytest.approx(body.centre, abs=1e-12)  # the centre of mass
        for name, xy in body.points.items():
            assert data.site(f"{body.name}.{name}").xpos[[0, 2]] == pytest.approx(xy, abs=1e-12)


def test_an_open_chain_moves_as_ours_in_mujoco():
    mechanism = chain("triple-a")  # bar 1 horizontal, bars 2 and 3 up, released at rest
    miss, travel, _ = largest_miss(mechanism, to_mjcf(mechanism, STEP))
    assert travel > 0.3
    assert miss < OPEN_CHAIN_AGREEMENT


@pytest.mark.parametrize("mechanism", [
    pytest.param(chain("four-bar"), id="four-bar"),
    pytest.param(MECHANISM_PRESETS["slider-crank"](), id="slider-crank"),
    pytest.param(slider_crank_with_torque(), id="torque-and-damping"),
    pytest.param(slider_crank_with_torque(reverse_pin=True), id="torque-on-a-reversed-pin"),
    pytest.param(MECHANISM_PRESETS["watt-six-bar"](), id="watt-six-bar"),
])
def test_closed_loops_move_as_ours_in_mujoco(mechanism):
    miss, travel, size = largest_miss(mechanism, to_mjcf(mechanism, STEP))
    assert travel > 0.01 * size / 2  # a real motion, from a pose away from equilibrium
    assert miss < LOOP_AGREEMENT * size


def test_mujocos_default_soft_constraint_would_not_pass():
    """The bound above tells a stiff loop constraint from MuJoCo's default one (time constant 0.02 s)."""
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    xml = to_mjcf(mechanism, STEP)
    soft = xml.replace(f'solref="{2 * STEP!r} 1"', 'solref="0.02 1"')
    assert soft != xml
    miss, _, size = largest_miss(mechanism, soft)
    assert miss > 10 * LOOP_AGREEMENT * size


@pytest.mark.parametrize("preset", ["crank-rocker", "jansen-leg"])
def test_a_speed_motor_is_a_servo_that_follows_the_speed(preset):
    """Not compared point by point: MuJoCo's velocity servo starts from rest and follows the speed within a few
    per cent (the motor's load changes over the turn), where ours prescribes the angle exactly. The angle is
    read from the crank's points, so it is the way the crank turns in the plane, counter-clockwise here."""
    mechanism = MECHANISM_PRESETS[preset]()
    driver = mechanism.drivers[0]
    pin = next(joint for joint in mechanism.joints if joint.name == driver.joint)
    assert pin.a.startswith("ground.")  # the crank is body b: it turns at +speed
    crank, pivot = pin.b.split(".")
    tip = next(name for name in mechanism.body(crank).points if name != pivot)
    model = mujoco.MjModel.from_xml_string(to_mjcf(mechanism))  # the file's own step
    data = mujoco.MjData(model)
    times, angles = [], []
    while data.time < 1.0 - model.opt.timestep / 2:
        mujoco.mj_step(model, data)
        dx, _, dy = data.site(f"{crank}.{tip}").xpos - data.site(f"{crank}.{pivot}").xpos
        times.append(data.time)
        angles.append(np.arctan2(dy, dx))
    angles = np.unwrap(angles)
    rates = np.gradient(angles, times)
    late = rates[np.asarray(times) >= 0.2]
    assert np.all(np.abs(late / driver.speed - 1) < 0.1)
    assert angles[-1] - angles[0] == pytest.approx(driver.speed * (times[-1] - times[0]), rel=0.02)


def test_pins_that_close_loops_cannot_carry_motors_or_damping():
    base = MECHANISM_PRESETS["crank-rocker"]()
    every_pin = [Driver(joint=joint.name, torque=0.01) for joint in base.joints]
    # the tree takes the pins in the file's order, so the last, O4, closes the loop
    with pytest.raises(LinkageError, match=r"^driver on 'O4': the motor's pin closes a loop"):
        to_mjcf(base.model_copy(update={"drivers": every_pin}))
    damped = [joint.model_copy(update={"damping": 0.01}) for joint in base.joints]
    with pytest.raises(LinkageError, match=r"^joint 'O4': damping on a pin that closes a loop"):
        to_mjcf(base.model_copy(update={"joints": damped, "drivers": []}))


def geared_pendulums(reverse_pin: bool) -> Mechanism:
    """Two pendulums on ground pivots, geared (ratio -0.5), released at rest; ``reverse_pin`` writes the second
    pin body-first, so the gear's sign in MJCF must follow which side of the pin is the hinge's child."""
    second = (["pendulum2.O2", "ground.O2"] if reverse_pin else ["ground.O2", "pendulum2.O2"])
    return Mechanism.model_validate({
        "name": "geared pendulums", "ground": {"O1": [0.0, 0.0], "O2": [0.3, 0.0]},
        "bodies": [{"name": "pendulum1", "points": {"O1": [0.0, 0.0], "E": [0.2, -0.1]}, "mass": 0.4,
                    "inertia": 0.002},
                   {"name": "pendulum2", "points": {"O2": [0.3, 0.0], "E": [0.3, -0.25]}, "mass": 0.6,
                    "inertia": 0.004}],
        "joints": [{"name": "P1", "a": "ground.O1", "b": "pendulum1.O1"},
                   {"name": "P2", "a": second[0], "b": second[1]},
                   {"kind": "gear", "name": "mesh", "joints": ["P1", "P2"], "ratio": -0.5}],
    })


@pytest.mark.parametrize("reverse_pin", [False, True], ids=["pins-ground-first", "second-pin-reversed"])
def test_a_gear_pair_is_a_joint_equality_and_moves_as_ours_in_mujoco(reverse_pin):
    mechanism = geared_pendulums(reverse_pin)
    xml = to_mjcf(mechanism, STEP)
    model = mujoco.MjModel.from_xml_string(xml)
    assert model.neq == 1 and model.eq_type[0] == mujoco.mjtEq.mjEQ_JOINT
    miss, travel, size = largest_miss(mechanism, xml)
    assert travel > 0.05 * size  # the pendulums swing
    assert miss < LOOP_AGREEMENT * size
