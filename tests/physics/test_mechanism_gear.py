"""The gear pair, the joint kind added through the joint interface (physics/mechanism/joints/gear.py).

* Three-way agreement: random valid mechanisms with gear pairs (between any two pins: on the ground, between
  moving bodies, cut or in the tree, beside motors and damped pins), at random assembled states and with random
  numbers (ratio and offset among them) on the compiled engine: every formulation's accelerations and every
  reaction row equal the numeric DAE's, and no number's change derives or compiles anything.
* Two geared discs turned by a torque motor: the speed ratio at every sample of a run and the contact torque of
  the torque balance of each disc (``I1 a1 = tau - ratio lambda``, ``I2 a2 = lambda``), in closed form.
* The geared five-bar preset against a position analysis written here (its cranks' angles from the motor and the
  gear, the couplers' meeting point by intersecting two circles); free under a torque motor, the same run in the
  three formulations and the reduced model, with the motor's work the only energy gained.
* The file format: TOML and JSON, and one-line refusals naming the field and the range.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from physics.codegen import cache
from physics.errors import LinkageError
from physics.mechanism import MECHANISM_PRESETS, assemble, engine
from physics.mechanism.constraints import Constraints
from physics.mechanism.description import Gear, Mechanism
from physics.mechanism.files import mechanism_from_text
from physics.mechanism.numeric_dae import MechanismDAE
from physics.mechanism.parameters import parameter_names, parameter_vector, structure_key
from physics.mechanism.reactions import reaction_row_names
from physics.mechanism.simulate import project_velocity, simulate_mechanism
from physics.mechanism.statics import evaluate, free_body
from physics.mechanism.topology import analyse

from .test_mechanism_symbolic import random_mechanism

METHODS = ("dae", "lagrange", "newton_euler")
AGREEMENT = 1e-9  # relative, as for every other mechanism (tests/physics/test_mechanism_symbolic.py)


def geared(rng: np.random.Generator) -> Mechanism:
    """A random mechanism of tests/physics/test_mechanism_symbolic.py with a gear pair between two of its pins
    (random ratio of either sign, random offset), drawn again until its count leaves the gear a degree of freedom
    to take, its constraints are independent and its ratio changes the motion."""
    while True:
        mechanism = random_mechanism(rng)
        closing = [joint.name for joint in mechanism.joints if joint.name.startswith("C")]
        if closing and rng.random() < 0.3:  # open a loop: two degrees of freedom for a gear and a speed motor
            spec = mechanism.model_dump()
            spec["joints"] = [joint for joint in spec["joints"] if joint["name"] != closing[-1]]
            spec["drivers"] = [driver for driver in spec["drivers"] if driver["joint"] != closing[-1]]
            mechanism = Mechanism.model_validate(spec)
        pins = [joint.name for joint in mechanism.joints if joint.kind == "revolute"]
        if len(pins) < 2 or analyse(mechanism).mobility < 1:
            continue
        first, second = (str(name) for name in rng.choice(pins, size=2, replace=False))
        ratio = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.3, 3.0))
        spec = mechanism.model_dump()
        spec["joints"].append({"kind": "gear", "name": "mesh", "joints": [first, second], "ratio": ratio,
                               "offset": float(rng.uniform(-0.2, 0.2))})
        undriven = [name for name in pins if name not in {d["joint"] for d in spec["drivers"]}]
        if analyse(mechanism).mobility >= 2 and undriven and rng.random() < 0.7:  # a speed motor beside the gear
            spec["drivers"].append({"joint": str(rng.choice(undriven)), "speed": float(rng.uniform(-4.0, 4.0))})
        candidate = Mechanism.model_validate(spec)
        constraints = Constraints(candidate)
        jacobian = constraints.jacobian(constraints.sketch_pose() + rng.normal(scale=0.1, size=constraints.size))
        if np.linalg.matrix_rank(jacobian) < jacobian.shape[0]:
            continue
        try:
            q = assemble(candidate).q
        except LinkageError:
            continue
        if not _ratio_matters(candidate, q):
            continue
        return candidate


def geared_five_bar(rng: np.random.Generator) -> Mechanism:
    """A random five-bar (random pivots, cranks, couplers, masses; pins written either way round) with a gear
    pair between two random pins of its loop (the cut pin among them), a torque motor, and a speed motor on half
    of them (the motors then fix every body: inverse dynamics)."""
    while True:
        o2 = np.array([rng.uniform(0.2, 0.5), rng.uniform(-0.1, 0.1)])
        a = rng.uniform(0.05, 0.15) * np.array([np.cos(t := rng.uniform(0, 2 * np.pi)), np.sin(t)])
        b = o2 + rng.uniform(0.05, 0.15) * np.array([np.cos(t := rng.uniform(0, 2 * np.pi)), np.sin(t)])
        c = (a + b) / 2 + np.array([rng.uniform(-0.1, 0.1), rng.uniform(0.2, 0.4)])

        def body(name: str, ends: dict) -> dict:
            extra = {"X": [float(v) for v in rng.uniform(-0.3, 0.3, 2)]}
            return {"name": name, "mass": float(rng.uniform(0.2, 1.5)), "inertia": float(rng.uniform(0.002, 0.05)),
                    "points": {**{k: [float(v) for v in xy] for k, xy in ends.items()}, **extra}}

        def pin(name: str, first: str, second: str) -> dict:
            sides = [first, second] if rng.random() < 0.5 else [second, first]
            return {"name": name, "a": sides[0], "b": sides[1], "damping": float(rng.uniform(0.0, 0.1))}

        pins = [pin("O1", "ground.O1", "crank1.O1"), pin("O2", "ground.O2", "crank2.O2"),
                pin("A", "crank1.A", "coupler1.A"), pin("B", "crank2.B", "coupler2.B"),
                pin("C", "coupler1.C", "coupler2.C")]
        first, second = (str(name) for name in rng.choice([p["name"] for p in pins], size=2, replace=False))
        ratio = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.3, 3.0))
        drivers = [{"joint": str(rng.choice(["O1", "O2", "A", "B", "C"])), "torque": float(rng.uniform(-1, 1))}]
        if rng.random() < 0.5:
            free = [p["name"] for p in pins if p["name"] != drivers[0]["joint"]]
            drivers.append({"joint": str(rng.choice(free)), "speed": float(rng.uniform(-4.0, 4.0))})
        spec = {"name": "random geared five-bar", "g": float(rng.uniform(1.0, 12.0)),
                "ground": {"O1": [0.0, 0.0], "O2": [float(o2[0]), float(o2[1])]},
                "bodies": [body("crank1", {"O1": (0.0, 0.0), "A": a}), body("crank2", {"O2": o2, "B": b}),
                           body("coupler1", {"A": a, "C": c}), body("coupler2", {"B": b, "C": c})],
                "joints": [*pins, {"kind": "gear", "name": "mesh", "joints": [first, second], "ratio": ratio,
                                   "offset": float(rng.uniform(-0.2, 0.2))}],
                "drivers": drivers}
        mechanism = Mechanism.model_validate(spec)
        try:
            q = assemble(mechanism).q
        except LinkageError:
            continue
        if _ratio_matters(mechanism, q):
            return mechanism


def _ratio_matters(mechanism: Mechanism, q: np.ndarray) -> bool:
    """The gear couples two motions the rest leaves independent: another ratio gives other accelerations at
    ``q`` from rest (a gear between two pins that turn together would only lock them, whatever its ratio)."""
    spec = mechanism.model_dump()
    spec["joints"][-1]["ratio"] *= 1.3
    other = Mechanism.model_validate(spec)
    rest = np.zeros_like(q)
    try:
        first, second = MechanismDAE(mechanism).solve(q, rest), MechanismDAE(other).solve(q, rest)
    except LinkageError:
        return False
    return bool(np.max(np.abs(first.qddot - second.qddot)) > 1e-3 * (1.0 + np.max(np.abs(first.qddot))))


def renumbered(mechanism: Mechanism, rng: np.random.Generator) -> Mechanism:
    """The same structure with other numbers: masses, inertias, g, damping, motors, every gear's ratio and offset."""
    spec = mechanism.model_dump()
    for body in spec["bodies"]:
        body["mass"] = float(body["mass"] * rng.uniform(0.5, 2.0))
        body["inertia"] = float(body["inertia"] * rng.uniform(0.5, 2.0))
    for joint in spec["joints"]:
        if joint["kind"] == "gear":
            joint["ratio"] = float(joint["ratio"] * rng.uniform(0.6, 1.6))
            joint["offset"] = float(joint["offset"] + rng.uniform(-0.1, 0.1))
        else:
            joint["damping"] = float(rng.uniform(0.0, 0.3))
    for driver in spec["drivers"]:
        if driver["speed"] is not None:
            driver["speed"] = float(rng.uniform(-5.0, 5.0))
        else:
            driver["torque"] = float(rng.uniform(-2.0, 2.0))
    spec["g"] = float(rng.uniform(1.0, 12.0))
    return Mechanism.model_validate(spec)


