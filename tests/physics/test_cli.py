"""The command line is a contract for scripts: exact CSV headers, JSON keys and shapes."""

from __future__ import annotations

import csv
import io
import json
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

import physics


def run_cli(*argv, check=True):
    result = subprocess.run([sys.executable, "-m", "physics", *argv], capture_output=True, text=True, timeout=300)
    if check:
        assert result.returncode == 0, result.stderr
    return result


def test_simulate_csv_header_open_chain():
    out = run_cli("simulate", "--preset", "triple-a", "--method", "lagrange", "--t-end", "1", "--samples", "11").stdout
    rows = list(csv.reader(io.StringIO(out)))
    assert rows[0] == ["t", "theta1", "theta2", "theta3", "omega1", "omega2", "omega3", "tip_x", "tip_y",
                       "kinetic", "potential", "energy"]
    assert len(rows) == 12
    assert float(rows[-1][0]) == pytest.approx(1.0)


def test_simulate_dae_adds_reactions_and_json_has_the_same_names(tmp_path):
    out = tmp_path / "run.csv"
    run_cli("simulate", "--preset", "triple-b", "--method", "dae", "--t-end", "1", "--samples", "5", "--out", str(out))
    header = out.read_text().splitlines()[0].split(",")
    assert header[-6:] == ["R0x", "R0y", "R1x", "R1y", "R2x", "R2y"]
    data = json.loads(run_cli("simulate", "--preset", "triple-b", "--method", "dae", "--t-end", "1", "--samples", "5",
                              "--format", "json").stdout)
    assert list(data) == header
    assert all(len(v) == 5 for v in data.values())


def test_simulate_set_and_links():
    out = run_cli("simulate", "--preset", "chain", "--links", "5", "--set", "L3=2", "--set", "theta2=0.3",
                  "--t-end", "0.5", "--samples", "3", "--format", "json").stdout
    data = json.loads(out)
    assert "theta5" in data and "theta6" not in data
    assert data["theta2"][0] == pytest.approx(0.3)


def test_four_bar_columns():
    out = run_cli("simulate", "--preset", "four-bar", "--method", "dae", "--t-end", "2", "--samples", "5",
                  "--stabilization", "baumgarte").stdout
    header = out.splitlines()[0].split(",")
    for column in ("constraint_x", "constraint_y", "trace_x", "trace_y", "RHx", "RHy", "R2y"):
        assert column in header


def test_accelerations_contract_hanging_chain_reaction_is_total_weight():
    out = json.loads(run_cli("accelerations", "--preset", "triple-a", "--method", "dae", "--state", "0,0,0,0,0,0").stdout)
    assert out["method"] == "dae" and out["links"] == 3
    assert out["theta_ddot"] == pytest.approx([0, 0, 0], abs=1e-15)
    assert out["joint_reactions"][0] == pytest.approx([0.0, 3.0])  # seed: m = 1 each, g = 1
    lagrange = json.loads(run_cli("accelerations", "--preset", "triple-a", "--method", "lagrange").stdout)
    assert "joint_reactions" not in lagrange


@pytest.mark.slow  # several CLI processes
def test_accelerations_batch_input(tmp_path):
    cases = [
        {"links": 3, "params": {"L1": 1.0, "L2": 1.0, "L3": 1.0, "d1": 0.5, "d2": 0.5, "d3": 0.5, "m1": 1.0,
                                "m2": 1.0, "m3": 1.0, "I1": 0.2, "I2": 0.3, "I3": 0.4, "g": 1.0},
         "theta": [0.1, 0.2, 0.3], "omega": [0.0, 0.5, -0.5]},
        {"links": 1, "params": {"L1": 2.0, "d1": 1.0, "m1": 3.0, "I1": 1.0, "g": 9.81}, "theta": [0.5], "omega": [0.0]},
    ]
    path = tmp_path / "cases.json"
    path.write_text(json.dumps(cases))
    results = {m: json.loads(run_cli("accelerations", "--method", m, "--input", str(path)).stdout)
               for m in ("newton_euler", "lagrange", "dae")}
    for m, res in results.items():
        assert [r["links"] for r in res] == [3, 1]
    # single compound pendulum: theta_ddot = -m g d sin(theta) / (I + m d^2)
    expected = -3.0 * 9.81 * 1.0 * np.sin(0.5) / (1.0 + 3.0)
    for res in results.values():
        assert res[1]["theta_ddot"][0] == pytest.approx(expected, rel=1e-12)
    np.testing.assert_allclose(results["dae"][0]["theta_ddot"], results["newton_euler"][0]["theta_ddot"], rtol=1e-10)


