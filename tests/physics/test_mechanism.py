"""Any planar mechanism, first part: the description, its topology, assembly and kinematics.

Independent checks: the Grübler–Kutzbach count against the rank of the constraint Jacobian; the slider-crank's
piston position, velocity and acceleration against their closed forms; the Jansen foot path against plain
position analysis written here (circle intersections, one dyad at a time); every bad file one clear line.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from physics.errors import LinkageError
from physics.mechanism import MECHANISM_PRESETS, Mechanism, assemble
from physics.mechanism.assembly import kinematics, track
from physics.mechanism.constraints import Constraints
from physics.mechanism.files import load_mechanism, mechanism_from_document

EXPECTED_MOBILITY = {  # after the motors: a driven mechanism has none left
    "slider-crank": 1,
    "crank-rocker": 0,
    "chebyshev-lambda": 0,
    "watt-six-bar": 1,
    "stephenson-six-bar": 1,
    "jansen-leg": 0,
    "geared-five-bar": 0,
}
EXPECTED_LOOPS = {"slider-crank": 1, "crank-rocker": 1, "chebyshev-lambda": 1, "watt-six-bar": 2,
                  "stephenson-six-bar": 2, "jansen-leg": 3, "geared-five-bar": 1}


def _driven(mechanism: Mechanism, joint: str, speed: float) -> Mechanism:
    document = mechanism.model_dump()
    document["drivers"] = [{"joint": joint, "speed": speed}]
    return Mechanism.model_validate(document)


@pytest.mark.parametrize("name", sorted(MECHANISM_PRESETS))
def test_presets_assemble_with_the_mobility_both_counts_give(name):
    mechanism = MECHANISM_PRESETS[name]()
    assembled = assemble(mechanism)
    assert assembled.residual <= 1e-12
    assert assembled.grubler_mobility == assembled.mobility == EXPECTED_MOBILITY[name]
    assert len(assembled.topology.loops) == EXPECTED_LOOPS[name]
    assert mechanism.description  # every preset says what it teaches


@pytest.mark.parametrize("name", sorted(MECHANISM_PRESETS))
def test_a_rough_sketch_is_pulled_together_and_stays_rigid(name):
    """Bodies moved off their places: Newton closes every joint again without deforming any body."""
    mechanism = MECHANISM_PRESETS[name]()
    rng = np.random.default_rng(7)
    constraints = Constraints(mechanism)
    guess = constraints.sketch_pose() + rng.normal(scale=0.01, size=constraints.size)
    assembled = assemble(mechanism, guess)
    assert np.max(np.abs(constraints.residual(assembled.q))) <= 1e-12
    for k, body in enumerate(mechanism.bodies):  # rigid: distances between a body's points unchanged
        names = list(body.points)
        for a in names:
            for b in names:
                drawn = math.dist(body.points[a], body.points[b])
                moved = np.linalg.norm(constraints.body_point(assembled.q, k, body.points[a])
                                       - constraints.body_point(assembled.q, k, body.points[b]))
                assert moved == pytest.approx(drawn, abs=1e-12)


def test_constraint_jacobian_and_gamma_match_finite_differences():
    mechanism = _driven(MECHANISM_PRESETS["slider-crank"](), "O", 2.0)
    constraints = Constraints(mechanism)
    rng = np.random.default_rng(3)
    q = rng.normal(scale=0.3, size=constraints.size)
    qdot = rng.normal(size=constraints.size)
    h = 1e-6
    numeric = np.array([(constraints.residual(q + h * e) - constraints.residual(q - h * e)) / (2 * h)
                        for e in np.eye(constraints.size)]).T
    assert np.allclose(constraints.jacobian(q), numeric, atol=1e-8)
    # d/dt (Phi_q qdot) = Phi_q qddot + (Phi_q qdot)_q qdot, so gamma = -(Phi_q qdot)_q qdot
    directional = (constraints.jacobian(q + h * qdot) @ qdot - constraints.jacobian(q - h * qdot) @ qdot) / (2 * h)
    assert np.allclose(constraints.acceleration_rhs(q, qdot), -directional, atol=1e-7)


def test_slider_crank_piston_matches_its_closed_form():
    r, rod, speed, start = 0.05, 0.2, 3.0, math.radians(60.0)
    mechanism = _driven(MECHANISM_PRESETS["slider-crank"](), "O", speed)
    constraints = Constraints(mechanism)
    times = np.linspace(0.0, 2.5, 61)  # more than one turn
    piston = [b.name for b in mechanism.bodies].index("piston")
    for t, q in zip(times, track(mechanism, times)):
        theta = start + speed * t
        s, c = math.sin(theta), math.cos(theta)
        root = math.sqrt(rod * rod - (r * s) ** 2)
        x = r * c + root
        dx = -r * s - r * r * s * c / root  # d x / d theta
        d2x = -r * c - r * r * (c * c - s * s) / root - r**4 * s * s * c * c / root**3
        point = constraints.body_point(q, piston, mechanism.body("piston").points["B"])
        qdot, qddot = kinematics(mechanism, q)
        assert point[0] == pytest.approx(x, abs=1e-12) and abs(point[1]) <= 1e-12
        assert qdot[3 * piston] == pytest.approx(dx * speed, abs=1e-10)
        assert qddot[3 * piston] == pytest.approx(d2x * speed**2, abs=1e-9)


def _circle(a, ra, b, rb, side):
    """Plain circle intersection, written again here so the test does not trust the preset's own."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    d = np.linalg.norm(b - a)
    along = (ra * ra - rb * rb + d * d) / (2 * d)
    unit = (b - a) / d
    normal = np.array([-unit[1], unit[0]])
    return a + along * unit + side * math.sqrt(ra * ra - along * along) * normal


