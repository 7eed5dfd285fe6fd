"""`python -m physics export` without the optional packages: our own TOML and JSON read back unchanged, MJCF's
structure (the spanning tree, the loop constraints, the actuators), pylinkage's JSON mapping and every refusal as
one line with exit 2. MuJoCo and pylinkage themselves check the files in test_formats_mjcf.py and
test_formats_pylinkage.py."""

from __future__ import annotations

import json
import math
import os
import xml.etree.ElementTree as ET

import pytest

from physics.chain_presets import preset_names
from physics.cli import main
from physics.errors import LinkageError
from physics.mechanism import MECHANISM_PRESETS, Driver, Prismatic
from physics.mechanism.files import load_mechanism
from physics.mechanism.mjcf import to_mjcf
from physics.mechanism.pylinkage_format import BLOCK_MASS, LINE_DENSITY, mechanism_from_pylinkage, to_pylinkage


@pytest.mark.parametrize("suffix", ["toml", "json"])
@pytest.mark.parametrize("preset", sorted(MECHANISM_PRESETS))
def test_our_own_format_reads_back_unchanged(preset, suffix, tmp_path):
    out = tmp_path / f"{preset}.{suffix}"
    assert main(["export", "--preset", preset, "--format", suffix, "--out", str(out)]) == 0
    assert load_mechanism(out) == MECHANISM_PRESETS[preset]()


@pytest.mark.parametrize("preset", ["triple-a", "four-bar", "chain"])
def test_chain_presets_become_mechanism_files(preset, tmp_path):
    out = tmp_path / "chain.toml"
    arguments = ["--links", "4"] if preset == "chain" else []
    assert main(["export", "--preset", preset, *arguments, "--format", "toml", "--out", str(out)]) == 0
    mechanism = load_mechanism(out)
    assert mechanism.name == preset
    assert len(mechanism.bodies) == (4 if preset == "chain" else 3)
    assert ("H" in mechanism.ground) == (preset == "four-bar")  # the four-bar's tip pinned to the ground


def test_mjcf_nests_the_spanning_tree_and_closes_loops_with_point_constraints(tmp_path, capsys):
    out = tmp_path / "sc.xml"
    assert main(["export", "--preset", "slider-crank", "--format", "mjcf", "--out", str(out)]) == 0
    root = ET.parse(out).getroot()
    world = root.find("worldbody")
    # the slider enters the tree first: the piston hangs from the world on a slide joint along the guide
    piston = world.find("body[@name='piston']")
    assert piston.find("joint").attrib == {"name": "guide", "type": "slide", "pos": "0 0 0", "axis": "1.0 0 0.0",
                                           "damping": "0.0"}
    rod = world.find("body[@name='crank']/body[@name='rod']")
    assert rod.find("joint").get("axis") == "0 -1 0"  # our counter-clockwise turn in MuJoCo's x-z plane
    assert [c.get("name") for c in root.find("equality")] == ["B"]  # pin B closes the loop
    assert root.find("option").get("gravity") == "0 0 -9.81"
    assert root.find("actuator") is None


def test_mjcf_motors_are_constant_torques_or_velocity_servos():
    sc = MECHANISM_PRESETS["slider-crank"]()
    torque = ET.fromstring(to_mjcf(sc.model_copy(update={"drivers": [Driver(joint="O", torque=0.25)]})))
    general = torque.find("actuator/general")
    assert (general.get("joint"), general.get("gear"), general.get("gainprm"), general.get("biasprm")) == (
        "O", "1.0", "0", "0.25 0 0")
    speed = ET.fromstring(to_mjcf(MECHANISM_PRESETS["crank-rocker"]()))
    kv_speed, _, minus_kv = (float(v) for v in speed.find("actuator/general").get("biasprm").split())
    assert kv_speed / -minus_kv == pytest.approx(2 * math.pi)  # force kv (speed - rate)