def close(mine: np.ndarray, theirs: np.ndarray) -> bool:
    mine, theirs = np.ravel(mine), np.ravel(theirs)
    return mine.shape == theirs.shape and bool(
        np.max(np.abs(mine - theirs), initial=0.0) <= AGREEMENT * (1.0 + np.max(np.abs(theirs), initial=0.0)))


def assembled_states(mechanism: Mechanism, rng: np.random.Generator, count: int):
    """``(q, qdot, t)``: poses assembled near random perturbations of the sketch at random times, with random
    velocities that satisfy the constraints, at which the augmented system is well posed."""
    dae = MechanismDAE(mechanism)
    constraints = dae.constraints
    found = 0
    for _ in range(10 * count):
        t = float(rng.uniform(0.0, 2.0))
        try:
            q = assemble(mechanism, constraints.sketch_pose() + rng.normal(scale=0.05, size=constraints.size), t).q
        except LinkageError:
            continue
        qdot = project_velocity(dae, q, rng.normal(size=q.size))
        jacobian = constraints.jacobian(q)
        if np.linalg.svd(jacobian, compute_uv=False)[-1] < 1e-3 * np.linalg.norm(jacobian):
            continue  # near a singular pose: the tree coordinates' accelerations are ill-conditioned
        yield q, qdot, t
        found += 1
        if found == count:
            return


