"""Design mode's model (physics/mechanism/design.py, design_analysis.py): edits, undo/redo, topology, drags,
coupler curves, and files."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from physics.cli import main
from physics.errors import LinkageError
from physics.mechanism import MECHANISM_PRESETS
from physics.mechanism.assembly import ASSEMBLY_TOLERANCE, assemble, sketch_size
from physics.mechanism.constraints import Constraints
from physics.mechanism.design import Design, History, design_from_mechanism
from physics.mechanism.design_analysis import (
    check_assembles,
    coupler_curve,
    design_from_text,
    design_to_text,
    drag,
    topology_of,
)
from physics.mechanism.files import mechanism_from_text
from physics.mechanism.writer import to_document
from physics.studies.design_bench import drag_latency


def four_bar() -> Design:
    """A crank-rocker drawn from nothing: crank 0.1, coupler 0.43, rocker 0.25, ground 0.4 (Grashof: s + l < p + q)."""
    design = Design().add_ground("O2", (0.0, 0.0)).add_ground("O4", (0.4, 0.0))
    design = design.add_bar("crank", ("A0", (0.0, 0.0)), ("A", (0.1, 0.0)))
    design = design.add_bar("coupler", ("A", (0.1, 0.0)), ("B", (0.45, 0.25)))
    design = design.add_bar("rocker", ("B", (0.45, 0.25)), ("B0", (0.4, 0.0)))
    design = design.add_pin("O2p", "ground.O2", "crank.A0").add_pin("Ap", "crank.A", "coupler.A")
    return design.add_pin("Bp", "coupler.B", "rocker.B").add_pin("O4p", "rocker.B0", "ground.O4")


def test_a_four_bar_built_from_nothing_has_mobility_one_and_a_motor_drives_it():
    design = four_bar()
    free = topology_of(design)
    assert (free.bodies, free.joints, free.mobility, free.grubler) == (3, 4, 1, 1)
    assert free.loops == ("loop Ap - O2p - O4p - Bp",)
    assert free.text().startswith("mobility 1 ") and "no motor" in free.text()
    driven = topology_of(design.add_motor("O2p", speed=2 * math.pi))
    assert driven.mobility == 1 and "driven by 1 motor" in driven.text() and driven.text().endswith("0 free")


def test_a_slider_crank_with_a_slider_on_the_ground_has_mobility_one():
    design = Design().add_ground("O", (0.0, 0.0)).add_ground("rail", (0.0, 0.0))
    design = design.add_bar("crank", ("O", (0.0, 0.0)), ("A", (0.05, 0.0)))
    design = design.add_bar("rod", ("A", (0.05, 0.0)), ("B", (0.25, 0.0)))
    design = design.add_bar("piston", ("B", (0.25, 0.0)), ("C", (0.3, 0.0)))
    design = design.add_pin("O1", "ground.O", "crank.O").add_pin("A1", "crank.A", "rod.A")
    design = design.add_pin("B1", "rod.B", "piston.B").add_slider("S", "piston.B", "ground.rail", (1.0, 0.0))
    topology = topology_of(design)
    assert topology.mobility == 1 and topology.grubler == 1, topology.notice
    design = design.add_motor("O1", speed=3.0).set_trace("piston.B")
    xs = coupler_curve(design, samples=72)[:, 0]
    assert np.all(np.isfinite(xs))
    assert max(xs) - min(xs) == pytest.approx(0.1, rel=1e-6)  # the stroke is twice the crank


def test_an_extra_pin_that_over_constrains_is_refused_naming_its_loop():
    design = four_bar().add_bar("brace", ("P", (0.1, 0.0)), ("Q", (0.45, 0.25)))
    design = design.add_pin("P1", "crank.A", "brace.P").add_pin("Q1", "brace.Q", "rocker.B")
    topology = topology_of(design)
    assert topology.mobility is None and "over-constrained" in topology.notice and "loop" in topology.notice
    with pytest.raises(LinkageError, match="loop .*over-constrained"):
        check_assembles(design)


def test_an_impossible_drag_is_refused_naming_the_joint_and_the_last_design_stays():
    design = four_bar()
    with pytest.raises(LinkageError, match=r"joint '(O2p|Ap|Bp|O4p)': the mechanism cannot be assembled"):
        drag(design, "ground.O4", (3.0, 0.0))
    assert design == four_bar()


def test_a_drag_keeps_the_bars_lengths_and_the_branch_and_changes_the_coupler_curve():
    design = four_bar().add_motor("O2p", speed=2 * math.pi).set_trace("coupler.B")
    before = coupler_curve(design)
    moved = drag(design, "ground.O4", (0.42, 0.01), grid=0.01)
    assert moved.point("ground.O4") == (0.42, 0.01)
    for body in moved.bodies:
        old = dict(design.body(body.name).points)
        new = dict(body.points)
        first, second = list(old)
        assert math.dist(new[first], new[second]) == pytest.approx(math.dist(old[first], old[second]), abs=1e-9)
    assert moved.point("coupler.B")[1] > 0  # the branch drawn (B above the ground line) is kept
    after = coupler_curve(moved)
    assert np.all(np.isfinite(after)) and np.max(np.abs(after - before)) > 1e-3


def test_the_coupler_curve_closes_over_a_full_turn():
    curve = coupler_curve(four_bar().add_motor("O2p", speed=2 * math.pi).set_trace("coupler.B"))
    assert np.all(np.isfinite(curve)) and np.allclose(curve[0], curve[-1], atol=1e-9)


def reference_curve(design: Design, samples: int) -> np.ndarray:
    """The traced point swept the plain way, independent of coupler_curve's Newton: physics' own ``assemble`` of
    the mechanism with its motor (generic rows, least-squares steps) at each motor angle, from the last pose
    that assembled; NaN where it refuses."""
    mechanism = design.to_mechanism()
    free = mechanism.model_copy(update={"drivers": []})
    start = assemble(free).q
    (motor,) = mechanism.drivers
    pin = next(joint for joint in mechanism.joints if joint.name == motor.joint)
    bodies = [body.name for body in mechanism.bodies]

    def angle(end: str) -> float:
        name = end.partition(".")[0]
        return float(start[3 * bodies.index(name) + 2]) if name in bodies else 0.0

    offset = (angle(pin.b) - angle(pin.a)) / motor.speed  # the motor's row is zero at t = 0 at the sketch
    constraints = Constraints(mechanism)
    owner, _, point = mechanism.trace.partition(".")
    curve = np.full((samples + 1, 2), np.nan)
    q = start
    for k, t in enumerate(np.linspace(0.0, 2 * math.pi / abs(motor.speed), samples + 1)):
        try:
            q = assemble(mechanism, q, t + offset).q
        except LinkageError:
            continue
        curve[k] = constraints.body_point(q, bodies.index(owner), mechanism.body(owner).points[point])
    return curve


@pytest.mark.parametrize("preset", ["crank-rocker", "jansen-leg"])
def test_the_coupler_curve_is_the_one_assembled_pose_by_pose(preset):
    """coupler_curve's fast sweep (constant pieces built once, a parabola predicting each pose, LAPACK's solve)
    gives the curve a pose-by-pose assembly gives, to within a thousand assembly tolerances (both stop within
    the tolerance of the exact pose; the traced point is farther out than the joints), on the same branch: a
    pivot dragged a little first, as the Design tab does."""
    design = design_from_mechanism(MECHANISM_PRESETS[preset]())
    pivot = "ground.O4" if preset == "crank-rocker" else "ground.P"
    x, y = design.point(pivot)
    for moved in (design, drag(design, pivot, (x + 0.002, y - 0.001))):
        fast, reference = coupler_curve(moved, samples=120), reference_curve(moved, 120)
        assert np.all(np.isfinite(reference))
        size = sketch_size(moved.to_mechanism())
        np.testing.assert_allclose(fast, reference, rtol=0, atol=1e3 * ASSEMBLY_TOLERANCE * size)


def test_a_crank_that_cannot_turn_fully_breaks_the_curve_where_assembly_refuses():
    """A four-bar whose crank cannot make a full turn (not Grashof: the longest bar 0.5 plus the crank 0.3
    exceed the other two, 0.4 + 0.35): NaN rows exactly where pose-by-pose assembly refuses, the same points
    elsewhere (the curve resumes on its branch after the break)."""
    design = Design().add_ground("O2", (0.0, 0.0)).add_ground("O4", (0.5, 0.0))
    design = design.add_bar("crank", ("A0", (0.0, 0.0)), ("A", (0.3, 0.0)))
    design = design.add_bar("coupler", ("A", (0.3, 0.0)), ("B", (0.55, 0.3)))
    design = design.add_bar("rocker", ("B", (0.55, 0.3)), ("B0", (0.5, 0.0)))
    design = design.add_pin("O2p", "ground.O2", "crank.A0").add_pin("Ap", "crank.A", "coupler.A")
    design = design.add_pin("Bp", "coupler.B", "rocker.B").add_pin("O4p", "rocker.B0", "ground.O4")
    design = design.add_motor("O2p", speed=2 * math.pi).set_trace("coupler.B")
    fast, reference = coupler_curve(design, samples=72), reference_curve(design, 72)
    broken = np.isnan(reference[:, 0])
    assert broken.any() and not broken.all()  # the case breaks the curve
    np.testing.assert_array_equal(np.isnan(fast[:, 0]), broken)
    np.testing.assert_allclose(fast[~broken], reference[~broken], rtol=0,
                               atol=1e3 * ASSEMBLY_TOLERANCE * sketch_size(design.to_mechanism()))


def test_save_and_load_give_the_same_design_in_toml_and_json():
    design = four_bar().add_motor("O2p", speed=2 * math.pi).set_trace("coupler.B")
    assert design_from_text(design_to_text(design, "toml"), "d.toml") == design
    assert design_from_text(design_to_text(design, "json"), "d.json") == design


def test_a_design_of_the_four_bar_preset_runs_as_the_preset_does(tmp_path, capsys):
    design = design_from_mechanism(MECHANISM_PRESETS["crank-rocker"]())
    path = tmp_path / "design.toml"
    path.write_text(design_to_text(design))
    assert main(["simulate", "--mechanism", str(path), "--t-end", "0.2", "--samples", "11"]) == 0
    from_design = capsys.readouterr().out
    assert main(["simulate", "--preset", "crank-rocker", "--t-end", "0.2", "--samples", "11"]) == 0
    from_preset = capsys.readouterr().out
    assert from_design.count("\n") == 12 and from_design == from_preset


def test_the_crank_rocker_drawn_from_nothing_is_the_presets_mechanism_but_for_the_coupler_mass():
    """Drawn edit by edit from the preset's own points and names (a pin named as its ground point, "O2", as the
    file format allows): the same ground, bodies' points, pins, motor and traced point, the bars' masses from the
    same density, and the same coupler curve. One difference is by design: a three-point coupler drawn as a
    plate gets the plate's frame mass, not the preset's bar with a point riding on it."""
    preset = MECHANISM_PRESETS["crank-rocker"]()
    design = Design()
    for name, xy in preset.ground.items():
        design = design.add_ground(name, xy)
    for body in preset.bodies:
        corners = list(body.points.items())
        design = design.add_bar(body.name, *corners) if len(corners) == 2 else design.add_plate(body.name, corners)
    pin_names = {joint.name: joint.name for joint in preset.joints}
    for joint in preset.joints:
        design = design.add_pin(pin_names[joint.name], joint.a, joint.b)
    (driver,) = preset.drivers
    design = design.add_motor(pin_names[driver.joint], speed=driver.speed).set_trace(preset.trace)
    drawn = design.to_mechanism()
    assert drawn.ground == preset.ground and drawn.trace == preset.trace
    assert [(b.name, b.points) for b in drawn.bodies] == [(b.name, b.points) for b in preset.bodies]
    assert [(j.name, j.kind, j.a, j.b) for j in drawn.joints] == [(j.name, j.kind, j.a, j.b) for j in preset.joints]
    assert [(d.joint, d.speed, d.torque) for d in drawn.drivers] == [
        (pin_names[d.joint], d.speed, d.torque) for d in preset.drivers]
    for name in ("crank", "rocker"):
        mine, theirs = drawn.body(name), preset.body(name)
        assert (mine.mass, mine.inertia) == pytest.approx((theirs.mass, theirs.inertia), rel=1e-12)
        assert mine.centre == pytest.approx(theirs.centre, abs=1e-12)
    assert topology_of(design).text() == topology_of(design_from_mechanism(preset)).text()
    np.testing.assert_allclose(coupler_curve(design), coupler_curve(design_from_mechanism(preset)), atol=1e-9)


def test_edits_name_what_they_refuse():
    design = four_bar()
    with pytest.raises(LinkageError, match="ground point 'O2': name: a ground point of that name exists"):
        design.add_ground("O2", (1.0, 1.0))
    with pytest.raises(LinkageError, match="plate 'p': needs at least 3 points"):
        design.add_plate("p", [("a", (0.0, 0.0)), ("b", (1.0, 0.0))])
    with pytest.raises(LinkageError, match="motor on 'nope'"):
        design.add_motor("nope", speed=1.0)
    with pytest.raises(LinkageError, match="grid"):
        design.move_point("ground.O2", (0.1, 0.1), grid=0.0)


def test_a_joint_or_body_may_share_a_ground_points_name_as_in_the_file_format():
    """Ground points, bodies and joints are three namespaces, as in the file format (a ground point is always
    written ``ground.NAME``): the crank-rocker preset's pin ``O2`` on ground point ``O2`` opens, is drawn again and
    edited; a bare name held by two items is refused naming the forms that name one."""
    preset = MECHANISM_PRESETS["crank-rocker"]()
    opened = design_from_mechanism(preset)
    assert opened.to_mechanism() == preset
    drawn = four_bar().rename("O2p", "O2").add_bar("O4", ("p", (1.0, 1.0)), ("q", (1.2, 1.0)))
    assert {j.name for j in drawn.joints} >= {"O2"} and {b.name for b in drawn.bodies} >= {"O4"}
    assert drawn.add_ground("Ap", (1.0, 0.0)).point("ground.Ap") == (1.0, 0.0)
    with pytest.raises(LinkageError, match=r"delete 'O2': names a ground point and a joint; write ground\.O2 or "
                                           r"joint:O2"):
        opened.delete("O2")
    with pytest.raises(LinkageError, match=r"rename 'O2': names a ground point and a joint"):
        opened.rename("O2", "drive")
    without_pivot = opened.delete("ground.O2")  # the pivot and the pin on it (and its motor) go; nothing else
    assert [n for n, _ in without_pivot.ground] == ["O4"] and "O2" not in {j.name for j in without_pivot.joints}
    without_pin = opened.delete("joint:O2")
    assert [n for n, _ in without_pin.ground] == ["O2", "O4"] and without_pin.drivers == ()
    assert {j.name for j in without_pin.joints} == {"A", "B", "O4"}
    renamed = opened.rename("joint:O2", "drive").rename("ground.O2", "P")
    assert renamed.joints[0].name == "drive" and renamed.joints[0].a == "ground.P"
    assert renamed.drivers[0].joint == "drive" and topology_of(renamed).text() == topology_of(opened).text()
    assert opened.rename("body:crank", "O2").delete("body:O2").trace == preset.trace  # a joint "O2" is kept
    assert opened.delete("A").joints == opened.delete("joint:A").joints  # a bare name held once names it


@pytest.mark.parametrize(("edit", "field"), [
    (lambda d: d.add_bar("1bad", ("p", (0.0, 0.0)), ("q", (1.0, 0.0))), "bar '1bad': name: allowed a letter"),
    (lambda d: d.add_bar("x" * 41, ("p", (0.0, 0.0)), ("q", (1.0, 0.0))), "name: allowed a letter then up to 39"),
    (lambda d: d.add_bar("ground", ("p", (0.0, 0.0)), ("q", (1.0, 0.0))), "bar 'ground': name: 'ground' is reserved"),
    (lambda d: d.add_bar("b", ("p", (0.0, 0.0)), ("p", (1.0, 0.0))), "bar 'b': two points have the same name"),
    (lambda d: d.add_pin("", "crank.A", "rocker.B"), "pin '': name: allowed a letter"),
    (lambda d: d.add_pin("p" * 41, "crank.A", "rocker.B"), "name: allowed a letter then up to 39"),
    (lambda d: d.add_pin("Ap", "crank.A", "rocker.B"), "pin 'Ap': name: a joint of that name exists"),
    (lambda d: d.rename("crank", "coupler"), "new name 'coupler': name: a body of that name exists"),
    (lambda d: d.rename("crank", "ground"), "name: 'ground' is reserved for the fixed frame"),
])
def test_a_name_the_file_format_refuses_is_refused_naming_the_field_and_the_allowed_form(edit, field):
    """Each of these names is one the file format refuses (a body's name out of its pattern, ``ground`` as a
    body, more than 40 characters, an empty joint name, two points, bodies or joints of one name): the design
    refuses it too, in one line naming the item, the field and what is allowed."""
    with pytest.raises(LinkageError, match=re.escape(field)) as refused:
        edit(four_bar())
    assert "\n" not in str(refused.value)


def body_names() -> st.SearchStrategy[str]:
    """Any body name the file format takes: its pattern, at most 40 characters, not ``ground``."""
    return st.from_regex(r"\A[A-Za-z][A-Za-z0-9_-]{0,39}\Z").filter(lambda name: name != "ground")


@st.composite
def renamed_crank_rocker(draw) -> dict:
    """The crank-rocker preset's file with every name drawn from what the file format takes, names shared across
    ground points, bodies, joints and points often: pinned points of the pin references' form, any other point,
    ground point or joint of any text (a joint at most 40 characters)."""
    document = to_document(MECHANISM_PRESETS["crank-rocker"]())
    pinned = st.from_regex(r"\A[A-Za-z0-9_-]{1,12}\Z")
    bodies = draw(st.lists(body_names(), min_size=3, max_size=3, unique=True))
    shared = st.sampled_from(bodies)
    ground = draw(st.lists(st.one_of(shared, pinned), min_size=2, max_size=2, unique=True))
    joints = draw(st.lists(st.one_of(shared, st.sampled_from(ground), st.text(min_size=1, max_size=40)),
                           min_size=4, max_size=4, unique=True))
    pins = st.one_of(st.sampled_from([*ground, *bodies]), pinned).filter(lambda name: name not in ("O2", "O4", "P"))
    point_of = dict(zip(("A", "B"), draw(st.lists(pins, min_size=2, max_size=2, unique=True))))
    loose = draw(st.one_of(st.sampled_from([*ground, *joints]), st.text(max_size=20)).filter(
        lambda name: name not in point_of.values()))  # a point of the coupler no pin holds
    ground_of = dict(zip(document["ground"], ground))
    body_of = dict(zip((body["name"] for body in document["bodies"]), bodies))

    def reference(old: str) -> str:
        owner, _, point = old.partition(".")
        if owner == "ground":
            return f"ground.{ground_of[point]}"
        return f"{body_of[owner]}.{point_of.get(point, point)}"

    document["ground"] = {ground_of[name]: xy for name, xy in document["ground"].items()}
    for body in document["bodies"]:
        body["name"] = body_of[body["name"]]
        body["points"] = {point_of.get(name, name): xy for name, xy in body["points"].items()}
    coupler = document["bodies"][1]["points"]
    coupler[loose] = coupler.pop("P")
    joint_of = {joint["name"]: new for joint, new in zip(document["joints"], joints)}
    for joint in document["joints"]:
        joint.update(name=joint_of[joint["name"]], a=reference(joint["a"]), b=reference(joint["b"]))
    for driver in document["drivers"]:
        driver["joint"] = joint_of[driver["joint"]]
    document["trace"] = f"{document['bodies'][1]['name']}.{loose}"
    return document


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(renamed_crank_rocker(), st.sampled_from(["toml", "json"]))
def test_any_names_the_file_format_takes_open_as_a_design_and_save_back_the_same_mechanism(document, fmt):
    """A file the command line's reader takes, whatever its names (a pin named as its ground point or as a body,
    a ground point named as a body, a point of any text), opens as a design and saves back, TOML or JSON, as the
    same mechanism; and every joint and ground point of it can be renamed by the form that names it alone."""
    text = json.dumps(document)
    mechanism = mechanism_from_text(text, "renamed.json")  # what simulate --mechanism reads
    design = design_from_text(text, "renamed.json")
    saved = design_to_text(design, fmt)
    assert mechanism_from_text(saved, f"saved.{fmt}") == mechanism
    assert design_from_text(saved, f"saved.{fmt}") == design
    new = next(f"new{k}" for k in range(10) if f"new{k}" not in design.names())
    for k, joint in enumerate(mechanism.joints):
        renamed = design.rename(f"joint:{joint.name}", new)
        assert renamed.joints[k].name == new and renamed.to_mechanism().joints[k].kind == joint.kind
    for name, xy in mechanism.ground.items():
        assert design.rename(f"ground.{name}", new).point(f"ground.{new}") == xy


def test_a_name_beyond_u_ffff_saves_as_toml_that_reads_back():
    """TOML escapes such a character ``\\UXXXXXXXX``; JSON's surrogate pair escapes, which the TOML writer wrote
    before, are not TOML (the file was refused when read back)."""
    document = to_document(MECHANISM_PRESETS["crank-rocker"]())
    document["joints"][1]["name"] = "A \U0001f527 \u00e9\x7f"
    design = design_from_text(json.dumps(document), "spanner.json")
    saved = design_to_text(design, "toml")
    assert "\\U0001f527 \\u00e9\\u007f" in saved and saved.isascii()
    assert design_from_text(saved, "spanner.toml") == design


@pytest.mark.parametrize(("where", "refusal"), [
    (("ground", "O\ud800"), "ground: 'O\\ud800': not Unicode text"),
    (("joint", "A\udc00"), "joint 'A\\udc00': name: 'A\\udc00': not Unicode text"),
    (("point", "P\udfff"), "body 'coupler': points: 'P\\udfff': not Unicode text"),
])
def test_a_json_name_of_a_lone_surrogate_is_refused_naming_where(where, refusal):
    """JSON can escape half a surrogate pair, which is no character: no UTF-8 file, TOML or CSV could write such
    a name back (the design saved it as another name), so a file holding one is refused where it is read."""
    kind, name = where
    document = to_document(MECHANISM_PRESETS["crank-rocker"]())
    if kind == "ground":
        document["ground"][name] = [1.0, 1.0]
    elif kind == "joint":
        document["joints"][1]["name"] = name
    else:
        document["bodies"][1]["points"][name] = document["bodies"][1]["points"].pop("P")
        document["trace"] = f"coupler.{name}"
    text = json.dumps(document)
    for read in (lambda: mechanism_from_text(text, "odd.json"), lambda: design_from_text(text, "odd.json")):
        with pytest.raises(LinkageError, match=re.escape(f"odd.json: {refusal} (a lone surrogate escape)")):
            read()
    fine = to_document(MECHANISM_PRESETS["crank-rocker"]())
    fine["ground"]["\U0001f527"] = [2.0, 2.0]  # a whole pair beyond U+FFFF (escaped as two) is a character
    assert "\U0001f527" in mechanism_from_text(json.dumps(fine), "fine.json").ground


def test_a_body_given_its_own_mass_keeps_it_in_the_file_until_a_point_moves():
    design = four_bar().set_mass("coupler", 2.5, inertia=0.04, com=(0.3, 0.1))
    coupler = design.to_mechanism().body("coupler")
    assert (coupler.mass, coupler.inertia, coupler.com) == (2.5, 0.04, (0.3, 0.1))
    assert design_from_text(design_to_text(design), "d.toml") == design
    drawn = four_bar().to_mechanism().body("coupler")
    for back in (design.set_mass("coupler", None), design.move_point("coupler.B", design.point("coupler.B"))):
        body = back.to_mechanism().body("coupler")
        assert (body.mass, body.inertia, body.centre) == (drawn.mass, drawn.inertia, drawn.centre)
    with pytest.raises(LinkageError, match="body 'coupler': mass"):
        design.set_mass("coupler", -1.0, inertia=0.1)
    with pytest.raises(LinkageError, match="body 'coupler': inertia"):
        design.set_mass("coupler", 1.0)


def test_a_point_of_a_body_not_yet_joined_to_the_ground_drags_freely():
    design = four_bar().add_bar("loose", ("p", (1.0, 1.0)), ("q", (1.2, 1.0)))
    assert drag(design, "loose.q", (1.3, 1.1)).point("loose.q") == (1.3, 1.1)


def test_deleting_a_body_removes_its_joints_and_their_motors():
    design = four_bar().add_motor("O2p", speed=1.0).set_trace("crank.A").delete("crank")
    assert {j.name for j in design.joints} == {"Bp", "O4p"} and design.drivers == () and design.trace is None


def test_renaming_a_body_renames_every_reference():
    design = four_bar().add_motor("O2p", speed=1.0).rename("crank", "input").rename("O2p", "drive")
    assert design.to_mechanism().joints[0].b == "input.A0" and design.drivers[0].joint == "drive"
    assert topology_of(design).mobility == 1


def test_undo_and_redo_with_nothing_to_do_are_refused():
    history = History()
    with pytest.raises(LinkageError, match="nothing to undo"):
        history.undo()
    with pytest.raises(LinkageError, match="nothing to redo"):
        history.redo()


NAMES = st.sampled_from(["a", "b", "c", "d", "e", "f", "g", "h", "O2", "crank", "Ap", "x-1", "1bad", "ground"])
POINT_NAMES = st.sampled_from(["p", "q", "r"])
ITEMS = st.one_of(NAMES, st.sampled_from(["ground.O2", "ground.a", "body:crank", "body:a", "joint:Ap", "joint:a"]))
# one coordinate in ten is out of bounds (NaN or 1e9 m): most edits are valid, some must be refused
COORDINATE = st.integers(0, 9).flatmap(
    lambda k: st.sampled_from([float("nan"), 1e9]) if k == 0 else st.floats(-2.0, 2.0, allow_nan=False))
STARTS = st.sampled_from(["empty", "four-bar", "driven four-bar"])
XY = st.tuples(COORDINATE, COORDINATE)


def references(design: Design) -> list[str]:
    refs = [f"ground.{name}" for name, _ in design.ground]
    refs += [f"{body.name}.{point}" for body in design.bodies for point, _ in body.points]
    return refs + ["nobody.p"]


@st.composite
def edit(draw, design: Design):
    refs = references(design)
    which = draw(st.sampled_from(["ground", "bar", "plate", "pin", "slider", "motor", "delete", "rename", "move",
                                  "trace", "drag", "mass"]))
    if which == "ground":
        return lambda d: d.add_ground(draw(NAMES), draw(XY))
    if which == "bar":
        return lambda d: d.add_bar(draw(NAMES), (draw(POINT_NAMES), draw(XY)), (draw(POINT_NAMES), draw(XY)))
    if which == "plate":
        corners = draw(st.lists(st.tuples(POINT_NAMES, XY), min_size=2, max_size=4))
        return lambda d: d.add_plate(draw(NAMES), corners)
    if which == "pin":
        return lambda d: d.add_pin(draw(NAMES), draw(st.sampled_from(refs)), draw(st.sampled_from(refs)))
    if which == "slider":
        return lambda d: d.add_slider(draw(NAMES), draw(st.sampled_from(refs)), draw(st.sampled_from(refs)), draw(XY))
    if which == "motor":
        speed = draw(st.one_of(st.none(), st.floats(-2e3, 2e3)))
        return lambda d: d.add_motor(draw(NAMES), speed=speed, torque=None if speed is not None else 1.0)
    if which == "delete":
        return lambda d: d.delete(draw(st.one_of(ITEMS, st.just("motor:a"))))
    if which == "rename":
        return lambda d: d.rename(draw(ITEMS), draw(NAMES))
    if which == "trace":
        return lambda d: d.set_trace(draw(st.sampled_from(refs)))
    if which == "drag":
        return lambda d: drag(d, draw(st.sampled_from(refs)), draw(XY))
    if which == "mass":
        bodies = st.sampled_from([b.name for b in design.bodies] + ["nobody"])
        amount = st.one_of(st.none(), st.just(float("nan")), st.floats(-1.0, 2e6))
        return lambda d: d.set_mass(draw(bodies), draw(amount), draw(amount), draw(st.one_of(st.none(), XY)))
    return lambda d: d.move_point(draw(st.sampled_from(refs)), draw(XY), draw(st.one_of(st.none(), st.just(0.05))))


def well_formed(design: Design) -> None:
    """A design's invariants: names unique among each kind's (the file format's namespaces), every joint's
    points exist; when complete it is a valid Mechanism."""
    for names in ([n for n, _ in design.ground], [b.name for b in design.bodies], [j.name for j in design.joints]):
        assert len(names) == len(set(names))
    if design.is_complete():
        design.to_mechanism()  # raises if any reference dangles
        topology_of(design)  # never raises: a notice at worst


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_random_edits_keep_the_design_valid_or_are_refused_and_undo_redo_are_exact(data):
    start = data.draw(STARTS)
    history = History(current=Design() if start == "empty" else four_bar() if start == "four-bar" else
                      four_bar().add_motor("O2p", speed=1.0).set_trace("coupler.B"))
    for _ in range(data.draw(st.integers(1, 14))):
        before = history.current
        change = data.draw(edit(before))
        try:
            after = change(before)
        except LinkageError as error:
            assert str(error)  # one notice, and nothing changed
            assert history.current is before
            continue
        well_formed(after)
        history.apply(after)
        assert history.undo() == before
        assert history.redo() == after


def test_the_drag_benchmark_times_a_full_curve_of_each_preset():
    for preset in ("crank-rocker", "jansen-leg"):
        row = drag_latency(preset, 2)
        assert row["curve_points_assembled"] == row["curve_samples"] + 1 and 0 < row["min_s"] <= row["median_s"]


def test_bench_suite_design_writes_its_report(tmp_path, capsys):
    assert main(["bench", "--suite", "design", "--quick", "--no-progress", "--out", str(tmp_path)]) == 0
    document = json.loads((tmp_path / "design.json").read_text())
    assert [row["preset"] for row in document["drags"]] == ["crank-rocker", "jansen-leg"]
    assert "| jansen-leg | ground.P |" in capsys.readouterr().out