def test_pylinkage_json_maps_links_joints_and_drivers():
    document = to_pylinkage(MECHANISM_PRESETS["crank-rocker"]())
    kinds = {joint["id"]: joint["type"] for joint in document["joints"]}
    assert kinds == {"P": "tracker", "O2": "ground", "O4": "ground", "A": "revolute", "B": "revolute"}
    crank = next(link for link in document["links"] if link["id"] == "crank")
    assert crank["type"] == "driver" and crank["motor_joint"] == "O2"
    assert crank["angular_velocity"] == pytest.approx(2 * math.pi / 100)  # one turn a second, 0.01 s a step
    assert crank["initial_angle"] == pytest.approx(math.pi / 2)
    back = mechanism_from_pylinkage(document)
    assert back.body("coupler").mass == pytest.approx(LINE_DENSITY * 0.35)  # the bars A-B, P a tracker


def test_a_pylinkage_slot_becomes_a_slider_block():
    document = to_pylinkage(MECHANISM_PRESETS["slider-crank"]())
    slot = next(joint for joint in document["joints"] if joint["type"] == "prismatic")
    assert slot["axis"] == [1.0, 0.0] and slot["line_point"] == [0.0, 0.0]
    back = mechanism_from_pylinkage(document)
    block = next(body for body in back.bodies if body.name.endswith("-block"))
    assert block.mass == BLOCK_MASS
    assert any(isinstance(joint, Prismatic) and joint.body == block.name for joint in back.joints)


