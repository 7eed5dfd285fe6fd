"""Every command line for every preset and mechanism file (issue 24, "Every study for every mechanism").

``presets`` lists chains and mechanisms in one table; ``simulate``, ``accelerations``, ``fbd``,
``equilibrium`` and ``warm`` take a mechanism preset (``--preset jansen-leg``) or a file (``--mechanism
FILE``). A mechanism run's table is the ``mechanism`` command's, byte for byte; the accelerations of the three
formulations agree; the forces ``fbd`` lists balance ``m a_G`` and ``I alpha``; the rest poses of
``equilibrium`` are at rest and the stable ones are minima of the potential. Refusals are one line, exit 2,
checked in a child process where the exit code and the line are the contract.
"""

from __future__ import annotations

import csv
import io
import json
import os
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from physics.chain_presets import get_preset, preset_names
from physics.cli import main
from physics.errors import LinkageError
from physics.mechanism import MECHANISM_PRESETS, assemble
from physics.mechanism.constraints import Constraints
from physics.mechanism.numeric_dae import MechanismDAE
from physics.mechanism.simulate import simulate_mechanism

ROOT = Path(__file__).resolve().parents[2]
CHAIN_KEYS = {"name", "description", "links", "params", "theta", "omega", "pin", "trace", "t_end"}


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def child(*argv: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "physics", *argv], capture_output=True, text=True, timeout=600,
                          cwd=ROOT)


def refused_line(result: subprocess.CompletedProcess) -> str:
    """The one line of a refusal (exit 2, nothing on stdout, one line on stderr)."""
    assert result.returncode == 2, (result.returncode, result.stderr)
    assert result.stdout == "" and result.stderr.count("\n") == 1 and "Traceback" not in result.stderr
    assert result.stderr.startswith("error: ")
    return result.stderr.strip()


def test_presets_lists_every_chain_and_mechanism_in_one_table(capsys):
    code, out, _ = run(capsys, "presets")
    entries = json.loads(out)
    names = [entry["name"] for entry in entries]
    assert code == 0 and names == [*preset_names(), *MECHANISM_PRESETS]
    for entry in entries[: len(preset_names())]:
        assert set(entry) - {"grashof"} == CHAIN_KEYS  # a chain's keys are a contract: no new one
    for entry in entries[len(preset_names()):]:
        mechanism = MECHANISM_PRESETS[entry["name"]]()
        assembled = assemble(mechanism)
        assert entry["kind"] == "mechanism"
        assert entry["bodies"] == [body.name for body in mechanism.bodies]
        assert entry["joints"] == [joint.name for joint in mechanism.joints]
        assert entry["mobility"] == assembled.mobility and entry["mechanism_mobility"] == assembled.mechanism_mobility
        assert entry["motors"] == len(mechanism.drivers) and entry["trace"] == mechanism.trace
        _, described, _ = run(capsys, "mechanism", "--preset", entry["name"], "--json")
        summary = json.loads(described)
        assert all(entry[key] == summary[key] for key in entry if key not in ("kind", "trace"))


def test_simulate_a_mechanism_preset_writes_the_mechanism_commands_table(capsys, tmp_path):
    """Byte for byte the ``mechanism`` command's CSV; the JSON table has the CSV's names as keys, the same
    numbers; without --out the table goes to stdout."""
    argv = ["--t-end", "0.5", "--samples", "6"]
    assert run(capsys, "simulate", "--preset", "jansen-leg", *argv, "--out", str(tmp_path / "a.csv"))[0] == 0
    assert run(capsys, "mechanism", "--preset", "jansen-leg", *argv, "--out", str(tmp_path / "b.csv"))[0] == 0
    table = (tmp_path / "a.csv").read_text()
    assert table == (tmp_path / "b.csv").read_text()
    code, out, _ = run(capsys, "simulate", "--preset", "jansen-leg", *argv)
    assert code == 0 and out == table
    rows = list(csv.reader(io.StringIO(table)))
    header = rows[0]
    assert header[:7] == ["t", "trace_x", "trace_y", "kinetic", "potential", "energy", "constraint_residual"]
    assert "lambda[O: driven angle]" in header and all(name.startswith("lambda[") for name in header[7:])
    assert run(capsys, "simulate", "--preset", "jansen-leg", *argv, "--out", str(tmp_path / "a.json"))[0] == 0
    document = json.loads((tmp_path / "a.json").read_text())
    assert list(document) == header
    numbers = np.array(rows[1:], dtype=float)
    for k, name in enumerate(header):
        assert np.array(document[name], dtype=float) == pytest.approx(numbers[:, k], rel=1e-15, abs=0)


