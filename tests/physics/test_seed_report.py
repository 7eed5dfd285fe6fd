"""The seed report's figures recomputed at small size, each number checked against a run made here."""

from __future__ import annotations

import io
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from physics import Settings, get_preset, simulate
from physics.seed_report import ANGLE_DEPARTURE, TIP_DEPARTURE, four_bar_case, print_summary, triple_case

ROOT = Path(__file__).resolve().parents[2]


def run(name, method, integrator, tolerance, t_end, samples, stabilization="projection"):
    preset = get_preset(name)
    trajectory = simulate(preset.chain, preset.theta0, preset.omega0,
                          Settings(method=method, integrator=integrator, rtol=tolerance, atol=tolerance,
                                   t_end=t_end, samples=samples, stabilization=stabilization))
    assert trajectory.success, trajectory.message
    return trajectory


def first_above(t, values, threshold):
    over = np.flatnonzero(values > threshold)
    return t[over[0]] if over.size else None


@pytest.fixture(scope="module")
def case_c():
    return triple_case("triple-c", t_end=18.0, samples=901, integrator="RK45")


def test_case_c_leaves_the_true_motion_when_a_tighter_run_says_so(case_c):
    """The study's departure time against one computed here from a different tight run (Lagrange instead of
    Newton-Euler for the report's run, newton_euler DOP853 at 1e-13 as truth)."""
    report = run("triple-c", "lagrange", "RK45", 1e-6, 18.0, 901)
    truth = run("triple-c", "newton_euler", "DOP853", 1e-13, 18.0, 901)
    distance = np.hypot(*(report.tip_xy - truth.tip_xy).T)
    expected = first_above(truth.t, distance, TIP_DEPARTURE)
    assert expected is not None and 14.0 < expected < 18.0
    assert case_c["departure_time"] == pytest.approx(expected, abs=0.2)
    assert case_c["tip_error_max"] > 0.5  # not a near miss: the curve is visibly elsewhere by 18 s
    assert case_c["reference_error_max"] < 1e-5  # the converged run is converged


def test_figures_12_13_measure_rounding_while_each_method_is_off(case_c):
    assert case_c["ne_minus_dae_max"] < 1e-7 and case_c["ne_minus_lagrange_max"] < 1e-7
    for method, error in case_c["x_error_max"].items():
        assert error > 1e4 * max(case_c["ne_minus_dae_max"], case_c["ne_minus_lagrange_max"]), method
    # same steps: the three formulations took the same number of RK45 steps
    assert len(set(case_c["steps"].values())) == 1


def test_case_b_stays_on_the_true_motion():
    case_b = triple_case("triple-b", t_end=10.0, samples=501, integrator="RK45")
    assert case_b["departure_time"] is None
    assert case_b["tip_error_max"] < 1e-4
    assert case_b["ne_minus_dae_max"] < 1e-12 and case_b["ne_minus_lagrange_max"] < 1e-12


def test_four_bar_at_the_reports_settings_drifts_off_its_pin():
    """30 s of the 100-s run: the pin gap and the crank angle's departure, against runs made here."""
    study = four_bar_case(t_end=30.0, samples=601, integrator="RK45")
    report = run("four-bar", "dae", "RK45", 1e-6, 30.0, 601, stabilization="none")
    truth = run("four-bar", "lagrange", "DOP853", 1e-12, 30.0, 601)
    gap = np.hypot(*report.constraint_xy.T)
    assert study["report"]["pin_gap_max"] == pytest.approx(gap.max(), rel=1e-9)
    assert 1e-4 < study["report"]["pin_gap_max"] < 1e-1  # mm-scale drift on a 1-m linkage
    assert study["projected"]["pin_gap_max"] < 1e-10 and study["reference"]["pin_gap_max"] < 1e-10
    expected = first_above(truth.t, np.abs(report.theta[:, 0] - truth.theta[:, 0]), ANGLE_DEPARTURE)
    assert expected is not None
    assert study["report"]["theta1_departure"] == pytest.approx(expected, abs=0.2)
    energy = np.abs(report.energy - report.energy[0]) / abs(report.energy[0])
    assert study["report"]["energy_error_max"] == pytest.approx(energy.max(), rel=1e-9)
    assert study["report"]["energy_error_max"] > 10 * study["projected"]["energy_error_max"]


def test_command_writes_figures_and_numbers(tmp_path):
    out = tmp_path / "seed-report"
    result = subprocess.run([sys.executable, "-m", "physics", "seed-report", "--out", str(out), "--quick"],
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    numbers = json.loads((out / "seed-report.json").read_text())
    assert set(numbers["triple"]) == {"A", "B", "C"} and set(numbers["text_readings"]) == {"B (text)", "C (text)"}
    for name in numbers["figures"]:
        assert (out / name).read_text().startswith("<svg")
    assert len(numbers["figures"]) == 15
    assert "Figures 12-13" in result.stdout and "Four-bar" in result.stdout
    case_c = numbers["triple"]["C"]
    assert f"{case_c['tip_error_max']:.3g}" in result.stdout  # printed as computed


def test_command_refuses_an_output_that_is_a_file(tmp_path):
    target = tmp_path / "file"
    target.write_text("x")
    result = subprocess.run([sys.executable, "-m", "physics", "seed-report", "--out", str(target)],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 2 and result.stderr.strip().count("\n") == 0 and "--out" in result.stderr


def test_docs_quote_the_committed_numbers_as_the_command_prints_them():
    """docs/seed-report.md's closing block is the command's printout of docs/seed-report/seed-report.json, and the
    figures it shows are the ones the command wrote there."""
    numbers = json.loads((ROOT / "docs" / "seed-report" / "seed-report.json").read_text())
    assert not numbers["settings"]["quick"]
    printed = io.StringIO()
    print_summary(numbers, printed)
    page = (ROOT / "docs" / "seed-report.md").read_text()
    assert printed.getvalue().strip() in page
    for name in numbers["figures"]:
        assert (ROOT / "docs" / "seed-report" / name).exists()
        assert f"seed-report/{name}" in page, f"{name} is not shown on the page"