GEARED_SEEDS = tuple(range(8))


@pytest.fixture(scope="module")
def geared_mechanisms() -> list[Mechanism]:
    """Half random mechanisms of tests/physics/test_mechanism_symbolic.py with a gear added, half random geared
    five-bars (a loop whose cut pin may be geared)."""
    return [(geared if seed % 2 == 0 else geared_five_bar)(np.random.default_rng(424242 + seed))
            for seed in GEARED_SEEDS]


def test_the_random_geared_mechanisms_hold_the_cases(geared_mechanisms):
    """Gears between pins of the tree and of loops, on the ground and between moving bodies, of both signs,
    beside speed and torque motors."""
    seen = set()
    for mechanism in geared_mechanisms:
        tree = set(analyse(mechanism).tree_joints)
        gear = next(joint for joint in mechanism.joints if isinstance(joint, Gear))
        pins = {joint.name: joint for joint in mechanism.joints}
        for name in gear.joints:
            seen.add("geared tree pin" if name in tree else "geared cut pin")
            pin = pins[name]
            seen.add("geared ground pin" if "ground" in (pin.a.split(".")[0], pin.b.split(".")[0]) else
                     "geared pin between bodies")
        seen.add("negative ratio" if gear.ratio < 0 else "positive ratio")
        seen.update("speed motor" if d.speed is not None else "torque motor" for d in mechanism.drivers)
    assert seen >= {"geared tree pin", "geared cut pin", "geared ground pin", "geared pin between bodies", "negative ratio",
                    "positive ratio", "speed motor", "torque motor"}, seen


@pytest.mark.parametrize("seed", GEARED_SEEDS)
def test_three_formulations_agree_with_gears_at_random_states_and_numbers_without_compiling(
        seed, geared_mechanisms, monkeypatch):
    """Every formulation's accelerations and every reaction row (the gear's contact torque among them) equal the
    numeric DAE's at random assembled states; after the first numbers compile the structure, other numbers
    (ratio and offset included) derive and compile nothing."""
    rng = np.random.default_rng(1000 + seed)
    base = geared_mechanisms[seed]
    loaded = {method: engine.compiled_system(base, method) for method in METHODS}

    def refuse(*_args, **_kwargs):
        raise AssertionError("a number's edit derived or generated code")

    monkeypatch.setattr(cache, "_generate", refuse)
    checked = 0
    for numbers in (base, renumbered(base, rng), renumbered(base, rng)):
        assert structure_key(numbers) == structure_key(base)
        names = reaction_row_names(numbers)
        assert "mesh: contact torque" in names
        for q, qdot, t in assembled_states(numbers, rng, 2):
            reference = MechanismDAE(numbers).solve(q, qdot)
            for method in METHODS:
                assert engine.compiled_system(numbers, method) is loaded[method]
                instant = evaluate(numbers, q, qdot, method, t)
                assert close(instant.qddot, reference.qddot), method
                assert close(instant.reactions, reference.reactions), method
                assert instant.row_names == names
            checked += 1
    assert checked >= 4