def test_simulate_a_mechanism_file_takes_every_option_that_applies(capsys, tmp_path):
    path = tmp_path / "slider.json"
    path.write_text(MECHANISM_PRESETS["slider-crank"]().model_dump_json(), encoding="utf-8")
    code, out, _ = run(capsys, "simulate", "--mechanism", str(path), "--t-end", "0.3", "--samples", "4", "--method",
                       "lagrange", "--stabilization", "baumgarte", "--rtol", "1e-9", "--atol", "1e-9",
                       "--integrator", "DOP853", "--json", "--out", str(tmp_path / "run.csv"))
    report = json.loads(out)["run"]
    assert code == 0 and report["method"] == "lagrange" and report["stabilization"] == "baumgarte"
    assert report["samples"] == 4 and report["t_end"] == pytest.approx(0.3)
    # the tolerances reach the integrator: a loose run differs from a tight one, both near the truth
    tight = simulate_mechanism(MECHANISM_PRESETS["slider-crank"](), 0.3, 4, rtol=1e-12, atol=1e-12)
    loose = {}
    for rtol in ("1e-4", "1e-12"):
        _, table, _ = run(capsys, "simulate", "--mechanism", str(path), "--t-end", "0.3", "--samples", "4",
                          "--rtol", rtol, "--atol", rtol, "--format", "json")
        loose[rtol] = np.array(json.loads(table)["energy"])
    assert np.max(np.abs(loose["1e-12"] - tight.energy)) < 1e-10 < np.max(np.abs(loose["1e-4"] - tight.energy))


def test_set_changes_the_numbers_of_a_mechanism(capsys):
    """``--set g=0``: the slider-crank released at rest stays at rest and every reaction vanishes; ``--set
    crank.mass=...`` changes the crank's weight in the pin reaction at O (the crank at rest at t = 0)."""
    code, out, _ = run(capsys, "simulate", "--preset", "slider-crank", "--set", "g=0", "--t-end", "0.2",
                       "--samples", "3", "--format", "json")
    table = json.loads(out)
    assert code == 0 and max(table["kinetic"]) == 0.0
    assert max(abs(v) for name, values in table.items() if name.startswith("lambda[") for v in values) == 0.0
    masses = {}
    for mass in ("0.05", "1.05"):
        _, out, _ = run(capsys, "accelerations", "--preset", "slider-crank", "--method", "dae", "--set",
                        f"crank.mass={mass}")
        masses[mass] = json.loads(out)
    assert masses["0.05"]["methods"]["dae"]["reactions"] != masses["1.05"]["methods"]["dae"]["reactions"]


@pytest.mark.parametrize("option, value, needle", [
    ("--links", "3", "--links: does not apply to a mechanism"),
    ("--pin", "1,1", "--pin: does not apply to a mechanism"),
    ("--trace", "1,0.5", "--trace: does not apply to a mechanism"),
    ("--damping", "0.1", "--set JOINT.damping=C"),
    ("--backend", "gpu", "backend = 'gpu': allowed values compiled, scipy"),
    ("--step", "0", "step = 0.0: allowed range 0 < step <= 1"),
    ("--max-steps", "0", "max_steps = 0: allowed range 1 <= max_steps <= 1e9"),
    ("--integrator", "euler", "integrator = 'euler': allowed values RK45, DOP853, ode45, Radau, LSODA, midpoint"),
    ("--integrator", "variational", "integrator = variational: needs method = lagrange (got dae)"),
    ("--set", "crank.colour=2", "--set crank.colour=2: names g, BODY.{mass,inertia}"),
    ("--set", "crank.mass=nan", "--set crank.mass=nan: expected a finite number"),
])
def test_an_option_that_does_not_apply_to_a_mechanism_is_refused_in_one_line(option, value, needle):
    line = refused_line(child("simulate", "--preset", "slider-crank", option, value))
    assert needle in line


