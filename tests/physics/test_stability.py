"""The stability study (physics.studies.stability_study): each case runs, on shorter horizons than docs/stability.md, and
shows what the docs say it shows."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np

from physics import apply_overrides, get_preset, load_compiled
from physics.simulate import SINGULAR_PIVOT_RATIO
from physics.simulate.chain_system import chain_system
from physics.studies import stability_figures
from physics.studies import stability_study as stability

ROOT = Path(__file__).resolve().parents[2]


def _curves(svg: str) -> int:
    return svg.count('<path d="M')


def test_case1_projection_holds_the_pin_and_no_stabilisation_drifts():
    result = stability.closed_loop_drift(t_end=20.0, samples=401, methods=("lagrange", "dae"))
    runs = {(r["stabilization"], r["method"]): r for r in result["runs"]}
    assert all(r["status"] == 0 for r in runs.values())
    for method in ("lagrange", "dae"):
        none, baumgarte, projection = (runs[(s, method)] for s in ("none", "baumgarte", "projection"))
        assert projection["max_distance"] < 1e-12
        distance = np.asarray(none["distance"])
        t = np.asarray(none["t"])
        assert distance[t >= 10.0].max() > 5 * distance[t <= 1.0].max()  # grows: drift, not noise
        assert none["final_distance"] > 1e3 * projection["max_distance"]
        assert baumgarte["final_distance"] < none["final_distance"]
    svg = stability_figures.figure_drift(result)
    assert svg.startswith("<svg") and _curves(svg) == 6 and "baumgarte, dae" in svg


def test_binned_median_tells_bounded_from_drifting():
    t = np.linspace(0.0, 1000.0, 100001)
    bounded = np.abs(np.sin(3.0 * t)) * 1e-4
    drifting = 1e-7 * t * (1.0 + 0.5 * np.sin(t))
    for values, low, high in ((bounded, -0.05, 0.05), (drifting, 0.9, 1.1)):
        centres, maxima = stability_figures.binned_median(t, values)
        fit = centres >= 10.0
        slope = np.polyfit(np.log10(centres[fit]), np.log10(maxima[fit]), 1)[0]
        assert low < slope < high


def test_case2_midpoint_energy_error_stays_bounded_while_rk45_drifts():
    result = stability.energy_drift("single", t_end=300.0, samples=3001, tolerance=1e-6, step=0.02,
                                    integrators=("RK45", "midpoint"))
    runs = {r["integrator"]: r for r in result["runs"]}
    assert all(r["status"] == 0 for r in runs.values())
    assert runs["RK45"]["slope"] > 0.8 and runs["RK45"]["growth"] > 3.0
    assert abs(runs["midpoint"]["slope"]) < 0.1 and runs["midpoint"]["growth"] < 1.5
    svg = stability_figures.figure_energy(result)
    assert _curves(svg) == 2


def test_case2_variational_energy_error_stays_bounded_on_chaotic_motion_while_dop853_drifts():
    result = stability.energy_drift("triple-a", t_end=1000.0, samples=4001, tolerance=1e-8, step=0.005,
                                    integrators=("DOP853", "variational"))
    runs = {r["integrator"]: r for r in result["runs"]}
    assert all(r["status"] == 0 for r in runs.values())
    assert runs["DOP853"]["growth"] > 2.0 and runs["DOP853"]["slope"] > 0.6
    assert runs["variational"]["growth"] < 1.5 and abs(runs["variational"]["slope"]) < 0.3
    # (The midpoint rule in (theta, omega) is not symplectic for a chain: tests/physics/test_variational.py.)


def test_case3_condition_peaks_near_the_change_point_and_failure_is_reported():
    result = stability.singular_approach(distances=(0.05, 1e-6), t_end=4.0, samples=401)
    near = [r for r in result["runs"] if r["distance"] == 0.05]
    at = [r for r in result["runs"] if r["distance"] == 1e-6]
    assert {r["method"] for r in near} == {"newton_euler", "lagrange", "dae", "reduced"}
    for run in near:
        assert run["status"] == 0 and 1e2 < run["peak_condition"] < 1e5
    for run in at:
        assert run["status"] < 0 and "singular" in run["message"] and run["t_reached"] == 0.0
    labels = [c["method"] for c in result["curves"]]
    assert labels[-1].startswith("loop Jacobian") and len(labels) == 5
    assert _curves(stability_figures.figure_condition(result)) == 5
    assert stability_figures.figure_peak_condition(result).startswith("<svg")


def test_case4_every_cell_either_runs_to_the_end_or_says_where_it_failed():
    scenarios = [s for s in stability.SCENARIOS if s[0].startswith(("seed", "bar 3 without", "light base"))]
    result = stability.degenerate(scenarios=scenarios, methods=("lagrange", "dae"), integrators=("DOP853", "midpoint"),
                                  t_end=2.0)
    rows = {row["scenario"].split(":")[0]: row for row in result["rows"]}
    rejected = rows["bar 3 without inertia"]["rejected"]
    assert rejected and "bar 3" in rejected and "I3" in rejected
    assert all(c["status"] == 0 and c["energy_drift"] < 1e-6 for c in rows["seed values (control)"]["cells"])
    failures = 0
    for row in result["rows"]:
        for cell in row["cells"]:
            if cell["status"] == 0:
                assert math.isclose(cell["t_reached"], 2.0)
            else:
                failures += 1
                assert cell["t_reached"] < 2.0 and "t = " in cell["message"]
            text, colour = stability_figures.cell_outcome(cell)
            assert (cell["status"] < 0) == text.startswith(("singular", "non-finite", "step", "max", "failed"))
    assert failures >= 1  # the heavy tip on a light base breaks something, and says so
    svg = stability_figures.figure_degenerate(result)
    assert "rejected" in svg and "lagrange" in svg


def test_case5_tighter_tolerance_predicts_further_and_formulations_agree_early():
    result = stability.chaos_divergence(presets=("triple-c",), tolerances=(1e-4, 1e-8), integrators=("DOP853",),
                                        t_end=30.0, samples=301)
    case = result["cases"]["triple-c"]
    loose, tight = case["horizons"]["DOP853"]
    assert loose["horizon"] is not None and 5.0 < loose["horizon"] < 20.0
    assert tight["horizon"] is None or tight["horizon"] > loose["horizon"] + 5.0
    t = np.asarray(case["t"])
    for method in ("newton_euler", "dae"):
        assert np.asarray(case["methods"][method]["distance"])[t <= 5.0].max() < 1e-10
    assert _curves(stability_figures.figure_divergence(result)) == 4
    assert stability_figures.figure_horizon(result).startswith("<svg")


def test_cli_rejects_a_bad_case_with_one_line(tmp_path):
    result = subprocess.run([sys.executable, "-m", "physics.stability", "--case", "9", "--out", str(tmp_path)],
                            capture_output=True, text=True, cwd=ROOT, timeout=60)
    assert result.returncode == 2
    assert len(result.stderr.strip().splitlines()) == 1 and "case" in result.stderr


def test_a_partial_run_keeps_the_other_cases_numbers(tmp_path, monkeypatch):
    (tmp_path / "stability.json").write_text(json.dumps({"case3": {"kept": True}, "case1": {"old": True}}))
    monkeypatch.setattr(stability, "closed_loop_drift", lambda t_end: {"case": 1, "new": True})
    monkeypatch.setattr(stability, "figure_drift", lambda result: "<svg></svg>")
    summary = stability.run_cases([1], tmp_path, quick=True, progress=False)
    stored = json.loads((tmp_path / "stability.json").read_text())
    assert stored == summary
    assert stored["case3"] == {"kept": True} and stored["case1"] == {"case": 1, "new": True}
    assert (tmp_path / "case1-drift.svg").read_text() == "<svg></svg>"


def test_cli_needs_out_and_writes_nothing_without_it(tmp_path):
    """The study's default folder held tracked files (docs/stability): a run without --out is refused with one
    line before any work, and writes nothing."""
    result = subprocess.run([sys.executable, "-m", "physics.stability", "--case", "1"],
                            capture_output=True, text=True, cwd=tmp_path, timeout=60)
    assert result.returncode == 2
    assert len(result.stderr.strip().splitlines()) == 1 and "--out" in result.stderr, result.stderr
    assert list(tmp_path.iterdir()) == []


def test_cli_prints_every_file_it_writes(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(stability, "closed_loop_drift", lambda t_end: {"case": 1, "new": True})
    monkeypatch.setattr(stability, "figure_drift", lambda result: "<svg></svg>")
    assert stability.main(["--case", "1", "--out", str(tmp_path), "--no-progress"]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert printed == [f"wrote {tmp_path / 'case1-drift.svg'}", f"wrote {tmp_path / 'stability.json'}"]
    assert sorted(path.name for path in tmp_path.iterdir()) == ["case1-drift.svg", "stability.json"]


def _chain_condition(chain, method: str, trajectory) -> np.ndarray:
    """The 2-norm condition number of the chain's own system (its formulas: the reduced model's samples are read
    by the pinned Lagrange system) at every sample of ``trajectory``."""
    formulation = "lagrange" if method == "reduced" else method
    compiled = load_compiled(formulation, chain.n, chain.pinned)
    matrices, _ = compiled.sample_matrices(np.ascontiguousarray(trajectory.theta),
                                           np.ascontiguousarray(trajectory.omega), chain.params())
    return np.linalg.cond(matrices)


def test_case3_verdicts_against_the_chains_own_condition():
    """The chain as a mechanism (issue 24) near the change point: every method runs to the end from 0.05 and 1e-3
    rad and is stopped at the start at 1e-6 rad, singular; the reported condition (the 2-norm number of the system
    actually solved) grows as 1/delta^2 and peaks within the case's bounds. The route's tree formulations solve
    another matrix than the chain's own (bar 3 hangs from the pin H), whose number is a constant factor of the
    chain's at the same states: measured 0.51 (Newton-Euler), 0.46 (Lagrange, and the reduced model, read by it)
    and 1.00 (the DAE) at every distance from 0.05 to 1e-5 rad (docs/physics.md, "Singular positions")."""
    distances = (0.05, 1e-3, 1e-6)
    result = stability.singular_approach(distances=distances, t_end=1.0, samples=101)
    factors = {"newton_euler": (0.45, 0.55), "lagrange": (0.4, 0.5), "reduced": (0.4, 0.5), "dae": (0.99, 1.01)}
    peaks: dict[tuple[float, str], tuple[float, float]] = {}
    for run in result["runs"]:
        if run["distance"] == 1e-6:
            assert run["status"] < 0 and "singular" in run["message"] and run["t_reached"] == 0.0
            continue
        assert (run["status"], run["t_reached"]) == (0, 1.0), run
        chain, theta0, omega0 = stability._change_point_start(run["distance"])
        trajectory, _ = stability._run(chain, theta0, omega0, method=run["method"], integrator="DOP853", t_end=1.0,
                                       samples=101)
        assert float(np.nanmax(trajectory.condition)) == run["peak_condition"]
        chain_peak = float(np.nanmax(_chain_condition(chain, run["method"], trajectory)))
        low, high = factors[run["method"]]
        assert low < run["peak_condition"] / chain_peak < high, run["method"]
        peaks[(run["distance"], run["method"])] = (run["peak_condition"], chain_peak)
        if run["distance"] == 0.05:
            assert 1e2 < run["peak_condition"] < 1e5
    for method in factors:  # 1/delta^2: a factor 2500 from 0.05 to 1e-3 rad (the peak is the release, a turning point)
        growth = [peaks[(1e-3, method)][side] / peaks[(0.05, method)][side] for side in (0, 1)]
        assert all(2000 < g < 3000 for g in growth), (method, growth)


def test_case4_verdicts_on_the_mechanism_engine():
    """Degenerate parameters, the chain as a mechanism: every cell runs to the end, but one. The very light tip's
    DAE is stopped at the start: its tree DAE (18 unknowns, a row per body's rotation) starts at a pivot ratio of
    1.09e6, above SINGULAR_PIVOT_RATIO, where the chain's own 15 x 15 DAE starts at 7.4e5 (docs/stability.md,
    case 4: it was stopped at 0.67 s on the chain's deleted kernels)."""
    scenarios = [s for s in stability.SCENARIOS if s[0].startswith(("seed", "bar 2 massless", "very light", "heavy"))]
    result = stability.degenerate(scenarios=scenarios, integrators=("DOP853",), t_end=2.0)
    cells = {(row["scenario"], c["method"]): c for row in result["rows"] for c in row["cells"]}
    assert len(cells) == 4 * 3
    for key, cell in cells.items():
        if key[0].startswith("very light") and key[1] == "dae":
            assert cell["status"] < 0 and cell["t_reached"] == 0.0
            assert cell["message"].startswith("the system became singular")
            continue
        assert (cell["status"], cell["t_reached"]) == (0, 2.0), key
    label, overrides = next(s for s in scenarios if s[0].startswith("very light"))
    preset = get_preset("triple-b")
    chain, theta0, omega0 = apply_overrides(preset.chain, preset.theta0, preset.omega0, overrides)
    _, chain_ratio = load_compiled("dae", 3, chain.pinned).solve_full(theta0, omega0, chain.params())
    _, route_ratio = chain_system(chain, "dae").solve(theta0, omega0)
    assert 7e5 < chain_ratio < SINGULAR_PIVOT_RATIO < route_ratio < 1.2e6, (label, chain_ratio, route_ratio)