def test_jansen_foot_path_matches_plain_position_analysis():
    cm = {"a": 38.0, "b": 41.5, "c": 39.3, "d": 40.1, "e": 55.8, "f": 39.4, "g": 36.7, "h": 65.7, "i": 49.0,
          "j": 50.0, "k": 61.9, "l": 7.8, "m": 15.0}
    n = {key: value / 100 for key, value in cm.items()}
    mechanism = MECHANISM_PRESETS["jansen-leg"]()
    speed = 2.0
    times = np.linspace(0.0, 2 * math.pi / speed, 73)
    constraints = Constraints(mechanism)
    foot = [b.name for b in mechanism.bodies].index("foot")
    foot_point = mechanism.body("foot").points["F"]
    worst = 0.0
    for t, q in zip(times, track(mechanism, times)):
        angle = speed * t
        p = np.array([-n["a"], -n["l"]])
        c = n["m"] * np.array([math.cos(angle), math.sin(angle)])
        u = _circle(p, n["b"], c, n["j"], +1)
        low = _circle(p, n["c"], c, n["k"], -1)
        w = _circle(p, n["d"], u, n["e"], +1)
        top = _circle(w, n["f"], low, n["g"], -1)
        f = _circle(low, n["i"], top, n["h"], +1)
        worst = max(worst, float(np.linalg.norm(constraints.body_point(q, foot, foot_point) - f)))
    assert worst <= 1e-10
    # and the path is Jansen's: a long, nearly flat bottom (within 1 cm of the lowest point for > 1/3 turn)
    feet = np.array([constraints.body_point(q, foot, foot_point) for q in track(mechanism, times)])
    low = feet[:, 1] <= feet[:, 1].min() + 0.01
    assert low.mean() > 1 / 3 and np.ptp(feet[low, 0]) > 0.4


def _document(name: str) -> dict:
    return json.loads(MECHANISM_PRESETS[name]().model_dump_json())


@pytest.mark.parametrize(
    "change, fragment",
    [
        (lambda doc: doc["bodies"][1].update(mass=-1.0),
         "body 'rod': mass: Input should be greater than or equal to 0"),
        (lambda doc: doc["joints"][1].update(b="rodd.A"), "joint 'A': no body 'rodd'"),
        (lambda doc: doc["joints"][1].update(b="rod.Z"), "body 'rod' has no point 'Z'"),
        (lambda doc: doc["bodies"][0]["points"].update(A=[float("nan"), 0.0]), "coordinates must be finite"),
        (lambda doc: doc.update(drivers=[{"joint": "nope", "speed": 1.0}]), "no joint named 'nope'"),
        (lambda doc: doc.update(drivers=[{"joint": "guide", "speed": 1.0}]), "motors drive revolute joints only"),
    ],
)
def test_bad_descriptions_are_refused_in_one_line_naming_the_element(change, fragment):
    document = _document("slider-crank")
    change(document)
    with pytest.raises(LinkageError) as caught:
        mechanism_from_document(document, "my.json")
    message = str(caught.value)
    assert "\n" not in message and message.startswith("my.json: ") and fragment in message, message