def test_accelerations_of_the_three_methods_agree_with_every_reaction_named_as_the_csv(capsys, tmp_path):
    mechanism = MECHANISM_PRESETS["crank-rocker"]()
    run_ = simulate_mechanism(mechanism, 0.3, 2)
    q, qdot = run_.q[-1], run_.qdot[-1]
    state = ",".join(repr(float(v)) for v in np.concatenate([q, qdot]))
    code, out, _ = run(capsys, "accelerations", "--preset", "crank-rocker", f"--state={state}", "--time", "0.3")
    document = json.loads(out)
    assert code == 0 and list(document["methods"]) == ["dae", "lagrange", "newton_euler"]
    assert document["disagreement"]["qddot"] <= 1e-10 and document["disagreement"]["reactions"] <= 1e-10
    assert list(document["methods"]["dae"]["reactions"]) == [f"lambda[{name}]" for name in run_.row_names]
    solution = MechanismDAE(mechanism).solve(q, qdot)
    assert np.allclose(document["methods"]["dae"]["qddot"], solution.qddot, rtol=0, atol=1e-12)
    assert np.allclose(list(document["methods"]["lagrange"]["reactions"].values()), run_.reaction_rows[-1],
                       rtol=0, atol=1e-8 * (1 + np.max(np.abs(run_.reaction_rows[-1]))))
    # without --state: the start of a run, in one method
    code, out, _ = run(capsys, "accelerations", "--preset", "crank-rocker", "--method", "newton_euler")
    start = json.loads(out)
    assert list(start["methods"]) == ["newton_euler"] and np.allclose(start["q"], run_.q[0], atol=1e-12)


def test_accelerations_refuse_a_state_off_the_constraints_naming_the_gap():
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    q = assemble(mechanism).q
    q[3] += 1e-3  # the rod's centre moved 1 mm: joints A and B open
    state = ",".join(repr(float(v)) for v in np.concatenate([q, np.zeros_like(q)]))
    line = refused_line(child("accelerations", "--preset", "slider-crank", f"--state={state}"))
    assert line.startswith("error: --state: the pose is off the constraints: joint 'A' (x gap) is 0.001 from closing")
    q = assemble(mechanism).q
    qdot = np.zeros_like(q)
    qdot[6] = 1.0  # the piston moves alone
    state = ",".join(repr(float(v)) for v in np.concatenate([q, qdot]))
    assert "the velocities break the constraints: joint 'B'" in refused_line(
        child("accelerations", "--preset", "slider-crank", "--state", state))
    assert "expected 18 comma-separated numbers" in refused_line(
        child("accelerations", "--preset", "slider-crank", "--state", "0,0"))


@pytest.mark.parametrize("method", ["dae", "lagrange"])
def test_fbd_forces_on_each_body_balance_its_m_a_and_moment(capsys, method):
    """Every load on each body of the slider-crank at t = 0.1 s sums to ``m a_G`` and its moments about G to
    ``I alpha``; the guide pushes across itself only (no friction); each pin's forces on its two bodies are
    equal and opposite (Newton's third law, from two separate diagrams)."""
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    diagrams = {}
    for body in mechanism.bodies:
        code, out, _ = run(capsys, "fbd", "--preset", "slider-crank", "--body", body.name, "--time", "0.1",
                           "--method", method, "--json")
        diagram = json.loads(out)
        assert code == 0 and diagram["body"] == body.name and diagram["method"] == method
        diagrams[body.name] = diagram
        net = np.sum([load["force"] for load in diagram["loads"]], axis=0)
        moment = sum(load["moment"] for load in diagram["loads"])
        scale = 1.0 + max(load["magnitude"] for load in diagram["loads"])
        assert np.allclose(net, body.mass * np.array(diagram["com_acceleration"]), rtol=0, atol=1e-9 * scale)
        assert abs(moment - body.inertia * diagram["alpha"]) <= 1e-9 * scale
        for load in diagram["loads"]:  # a force's moment about G is r x F
            if load["kind"] == "pin":
                arm = np.array(load["at"]) - np.array(diagram["centre"])
                assert load["moment"] == pytest.approx(arm[0] * load["force"][1] - arm[1] * load["force"][0],
                                                       abs=1e-12 * scale)
        assert diagram["loads"][0] == {"name": "gravity", "kind": "gravity", "force": [0.0, -mechanism.g * body.mass],
                                       "moment": 0.0, "at": diagram["centre"], "magnitude": mechanism.g * body.mass}
    guide = next(load for load in diagrams["piston"]["loads"] if load["kind"] == "slider")
    assert guide["force"][0] == 0.0 and abs(guide["force"][1]) > 0.1  # along the guide (x): nothing
    on_rod = {load["name"].split()[1]: load["force"] for load in diagrams["rod"]["loads"] if load["kind"] == "pin"}
    on_crank = next(load["force"] for load in diagrams["crank"]["loads"] if load["name"].startswith("pin A"))
    on_piston = next(load["force"] for load in diagrams["piston"]["loads"] if load["name"].startswith("pin B"))
    assert np.allclose(on_rod["A"], -np.array(on_crank), atol=1e-12)
    assert np.allclose(on_rod["B"], -np.array(on_piston), atol=1e-12)