@pytest.mark.slow  # one CLI process per method
def test_four_bar_accelerations_report_tip_reaction_and_grashof_for_every_method():
    outs = [json.loads(run_cli("accelerations", "--preset", "four-bar", "--method", m).stdout)
            for m in ("newton_euler", "lagrange", "dae")]
    for out in outs:
        assert len(out["tip_reaction"]) == 2
        assert "grashof" in out
    np.testing.assert_allclose(outs[0]["tip_reaction"], outs[2]["tip_reaction"], rtol=1e-10)
    assert len(outs[2]["joint_reactions"]) == 3


def test_presets_lists_every_preset_with_parameters():
    data = json.loads(run_cli("presets").stdout)
    names = [p["name"] for p in data]
    for name in ("single", "double", "triple-a", "triple-b", "triple-c", "four-bar", "change-point", "chain"):
        assert name in names
    four_bar = data[names.index("four-bar")]
    assert four_bar["params"]["L3"] == 2.0 and four_bar["pin"] is not None and "grashof" in four_bar


@pytest.mark.slow  # three ensemble runs through the CLI
def test_ensemble_fan_opens_as_json_csv_and_png(tmp_path):
    document = json.loads(run_cli("ensemble", "--preset", "triple-a", "--count", "50", "--t-end", "30",
                                  "--samples", "7").stdout)
    assert document["count"] == 50 and document["spread"] == 1e-9 and document["method"] == "lagrange"
    assert document["t"] == pytest.approx([0, 5, 10, 15, 20, 25, 30])
    spread = document["tip_spread"]
    assert spread[0] < 1e-6 and spread[-1] > 0.1  # chaos: 1e-9 rad apart at the start, visibly apart at 30 s
    assert max(document["energy_drift"]) < 1e-6  # each copy keeps its energy (RK4 at 1/240 s)
    assert document["alive"] == [50] * 7 and len(document["final_tips"]) == 50

    table = tmp_path / "fan.csv"
    run_cli("ensemble", "--preset", "double", "--count", "10", "--t-end", "2", "--samples", "5", "--out", str(table))
    rows = list(csv.reader(table.open()))
    assert rows[0] == ["t", "tip_spread", "alive", "energy_drift"] and len(rows) == 6

    picture = tmp_path / "fan.png"
    run_cli("ensemble", "--preset", "triple-a", "--count", "20", "--t-end", "30", "--samples", "2",
            "--out", str(picture))
    image = np.asarray(Image.open(picture).convert("RGB"))
    coloured = (image.max(axis=2).astype(int) - image.min(axis=2)) > 60
    assert coloured.mean() > 0.005  # the copies' links are drawn


def test_ensemble_bad_count_is_one_line():
    result = run_cli("ensemble", "--preset", "triple-a", "--count", "0", check=False)
    assert result.returncode == 2 and len(result.stderr.strip().splitlines()) == 1
    assert "count" in result.stderr and "1 <= count" in result.stderr


@pytest.mark.slow  # warms every preset's mechanisms in a child process
def test_warm_without_arguments_builds_every_preset_mechanism():
    result = run_cli("warm")
    built = {tuple(line.split(":")[0].split()) for line in result.stdout.splitlines()}
    expected = set()
    for name in physics.preset_names():
        chain = physics.get_preset(name).chain
        for method in physics.FORMULATION_NAMES:
            expected.add((method, f"n={chain.n}", "pinned" if chain.pinned else "open"))
    assert built == expected
    info = json.loads(run_cli("cache", "--info", "--json").stdout)
    held = {(e["method"], f"n={e['links']}", e["closure"]) for e in info["mechanisms"]}
    assert expected <= held


@pytest.mark.parametrize("links", ["1.5", "0", "13", "two"])
def test_warm_refuses_links_that_are_not_whole_numbers_in_range(links):
    result = run_cli("warm", "--links", links, check=False)
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and "--links" in result.stderr and "1..12" in result.stderr