def test_the_gear_row_and_its_numbers_come_from_the_parameter_vector():
    """Ratio and offset are named parameters (never literals): changing them leaves the structure key alone and
    moves the constraint's residual as the equation says."""
    mechanism = MECHANISM_PRESETS["geared-five-bar"]()
    names = parameter_names(mechanism)
    values = parameter_vector(mechanism)
    assert values[names.index("gear gears.ratio")] == -1.0
    assert values[names.index("gear gears.offset")] == 0.0
    spec = mechanism.model_dump()
    spec["joints"][-1].update(ratio=-2.5, offset=0.3)
    other = Mechanism.model_validate(spec)
    assert structure_key(other) == structure_key(mechanism)
    q = Constraints(mechanism).sketch_pose()
    q[2::3] = np.random.default_rng(2).normal(size=len(mechanism.bodies))
    row = [k for k, r in enumerate(Constraints(other).rows) if r.joint == "gears"]
    index = {body.name: k for k, body in enumerate(mechanism.bodies)}
    expected = q[3 * index["crank2"] + 2] - (-2.5) * q[3 * index["crank1"] + 2] - 0.3
    np.testing.assert_allclose(Constraints(other).residual(q)[row], [expected], atol=1e-15)


# --------------------------------------------------------------------------------------------- a gear in a run


def geared_discs(ratio: float, torque: float, inertias=(0.02, 0.05)) -> Mechanism:
    """Two discs, each pinned to the ground at its centre of mass, geared; a torque motor on the first."""
    return Mechanism.model_validate({
        "name": "geared discs", "g": 9.81, "ground": {"O1": [0.0, 0.0], "O2": [0.3, 0.0]},
        "bodies": [{"name": "disc1", "points": {"O1": [0.0, 0.0], "R": [0.1, 0.0]}, "com": [0.0, 0.0], "mass": 1.0,
                    "inertia": inertias[0]},
                   {"name": "disc2", "points": {"O2": [0.3, 0.0], "R": [0.45, 0.0]}, "com": [0.3, 0.0],
                    "mass": 2.0, "inertia": inertias[1]}],
        "joints": [{"name": "P1", "a": "ground.O1", "b": "disc1.O1"}, {"name": "P2", "a": "ground.O2", "b": "disc2.O2"},
                   {"kind": "gear", "name": "mesh", "joints": ["P1", "P2"], "ratio": ratio}],
        "drivers": [{"joint": "P1", "torque": torque}],
    })