def test_fbd_shows_a_speed_motors_torque_and_a_torque_motors(capsys):
    code, out, _ = run(capsys, "fbd", "--preset", "crank-rocker", "--body", "crank", "--json")
    loads = {load["name"]: load for load in json.loads(out)["loads"]}
    _, acc, _ = run(capsys, "accelerations", "--preset", "crank-rocker", "--method", "dae")
    torque = json.loads(acc)["methods"]["dae"]["reactions"]["lambda[O2: driven angle]"]
    assert code == 0 and loads["motor O2 (speed, by ground)"]["moment"] == pytest.approx(torque, rel=1e-12)
    code, out, _ = run(capsys, "fbd", "--preset", "crank-rocker", "--set", "O2.torque=0.25", "--body", "crank",
                       "--json")
    diagram = json.loads(out)
    kinds = {load["kind"]: load for load in diagram["loads"]}
    assert code == 0 and "motor" not in kinds and kinds["torque motor"]["moment"] == 0.25
    assert abs(diagram["balance"]["moment_gap"]) <= 1e-12 and diagram["balance"]["force_gap"] <= 1e-12


def test_fbd_of_a_mechanism_draws_its_loads_as_svg(capsys, tmp_path):
    out = tmp_path / "crank.svg"
    code, printed, _ = run(capsys, "fbd", "--preset", "crank-rocker", "--body", "crank", "--time", "0.1", "--out",
                           str(out))
    text = out.read_text()
    assert code == 0 and printed == "" and text.startswith("<svg") and text.rstrip().endswith("</svg>")
    for name in ("gravity", "pin O2 (by ground)", "pin A (by coupler)", "motor O2 (speed, by ground)", "m a_G"):
        assert name in text
    assert text.count("marker-end=") == 3  # gravity and two pins as arrows; the motor's torque a couple
    assert refused_line(child("fbd", "--preset", "crank-rocker", "--body", "crank", "--out", "x.png")) == (
        "error: --out x.png: unknown file type '.png'; allowed .svg")


def test_fbd_of_a_mechanism_refuses_a_bar_number_and_an_unknown_body():
    assert "--bar: does not apply to a mechanism" in refused_line(
        child("fbd", "--preset", "slider-crank", "--bar", "2", "--body", "rod"))
    assert refused_line(child("fbd", "--preset", "slider-crank", "--body", "wheel")) == (
        "error: --body 'wheel': no body of that name (bodies: crank, rod, piston)")