def test_a_disconnected_body_is_named():
    document = _document("slider-crank")
    document["bodies"].append({"name": "loose", "points": {"X": [1.0, 1.0]}, "mass": 1.0, "inertia": 0.1})
    with pytest.raises(LinkageError, match="body 'loose': not connected to the ground"):
        assemble(mechanism_from_document(document))


def test_an_over_constrained_loop_is_named():
    document = _document("crank-rocker")
    document["drivers"] = []
    # a second rocker between the same points: a loop that fixes nothing new (a redundant constraint)
    rocker = next(body for body in document["bodies"] if body["name"] == "rocker")
    document["bodies"].append({**rocker, "name": "rocker2"})
    document["joints"] += [{"kind": "revolute", "name": "O4b", "a": "ground.O4", "b": "rocker2.O4"},
                           {"kind": "revolute", "name": "Bb", "a": "coupler.B", "b": "rocker2.B"}]
    with pytest.raises(LinkageError, match=r"loop .*: over-constrained \(1 redundant constraint"):
        assemble(mechanism_from_document(document))


def test_a_mechanism_that_cannot_close_names_the_open_joint():
    document = _document("crank-rocker")
    rocker = next(body for body in document["bodies"] if body["name"] == "rocker")
    rocker["points"]["B"] = [rocker["points"]["O4"][0], rocker["points"]["O4"][1] + 0.02]  # far too short
    with pytest.raises(LinkageError, match=r"joint '\w+': the mechanism cannot be assembled near the sketch"):
        assemble(mechanism_from_document(document))


def test_files_in_toml_and_json_read_the_same(tmp_path):
    mechanism = MECHANISM_PRESETS["crank-rocker"]()
    json_path = tmp_path / "rocker.json"
    json_path.write_text(mechanism.model_dump_json(), encoding="utf-8")
    toml_path = tmp_path / "rocker.toml"
    toml_path.write_text(
        '\n'.join([
            'name = "crank-rocker"', 'g = 9.81', '[ground]', 'O2 = [0.0, 0.0]', 'O4 = [0.3, 0.0]',
            *[line for body in mechanism.bodies for line in (
                '[[bodies]]', f'name = "{body.name}"', f'mass = {body.mass!r}', f'inertia = {body.inertia!r}',
                f'com = [{body.centre[0]!r}, {body.centre[1]!r}]',
                'points = { ' + ", ".join(f"{k} = [{v[0]!r}, {v[1]!r}]" for k, v in body.points.items()) + ' }')],
            *[line for joint in mechanism.joints for line in (
                '[[joints]]', 'kind = "revolute"', f'name = "{joint.name}"', f'a = "{joint.a}"', f'b = "{joint.b}"')],
            '[[drivers]]', 'joint = "O2"', f'speed = {2 * math.pi!r}',
        ]),
        encoding="utf-8",
    )
    from_json, from_toml = load_mechanism(json_path), load_mechanism(toml_path)
    ignored = {"description", "trace"}
    assert from_json.model_dump(exclude=ignored) == from_toml.model_dump(exclude=ignored)
    assert assemble(from_toml).mobility == 0
    bad = tmp_path / "bad.toml"
    bad.write_text("name = [", encoding="utf-8")
    with pytest.raises(LinkageError, match=r"bad.toml: not valid TOML"):
        load_mechanism(bad)
    other = tmp_path / "rocker.yaml"
    other.write_text("name: x", encoding="utf-8")
    with pytest.raises(LinkageError, match=r"rocker.yaml: expected a .toml or .json file"):
        load_mechanism(other)
    with pytest.raises(LinkageError, match=r"missing.json: cannot read it"):
        load_mechanism(tmp_path / "missing.json")