@pytest.mark.parametrize("method", METHODS)
def test_geared_discs_keep_the_speed_ratio_and_the_torque_balance(method):
    """``a1 = tau / (I1 + ratio^2 I2)``, ``w2 = ratio w1`` at every sample, and the contact torque ``lambda =
    I2 a2`` on the second disc while the first feels ``-ratio lambda``: ``I1 a1 = tau - ratio lambda``."""
    ratio, tau, (i1, i2) = -2.5, 0.4, (0.02, 0.05)
    mechanism = geared_discs(ratio, tau, (i1, i2))
    run = simulate_mechanism(mechanism, 1.0, 11, method=method)
    alpha1 = tau / (i1 + ratio**2 * i2)
    spin1, spin2 = run.qdot[:, 2], run.qdot[:, 5]
    np.testing.assert_allclose(spin1, alpha1 * run.t, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(spin2, ratio * spin1, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(run.q[:, 5], ratio * run.q[:, 2], rtol=1e-9, atol=1e-12)
    contact = run.reaction_rows[:, list(run.row_names).index("mesh: contact torque")]
    np.testing.assert_allclose(contact, i2 * ratio * alpha1, rtol=1e-8)
    np.testing.assert_allclose(i1 * alpha1, tau - ratio * contact, rtol=1e-8)
    # the free-body diagrams say the same: the gear's couple on each disc
    instant = evaluate(mechanism, run.q[-1], run.qdot[-1], method, float(run.t[-1]))
    couples = {}
    for body in ("disc1", "disc2"):
        loads = [load for load in free_body(mechanism, instant, body).loads if load.kind == "gear"]
        assert len(loads) == 1 and loads[0].force == (0.0, 0.0)
        couples[body] = loads[0].moment
    np.testing.assert_allclose(couples["disc2"], i2 * ratio * alpha1, rtol=1e-8)
    np.testing.assert_allclose(couples["disc1"], -ratio * couples["disc2"], rtol=1e-12)


def test_the_geared_five_bar_follows_a_position_analysis():
    """Crank 1 at 90 deg + w t, crank 2 at 30 deg + ratio w t; C where circles of the couplers' lengths about A and
    B meet, left of A -> B: the run's traced point and every body's angle, for each formulation."""
    mechanism = MECHANISM_PRESETS["geared-five-bar"]()
    speed = mechanism.drivers[0].speed
    gear = next(joint for joint in mechanism.joints if isinstance(joint, Gear))
    assert speed is not None and gear.ratio == -1.0
    top = assemble(mechanism)
    assert top.mobility == 0 and top.mechanism_mobility == 1 and top.grubler_mechanism_mobility == 1
    crank, couplers, o2 = 0.08, (0.28, 0.32), np.array([0.3, 0.0])

    def meeting_point(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        d = float(np.linalg.norm(b - a))
        along = (couplers[0] ** 2 - couplers[1] ** 2 + d * d) / (2 * d)
        across = math.sqrt(couplers[0] ** 2 - along**2)
        u = (b - a) / d
        return a + along * u + across * np.array([-u[1], u[0]])

    for method in METHODS:
        run = simulate_mechanism(mechanism, 1.5, 31, method=method)
        for t, trace, q in zip(run.t, run.trace_xy, run.q):
            first = math.radians(90.0) + speed * t
            second = math.radians(30.0) + gear.ratio * speed * t
            a = crank * np.array([math.cos(first), math.sin(first)])
            b = o2 + crank * np.array([math.cos(second), math.sin(second)])
            c = meeting_point(a, b)
            np.testing.assert_allclose(trace, c, atol=1e-9)
            np.testing.assert_allclose([q[2], q[5]], [speed * t, gear.ratio * speed * t], atol=1e-9)
            for k, name, start, pivot in ((2, "coupler1", a, "A"), (3, "coupler2", b, "B")):
                points = mechanism.body(name).points  # each coupler's angle from its sketch
                drawn = math.atan2(points["C"][1] - points[pivot][1], points["C"][0] - points[pivot][0])
                now = math.atan2(c[1] - start[1], c[0] - start[0])
                assert abs(math.remainder(q[3 * k + 2] - (now - drawn), 2 * math.pi)) < 1e-9


# --------------------------------------------------------------------------------------------- the file format


GEARED_TOML = """
name = "discs"
[ground]
O1 = [0.0, 0.0]
O2 = [0.3, 0.0]

[[bodies]]
name = "disc1"
mass = 1.0
inertia = 0.02
points = { O1 = [0.0, 0.0] }

[[bodies]]
name = "disc2"
mass = 1.0
inertia = 0.02
points = { O2 = [0.3, 0.0] }

[[joints]]
name = "P1"
a = "ground.O1"
b = "disc1.O1"

[[joints]]
name = "P2"
a = "ground.O2"
b = "disc2.O2"

[[joints]]
kind = "gear"
name = "mesh"
joints = ["P1", "P2"]
ratio = -2.0
offset = 0.0
"""


def test_a_gear_reads_from_toml_and_json_alike():
    from_toml = mechanism_from_text(GEARED_TOML, "discs.toml")
    from_json = mechanism_from_text(json.dumps(from_toml.model_dump(mode="json")), "discs.json")
    assert from_toml == from_json
    gear = from_toml.joints[-1]
    assert isinstance(gear, Gear) and gear.joints == ("P1", "P2") and gear.ratio == -2.0
    assert analyse(from_toml).mobility == 1
    assert reaction_row_names(from_toml)[-1] == "mesh: contact torque"
    from physics.mechanism.writer import to_json, to_toml  # noqa: PLC0415

    preset = MECHANISM_PRESETS["geared-five-bar"]()  # written and read back unchanged, both ways
    assert mechanism_from_text(to_toml(preset), "g5.toml") == preset == mechanism_from_text(to_json(preset), "g5.json")


@pytest.mark.parametrize(("change", "message"), [
    ({"ratio": 0.0}, "discs.toml: joint 'mesh': ratio: must not be 0: allowed -1000 <= ratio <= 1000, ratio != 0"),
    ({"ratio": "nan"}, "discs.toml: joint 'mesh': ratio: must be a finite number"),
    ({"ratio": 5000.0}, "discs.toml: joint 'mesh': ratio: Input should be less than or equal to 1000"),
    ({"offset": "inf"}, "discs.toml: joint 'mesh': offset: must be a finite number"),
    ({"joints": ["P1", "P3"]}, "discs.toml: joint 'mesh': joints: no joint named 'P3'"),
    ({"joints": ["P1", "P1"]}, "discs.toml: joint 'mesh': joints: gears joint 'P1' to itself"),
    ({"joints": ["P1", "mesh"]}, "discs.toml: joint 'mesh': joints: 'mesh' is a gear joint; a gear couples two "
                                 "revolute joints"),
    ({"kind": "belt"}, "discs.toml: joint 'mesh': kind: allowed revolute, prismatic, gear"),
])
def test_a_bad_gear_is_refused_in_one_line_naming_the_field(change, message):
    text = GEARED_TOML
    for field, value in change.items():
        written = json.dumps(value) if not isinstance(value, str) or field in ("kind",) else value
        if field == "joints":
            text = text.replace('joints = ["P1", "P2"]', f"joints = {json.dumps(value)}")
        elif field == "kind":
            text = text.replace('kind = "gear"', f"kind = {written}")
        else:
            line = {"ratio": "ratio = -2.0", "offset": "offset = 0.0"}[field]
            text = text.replace(line, f"{field} = {written}")
    with pytest.raises(LinkageError) as error:
        mechanism_from_text(text, "discs.toml")
    assert str(error.value).startswith(message), str(error.value)
    assert "\n" not in str(error.value)


def test_a_motor_on_a_gear_is_refused():
    text = GEARED_TOML + '\n[[drivers]]\njoint = "mesh"\nspeed = 1.0\n'
    with pytest.raises(LinkageError, match="driver on 'mesh': motors drive revolute joints only"):
        mechanism_from_text(text, "discs.toml")


def test_a_free_geared_five_bar_runs_alike_in_every_method_and_its_gear_does_no_work():
    """The preset with a torque motor instead of its speed motor (one free coordinate): the three formulations
    and the reduced model give one motion and one set of reactions, the cranks keep the ratio, and the energy
    gained is the motor's work alone, ``tau * angle(O1)`` (the gear's two torques do no work together)."""
    spec = MECHANISM_PRESETS["geared-five-bar"]().model_dump()
    tau = 0.05
    spec["drivers"] = [{"joint": "O1", "torque": tau}]
    mechanism = Mechanism.model_validate(spec)
    runs = {method: simulate_mechanism(mechanism, 1.0, 21, method=method) for method in (*METHODS, "reduced")}
    reference = runs["dae"]
    assert abs(reference.q[-1, 2]) > 3.0  # the cranks turn through more than half a turn
    np.testing.assert_allclose(reference.q[:, 5], -reference.q[:, 2], atol=1e-9)
    energy = reference.kinetic + reference.potential
    np.testing.assert_allclose(energy - energy[0], tau * reference.q[:, 2], atol=1e-7)
    for method, run in runs.items():
        np.testing.assert_allclose(run.q, reference.q, atol=1e-7, err_msg=method)
        np.testing.assert_allclose(run.reaction_rows, reference.reaction_rows, atol=1e-6 * np.max(np.abs(reference.reaction_rows)),
                                   err_msg=method)


def test_the_command_line_sets_a_gears_ratio_and_refuses_a_zero_one(capsys, tmp_path):
    from physics.cli import main  # noqa: PLC0415
    from physics.mechanism.cli_runs import with_settings  # noqa: PLC0415

    preset = MECHANISM_PRESETS["geared-five-bar"]()
    changed = with_settings(preset, {"gears.ratio": "-2", "gears.offset": "0.1"})
    assert (changed.joints[-1].ratio, changed.joints[-1].offset) == (-2.0, 0.1)
    argv = ["simulate", "--preset", "geared-five-bar", "--t-end", "0.5", "--samples", "6"]
    assert main([*argv, "--out", str(tmp_path / "one.csv")]) == 0
    assert main([*argv, "--set", "gears.ratio=-2", "--out", str(tmp_path / "two.csv")]) == 0
    one, two = (np.loadtxt(tmp_path / name, delimiter=",", skiprows=1) for name in ("one.csv", "two.csv"))
    assert np.allclose(one[0, 1:3], two[0, 1:3]) and not np.allclose(one[-1, 1:3], two[-1, 1:3])  # C moves otherwise
    capsys.readouterr()
    assert main([*argv, "--set", "gears.ratio=0"]) == 2
    error = capsys.readouterr().err.strip()
    assert error == ("error: --set: joint 'gears': ratio: must not be 0: allowed -1000 <= ratio <= 1000, ratio != 0 "
                     "(a zero ratio would lock the second joint)")