def test_equilibrium_finds_the_rest_poses_of_the_slider_crank(capsys):
    """Four rest poses (the crank straight down or up, the rod on either side): at each the accelerations from
    rest vanish; the crank down is stable and a minimum of the potential along the motion, the crank up is not."""
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    dae = MechanismDAE(mechanism)
    constraints = Constraints(mechanism)
    code, out, _ = run(capsys, "equilibrium", "--preset", "slider-crank", "--json")
    poses = json.loads(out)["rest_poses"]
    assert code == 0 and len(poses) == 4
    sketch_angle = np.arctan2(*reversed(mechanism.body("crank").points["A"]))  # the crank drawn at 60 degrees
    for pose in poses:
        q = np.array(pose["q"])
        assert np.max(np.abs(constraints.residual(q))) <= 1e-10
        assert np.max(np.abs(dae.solve(q, np.zeros_like(q)).qddot)) <= 1e-8  # at rest it stays at rest
        crank = np.degrees(sketch_angle + q[2])
        down = np.isclose((crank + 90.0) % 360.0, 0.0, atol=1e-6) or np.isclose((crank + 90.0) % 360.0, 360.0)
        assert pose["stable"] == bool(down), (crank, pose["stable"])
        # along the motion (a small turn of the crank, the rest assembled), V rises at a stable pose only
        nearby = []
        for turn in (-1e-3, 1e-3):
            guess = q.copy()
            guess[2] += turn
            moved = assemble(mechanism, guess).q
            nearby.append(dae.energy(moved, np.zeros_like(moved))[1] - pose["potential"])
        assert (min(nearby) > 0) == pose["stable"]
    assert [pose["stable"] for pose in poses] == [True, True, False, False]  # lowest potential first


def test_equilibrium_refuses_a_mechanism_its_motors_fully_drive():
    line = refused_line(child("equilibrium", "--preset", "jansen-leg"))
    assert "jansen-leg: its speed motor fixes every body (mobility 0 after 1 speed motor)" in line


def test_warm_derives_a_mechanism_presets_three_formulations(capsys):
    code, out, _ = run(capsys, "warm", "--preset", "slider-crank")
    assert code == 0 and [line.split(":")[0] for line in out.splitlines()] == [
        "dae slider-crank", "lagrange slider-crank", "newton_euler slider-crank"]
    # warmed once, every formulation of this structure is in the cache, whatever its numbers
    code, out, _ = run(capsys, "warm", "--preset", "slider-crank", "--set", "crank.mass=0.3", "--set", "g=1")
    assert code == 0 and all(line.endswith("s (cached)") for line in out.splitlines()), out


# After warm, a run in a new process: how many modules it compiled and loaded (physics.codegen.machine_code.COUNTS)
_RUN_AND_COUNT = """
import json, sys
from physics.cli import main
from physics.codegen import machine_code
code = main(["mechanism", "--preset", "crank-rocker", "--t-end", "1", "--json"])
print(json.dumps({"code": code, **machine_code.COUNTS}), file=sys.stderr)
"""


@pytest.mark.slow
def test_warm_of_a_fully_driven_mechanism_leaves_its_first_run_nothing_to_compile(tmp_path):
    """A mechanism its motors fully drive runs by position analysis (the driven sequence's own machine code,
    physics.codegen.native_states), not by an integrator: warm must prepare that too, so that the first run after
    it compiles nothing (without the position-analysis run in warm, this run compiled one module)."""
    environment = {**os.environ, "LINKAGE_LAB_CACHE": str(tmp_path / "cache")}
    warmed = subprocess.run([sys.executable, "-m", "physics", "warm", "--preset", "crank-rocker"],
                            capture_output=True, text=True, env=environment, timeout=600)
    assert warmed.returncode == 0, warmed.stderr
    assert warmed.stdout.splitlines()[-1] == "position analysis crank-rocker: ready", warmed.stdout
    counted = subprocess.run([sys.executable, "-c", _RUN_AND_COUNT], capture_output=True, text=True,
                             env=environment, timeout=600)
    counts = json.loads(counted.stderr.strip().splitlines()[-1])
    assert counts["code"] == 0 and counts["compiled"] == 0 and counts["loaded"] >= 1, (counts, counted.stderr)


def test_a_chain_study_names_a_mechanism_preset_as_one():
    """A chain-only study given a mechanism preset says so in one line (not "invalid choice")."""
    with pytest.raises(LinkageError, match="a mechanism preset; this command takes a chain preset"):
        get_preset("jansen-leg")


def test_a_chain_preset_with_a_mechanism_file_is_refused_in_one_line():
    line = refused_line(child("simulate", "--preset", "single", "--mechanism", "docs/examples/slider-crank.toml"))
    assert line == "error: give one of --preset NAME (a mechanism preset) or --mechanism FILE, not both"