@pytest.mark.parametrize("arguments, message", [
    (["--preset", "crank-rocker", "--format", "xml"], "--format 'xml': allowed mjcf, pylinkage, toml, json"),
    (["--format", "mjcf"], "give exactly one of --preset NAME, --mechanism FILE.toml|.json or --pylinkage FILE.json"),
    (["--preset", "nope", "--format", "mjcf"], "--preset 'nope': allowed chebyshev-lambda"),
    (["--preset", "chain", "--links", "40", "--format", "mjcf"], "--links 40: allowed range 1..12"),
    (["--preset", "four-bar", "--links", "4", "--format", "mjcf"], "--links 4: applies to --preset chain only"),
    (["--preset", "crank-rocker", "--format", "mjcf", "--timestep", "nan"],
     "--timestep nan: allowed 0 < timestep <= 0.01 s"),
    (["--preset", "crank-rocker", "--format", "mjcf", "--timestep", "0.5"],
     "--timestep 0.5: allowed 0 < timestep <= 0.01 s"),
    (["--preset", "slider-crank", "--format", "pylinkage", "--timestep", "0.001"],
     "--timestep: applies to --format mjcf only"),
    (["--pylinkage", "missing.json", "--format", "toml"], "--pylinkage missing.json: cannot read it"),
])
def test_bad_input_is_one_line_and_exit_2(arguments, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["export", *arguments]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {message}")
    assert err.count("\n") == 1


@pytest.mark.parametrize("document, message", [
    ({"joints": [{"id": "A", "type": "Crank"}], "links": []}, "pylinkage's legacy format"),
    ({"joints": [{"id": "A", "position": [0, "x"]}], "links": [{"id": "L"}]},
     "joint 'A': position: expected [x, y] of finite numbers, got [0, 'x']"),
    ({"joints": [{"id": "A", "position": [0, 0]}, {"id": "B", "position": [1, 0]}],
      "links": [{"id": "arm", "type": "arc_driver", "joints": ["A", "B"]}]}, "link 'arm': an arc driver"),
    ({"joints": [{"id": "A", "position": [0, 0]}], "links": [{"id": "arm", "joints": ["A", "Z"]}]},
     "link 'arm': no joint 'Z'"),
    ({"joints": [{"id": "A", "position": [0, 0]}], "links": [{"id": "arm", "joints": ["A"]}]},
     "link 'arm': a link needs at least two joints"),
    ({"joints": [{"id": "A", "position": [0, 0]}, {"id": "B", "position": [1, 0]},
                 {"id": "T", "type": "tracker", "ref_joint1_id": "A", "ref_joint2_id": "Q"}],
      "links": [{"id": "arm", "joints": ["A", "B"]}]}, "joint 'T': a tracker must refer to two joints of one link"),
    ([1, 2], "expected pylinkage's JSON object"),
])
def test_bad_pylinkage_files_are_one_line(document, message, tmp_path, capsys):
    source = tmp_path / "bad.json"
    source.write_text(json.dumps(document))
    assert main(["export", "--pylinkage", str(source), "--format", "toml"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 + ("note:" in err[0])  # the density note is printed only after the file is read
    assert err[-1].startswith(f"error: {source}: ")
    assert message in err[-1]


def test_what_pylinkage_cannot_hold_is_refused_naming_it():
    sc = MECHANISM_PRESETS["slider-crank"]()
    with pytest.raises(LinkageError, match=r"^driver on 'O': a torque motor has no pylinkage counterpart"):
        to_pylinkage(sc.model_copy(update={"drivers": [Driver(joint="O", torque=1.0)]}))
    moving_guide = [joint.model_copy(update={"on": "crank", "through": "A"}) if joint.name == "guide" else joint
                    for joint in sc.joints]
    with pytest.raises(LinkageError, match=r"^joint 'guide': pylinkage's slider is a pin in a slot fixed to the ground"):
        to_pylinkage(sc.model_copy(update={"joints": moving_guide}))


# What a format cannot hold, and the one line that says so: pylinkage has no gears.
REFUSED = {("geared-five-bar", "pylinkage"): "error: joint 'gears': a gear pair has no pylinkage counterpart"}


def test_every_preset_exports_to_every_format_or_says_why(tmp_path, capsys):
    """Every mechanism and chain preset writes MJCF and pylinkage's JSON (the undriven ones too: pylinkage keeps
    their geometry), except what a format cannot hold (REFUSED), refused in one line."""
    for preset in [*sorted(MECHANISM_PRESETS), *preset_names()]:
        for kind in ("mjcf", "pylinkage"):
            code = main(["export", "--preset", preset, "--format", kind, "--out", str(tmp_path / "out")])
            error = capsys.readouterr().err.strip()
            if (preset, kind) in REFUSED:
                assert code == 2 and error.startswith(REFUSED[preset, kind]) and "\n" not in error, (preset, error)
            else:
                assert code == 0, (preset, kind, error)


def test_toml_quotes_any_name_and_text(tmp_path):
    """Point names and descriptions are the user's text: quotes, newlines, backslashes and accents survive."""
    base = MECHANISM_PRESETS["crank-rocker"]()
    odd_points = {**base.body("coupler").points, 'P "tip" \\ é': (0.1, 0.2)}
    bodies = [body.model_copy(update={"points": odd_points}) if body.name == "coupler" else body
              for body in base.bodies]
    odd = base.model_copy(update={"bodies": bodies, "description": 'two lines\nwith "quotes" and \\ and \t tab'})
    source = tmp_path / "odd.json"
    source.write_text(json.dumps(odd.model_dump(mode="json")))
    out = tmp_path / "odd.toml"
    assert main(["export", "--mechanism", str(source), "--format", "toml", "--out", str(out)]) == 0
    assert load_mechanism(out) == odd


def test_hostile_files_and_outputs_are_one_line(tmp_path, capsys):
    """A device, a FIFO or a folder given as the pylinkage file is refused without reading it (never a hang);
    an output that cannot be written is refused before any work, or when the write fails."""
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    big = tmp_path / "big.json"
    with open(big, "wb") as handle:  # sparse: 20 MB by stat, nothing on disk
        handle.truncate(20_000_000)
    for source, needle in (("/dev/zero", "a device"), (str(fifo), "a pipe (FIFO)"), (str(tmp_path), "a folder"),
                           (str(big), "1000000")):
        assert main(["export", "--pylinkage", source, "--format", "toml"]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"error: --pylinkage {source}: ") and needle in err and err.count("\n") == 1, err
    for out, needle in ((str(tmp_path), "is a folder"), (str(tmp_path / "no" / "x.xml"), "does not exist"),
                        ("/dev/full", "could not write")):
        assert main(["export", "--preset", "slider-crank", "--format", "mjcf", "--out", out]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"error: --out {out}") and needle in err and err.count("\n") == 1, err