def docs_examples() -> list[str]:
    """The commands of docs/cli.md's first fenced bash block, comments removed."""
    text = (ROOT / "docs" / "cli.md").read_text(encoding="utf-8")
    block = text.split("```bash\n", 1)[1].split("```", 1)[0]
    return [" ".join(shlex.split(line, comments=True)) for line in block.splitlines() if line.strip()]


def test_the_docs_name_every_mechanism_command():
    commands = {shlex.split(line)[3] for line in docs_examples()}
    assert commands == {"presets", "simulate", "accelerations", "fbd", "equilibrium", "warm", "ensemble"}


@pytest.mark.slow  # each example is a process of its own
@pytest.mark.parametrize("line", docs_examples())
def test_docs_cli_example_runs_as_written(line, tmp_path):
    words = shlex.split(line)
    outputs = []
    for index, word in enumerate(words[:-1]):
        if word == "--out":
            outputs.append(tmp_path / Path(words[index + 1]).name)
            words[index + 1] = str(outputs[-1])
    words[0] = sys.executable
    result = subprocess.run(words, cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, f"{line}\n{result.stderr}"
    for output in outputs:
        assert output.stat().st_size > 0, f"{line} wrote an empty {output.name}"
    assert result.stdout.strip() or outputs, f"{line} printed nothing"


def test_ensemble_of_a_mechanism_preset_as_json_csv_and_png(capsys, tmp_path):
    """``ensemble --preset slider-crank``: the chain ensemble's keys with the mechanism's; copy 0 is the plain run
    (its probe, the piston, ends where simulate's trace ends); the time series as CSV; the copies as a PNG."""
    code, out, _ = run(capsys, "ensemble", "--preset", "slider-crank", "--count", "3", "--spread", "1e-6",
                       "--t-end", "0.4", "--samples", "3")
    document = json.loads(out)
    assert code == 0 and document["mechanism"] == "slider-crank" and document["count"] == 3
    assert {"t", "tip_spread", "alive", "energy_drift", "message", "final_tips", "method"} <= set(document)
    assert document["alive"] == [3, 3, 3] and document["t"] == pytest.approx([0.0, 0.2, 0.4])
    _, table, _ = run(capsys, "simulate", "--preset", "slider-crank", "--t-end", "0.4", "--samples", "3",
                      "--format", "json")
    trace = json.loads(table)
    assert document["final_tips"][0] == pytest.approx([trace["trace_x"][-1], trace["trace_y"][-1]], abs=1e-9)
    assert 0 < max(document["tip_spread"]) < 1e-4  # copies 1e-6 rad apart stay close over 0.4 s
    assert run(capsys, "ensemble", "--preset", "slider-crank", "--count", "2", "--t-end", "0.2", "--samples", "3",
               "--out", str(tmp_path / "fan.csv"))[0] == 0
    rows = list(csv.reader((tmp_path / "fan.csv").open()))
    assert rows[0] == ["t", "tip_spread", "alive", "energy_drift"] and len(rows) == 4
    assert run(capsys, "ensemble", "--preset", "slider-crank", "--count", "2", "--t-end", "0.2", "--samples", "3",
               "--out", str(tmp_path / "fan.png"))[0] == 0
    assert (tmp_path / "fan.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # every integrator runs a mechanism's copies (midpoint's fixed --step), and a combination that cannot run is
    # refused in one line naming it
    assert "integrator = variational: needs method = lagrange (got dae)" in refused_line(
        child("ensemble", "--preset", "slider-crank", "--integrator", "variational", "--step", "0.01"))


def test_every_rest_pose_of_the_watt_six_bar_is_at_rest_and_its_stability_is_the_potentials_shape(capsys):
    """At each rest pose the accelerations from rest vanish, and a small motion along the one free direction
    (the constraints' tangent, the rest assembled again) raises the potential both ways exactly when the pose is
    called stable."""
    mechanism = MECHANISM_PRESETS["watt-six-bar"]()
    dae = MechanismDAE(mechanism)
    constraints = Constraints(mechanism)
    code, out, _ = run(capsys, "equilibrium", "--preset", "watt-six-bar", "--json")
    poses = json.loads(out)["rest_poses"]
    assert code == 0 and len(poses) >= 2 and any(p["stable"] for p in poses) and not all(p["stable"] for p in poses)
    assert [p["potential"] for p in poses] == sorted(p["potential"] for p in poses)
    for pose in poses:
        q = np.array(pose["q"])
        assert np.max(np.abs(dae.solve(q, np.zeros_like(q)).qddot)) <= 1e-8
        assert np.all(np.abs(q[2::3]) <= np.pi)
        tangent = np.linalg.svd(constraints.jacobian(q))[2][-1]
        rises = []
        for sign in (-1.0, 1.0):
            moved = assemble(mechanism, q + sign * 1e-3 * tangent / np.max(np.abs(tangent))).q
            rises.append(dae.energy(moved, np.zeros_like(moved))[1] - pose["potential"] > 0)
        assert all(rises) == pose["stable"], pose


def test_equilibrium_without_anything_pulling_is_refused_in_one_line():
    line = refused_line(child("equilibrium", "--preset", "slider-crank", "--set", "g=0"))
    assert line.startswith("error: slider-crank: no gravity (g = 0) and no torque motor")


HOSTILE = ["", "nan", "inf", "-1", "0", "1e308", "abc", "0x10", "1e-320", "0.2"]
MECHANISM_ARGUMENTS = {
    # command: (leading arguments, {option: values}); the values keep each accepted run short
    "simulate": (["--preset", "slider-crank", "--t-end", "0.1", "--samples", "3"], {
        "--t-end": HOSTILE, "--samples": ["1", "2", "abc", "100001"], "--method": ["lagrange", "reduced", "x"],
        "--stabilization": ["none", "x"], "--rtol": HOSTILE, "--atol": HOSTILE, "--integrator": ["DOP853", "RK45"],
        "--set": ["g=nan", "g=1", "crank.mass=0", "crank.mass=true", "O.speed=1e4", "x=1", "noequals", "O.torque=1"],
        "--format": ["csv", "json", "x"], "--json": None, "--links": ["3"], "--pin": ["1,1"], "--step": ["0.1"]}),
    "accelerations": (["--preset", "crank-rocker"], {
        "--state": ["", "0,0", "nan," * 17 + "nan", "0," * 17 + "0"], "--method": ["dae", "reduced", "dae,x", ","],
        "--time": HOSTILE, "--set": ["O2.speed=0", "g=-1"], "--input": ["x.json"]}),
    "fbd": (["--preset", "slider-crank", "--body", "rod"], {
        "--body": ["", "crank", "nope"], "--time": HOSTILE, "--method": ["dae", "lagrange", "x"], "--json": None,
        "--bar": ["1"], "--out": ["/dev/full", "x.png"]}),
    "equilibrium": (["--preset", "slider-crank"], {"--set": ["g=0", "crank.mass=2", "O.torque=0.01"],
                                                      "--json": None, "--links": ["2"]}),
    "ensemble": (["--preset", "slider-crank", "--count", "2", "--t-end", "0.1", "--samples", "3"], {
        "--count": ["0", "2", "2000", "abc"], "--spread": HOSTILE, "--t-end": HOSTILE,
        "--samples": ["1", "3", "abc"], "--step": ["0.1"], "--damping": ["1"]}),
}


@settings(max_examples=25, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(data=st.data())
def test_property_every_mechanism_command_answers_any_arguments(capsys, data):
    """Any mix of options and hostile values: exit 0, or 2 with one line, or 3 with its line last; never a
    traceback."""
    command = data.draw(st.sampled_from(sorted(MECHANISM_ARGUMENTS)))
    leading, options = MECHANISM_ARGUMENTS[command]
    argv = [command, *leading]
    for option in data.draw(st.lists(st.sampled_from(sorted(options)), max_size=3)):
        if options[option] is None:
            argv.append(option)
            continue
        argv.append(f"{option}={data.draw(st.sampled_from(options[option]))}")
    code, _, err = run(capsys, *argv)
    lines = [line for line in err.splitlines() if line.strip()]
    assert "Traceback" not in err and code in (0, 2, 3), (argv, code, err)
    if code == 2:
        assert len(lines) == 1 and lines[0].startswith("error: "), (argv, err)
