"""The studies for a general mechanism (issue 24, "every study for every mechanism"): work-precision, the
stability study, the chaos map and the ensemble, each on a mechanism preset or a mechanism file. Runs are short
(a fraction of a second of simulated time, a few tolerances, a few pixels or copies); speed is never asserted."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from physics.chain_presets import get_preset
from physics.ensemble import MechanismEnsemble
from physics.errors import LinkageError
from physics.mechanism.chains import chain_mechanism, chain_state
from physics.mechanism.presets import MECHANISM_PRESETS
from physics.mechanism.simulate import simulate_mechanism
from physics.studies import bench, chaos_map, mechanism_cases, mechanism_chaos, work_precision
from physics.studies import stability_study as stability
from physics.studies.charts import fan_picture
from physics.studies.mechanism_stability import (
    change_point_mechanism,
    figure_mechanism_drift,
    mechanism_drift,
    mechanism_singular_approach,
)
from physics.studies.mechanism_work_precision import mechanism_case
from physics.studies.work_precision_chart import chart

ROOT = Path(__file__).resolve().parents[2]

# A double pendulum written as a mechanism file, hanging straight down in its sketch (so each body's rotation
# from the sketch is its angle from the downward vertical): two bodies, two pins, mobility 2. The file the docs'
# chaos-map example names.
DOUBLE_PENDULUM = ROOT / "docs" / "examples" / "double-pendulum.toml"


@pytest.fixture(scope="module")
def double_file() -> Path:
    return DOUBLE_PENDULUM


def _physics(*args, timeout=300):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "physics", *args], capture_output=True, text=True, cwd=ROOT,
                          env=env, timeout=timeout)


# ------------------------------------------------------------------------------------------------
# The shared pieces


def test_a_case_is_a_preset_or_a_file_and_a_bad_one_is_one_line(double_file):
    assert mechanism_cases.load_case(preset="slider-crank").name == "slider-crank"
    assert mechanism_cases.load_case(file=str(double_file)).name == "double-pendulum"
    with pytest.raises(LinkageError, match="not a mechanism preset"):
        mechanism_cases.load_case(preset="triple-a")
    with pytest.raises(LinkageError, match="give one of"):
        mechanism_cases.load_case()


def test_the_probe_path_is_the_traced_point_of_every_pose():
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    outcome = mechanism_cases.run_case(mechanism, 0.2, 5, method="dae")
    assert outcome.success and outcome.tip_xy.shape == (5, 2)
    np.testing.assert_allclose(outcome.tip_xy, outcome.run.trace_xy, atol=1e-12)


def test_a_failed_run_comes_back_as_a_status_not_an_exception():
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    outcome = mechanism_cases.run_case(mechanism, 0.2, 5, method="reduced", stabilization="none")
    assert not outcome.success and outcome.run is None and "stabilization" in outcome.message


def test_a_failed_run_is_a_failed_point_of_the_sweep_not_a_crash():
    # a run that stopped has no evaluation count (n_rhs None): the watt six-bar's sweep used to die on it
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    outcome = mechanism_cases.run_case(mechanism, 0.2, 5, method="reduced", stabilization="none")
    point = work_precision._point(outcome, np.zeros((5, 2)), 0.01, 1, 1e-6, "tolerance")
    assert outcome.n_rhs is None and point["n_rhs"] is None
    assert point["status"] != 0 and point["error"] is None and "stabilization" in point["message"]


def test_an_engine_linear_algebra_failure_is_a_failed_cell_that_says_so(monkeypatch):
    def fails(*args, **kwargs):
        raise np.linalg.LinAlgError("SVD did not converge")

    monkeypatch.setattr(mechanism_cases, "simulate_mechanism", fails)
    outcome = mechanism_cases.run_case(MECHANISM_PRESETS["slider-crank"](), 0.2, 5, method="dae")
    assert not outcome.success and "SVD did not converge" in outcome.message and "not a LinkageError" in outcome.message


# ------------------------------------------------------------------------------------------------
# 1. Work-precision


def test_work_precision_of_the_slider_crank_sweeps_every_method_and_stabilisation():
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    case = mechanism_case(mechanism, horizon=0.3, stabilizations=("none", "projection"), tolerances=(1e-4, 1e-8),
                          repeats=1, budget=0.05)
    assert case["mobility"] == 1 and case["probe"] == "point piston.B"
    assert case["reference"]["uncertainty"] < 1e-9
    labels = {(c["formulation"], c["stabilization"]) for c in case["curves"]}
    assert labels == {(m, s) for m in ("newton_euler", "lagrange", "dae") for s in ("none", "projection")} | {
        ("reduced", "position analysis")}
    for curve in case["curves"]:
        errors = [p["error"] for p in curve["points"]]
        assert all(p["status"] == 0 and p["seconds"] > 0 for p in curve["points"]), curve["label"]
        assert errors[1] < 1e-2 * errors[0], (curve["label"], errors)  # tightening the tolerance buys accuracy
    svg = chart("slider-crank", case)
    assert svg.startswith("<svg") and "colour: stabilisation" in svg and svg.count('<path d="M') >= len(labels)


def test_work_precision_of_a_driven_mechanism_is_checked_against_its_position_analysis():
    mechanism = MECHANISM_PRESETS["crank-rocker"]()
    case = mechanism_case(mechanism, horizon=0.2, formulations=("dae",), stabilizations=("projection",),
                          tolerances=(1e-6,), repeats=1, budget=0.05)
    assert case["mobility"] == 0 and "position_analysis" in case["reference"]["checks"]
    assert case["reference"]["checks"]["position_analysis"] < 1e-8
    # one curve per integrator the sweep runs, no reduced model without a free coordinate
    assert [c["formulation"] for c in case["curves"]] == ["dae"] * len(mechanism_cases.MECHANISM_INTEGRATORS)


def test_bench_quick_keeps_every_method_for_a_mechanism(tmp_path, monkeypatch):
    seen = {}

    def document(cases, options, progress):
        seen.update(options, cases=tuple(cases))
        return {"cases": {}, "elapsed_seconds": 0.0}

    monkeypatch.setattr(bench, "mechanism_document", document)
    monkeypatch.setattr(bench, "write_outputs", lambda document, out: [])
    monkeypatch.setattr(bench, "markdown_summary", lambda document: "")
    assert bench.main(["--preset", "slider-crank", "--quick", "--no-progress", "--out", str(tmp_path)]) == 0
    assert seen["cases"] == ("slider-crank",) and seen["formulations"] == ("newton_euler", "lagrange", "dae")
    assert seen["stabilizations"] == ("none", "baumgarte", "projection")
    assert set(seen["integrators"]) == set(mechanism_cases.MECHANISM_INTEGRATORS)


def test_bench_command_writes_a_mechanism_report(tmp_path, double_file):
    out = tmp_path / "bench"
    result = _physics("bench", "--preset", "slider-crank", "--mechanism", str(double_file), "--formulations", "dae",
                      "--stabilizations", "none,projection", "--tolerances", "1e-4,1e-7", "--repeats", "1",
                      "--quick", "--no-progress", "--out", str(out))
    assert result.returncode == 0, result.stderr[-2000:]
    document = json.loads((out / "work_precision.json").read_text())
    assert set(document["cases"]) == {"slider-crank", "double-pendulum"}
    assert sorted(c["label"] for c in document["cases"]["double-pendulum"]["curves"]) == sorted(
        f"dae / {integrator} ({stabilization})" for integrator in mechanism_cases.MECHANISM_INTEGRATORS
        for stabilization in ("none", "projection"))  # every integrator the sweep runs; mobility 2: no reduced model
    for name in ("slider-crank", "double-pendulum"):
        assert (out / f"work_precision_{name}.svg").read_text().startswith("<svg")
        assert f"**{name}**" in result.stdout
    assert "Headline" not in (out / "work_precision.html").read_text()  # no chain case, no seed baseline


@pytest.mark.parametrize("args, needle", [
    (["--preset", "slider-crank", "--stabilizations", "tight"], "--stabilizations"),
    (["--mechanism", "/nonexistent/m.toml"], "m.toml"),
    (["--preset", "slider-crank", "--integrators", "midpoint"], "--integrators"),
    (["--suite", "ensemble", "--preset", "slider-crank"], "--suite ensemble"),
    (["--suite", "all", "--preset", "slider-crank"], "--suite all"),
])
def test_bench_refuses_what_does_not_apply_to_a_mechanism(args, needle, tmp_path):
    with pytest.raises(LinkageError, match=needle):
        bench.main([*args, "--out", str(tmp_path / "out"), "--no-progress"])


def test_bench_refusal_is_one_line_on_the_command_line(tmp_path):
    result = _physics("bench", "--preset", "slider-crank", "--stabilizations", "tight", "--out", str(tmp_path / "o"),
                      timeout=120)
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2 and len(lines) == 1 and "--stabilizations" in lines[0], result.stderr


# ------------------------------------------------------------------------------------------------
# 2. The stability study


def test_drift_of_the_slider_crank_without_and_with_stabilisation():
    result = mechanism_drift(MECHANISM_PRESETS["slider-crank"](), t_end=1.0, samples=21, methods=("dae", "lagrange"))
    runs = {(r["method"], r["stabilization"]): r for r in result["runs"]}
    assert len(runs) == 6 and all(r["status"] == 0 and r["t_reached"] == 1.0 for r in runs.values())
    for method in ("dae", "lagrange"):
        none, baumgarte, projection = (runs[method, s]["max_residual"] for s in ("none", "baumgarte", "projection"))
        assert projection < 1e-11 and none > 10 * projection and baumgarte < none, (method, none, baumgarte, projection)
        assert runs[method, "none"]["energy_drift"] < 1e-5  # no motor: energy is conserved up to the tolerance
        assert runs[method, "none"]["peak_condition"] > 1
    svg = figure_mechanism_drift(result)
    assert svg.startswith("<svg") and "slider-crank" in svg and svg.count('<path d="M') >= 6


def test_the_change_point_mechanism_nears_its_singular_pose_as_its_release_does():
    mechanism, theta = change_point_mechanism(1e-3)
    assert mechanism_cases.mobility(mechanism) == 1 and len(mechanism.bodies) == 3
    result = mechanism_singular_approach(distances=(0.05, 1e-3), t_end=0.2, samples=5, methods=("dae", "reduced"))
    dae = {r["distance"]: r for r in result["runs"] if r["method"] == "dae"}
    # The condition grows as 1 / distance (the links' misalignment): 50x closer, 50x worse conditioned.
    assert dae[1e-3]["peak_condition"] / dae[0.05]["peak_condition"] == pytest.approx(50, rel=0.05)
    assert [c["method"] for c in result["curves"]] == ["dae"]  # the reduced model has no maximal-coordinate Jacobian
    assert all(r["status"] == 0 for r in result["runs"])


def test_stability_command_runs_a_mechanism_and_refuses_a_chain_only_case(tmp_path):
    assert stability.main(["--preset", "slider-crank", "--case", "1", "--quick", "--no-progress",
                           "--out", str(tmp_path)]) == 0
    document = json.loads((tmp_path / "stability-mechanism.json").read_text())
    assert document["mechanism"] == "slider-crank" and len(document["case1"]["runs"]) == 9
    assert (tmp_path / "mechanism-drift-slider-crank.svg").read_text().startswith("<svg")
    assert not (tmp_path / "stability.json").exists()  # the chains' summary is left alone
    assert stability.main(["--preset", "slider-crank", "--case", "2", "--out", str(tmp_path)]) == 2


# ------------------------------------------------------------------------------------------------
# 3. The chaos map


def test_the_double_pendulum_written_as_a_mechanism_flips_where_the_chains_map_says():
    """The chain's map (its own batched RK4) against the general engine's, pixel by pixel: the same flips at the
    same times (to a sample or two), and no flip where the chain's energy bound forbids one."""
    chain = get_preset("double").chain
    times, messages = mechanism_chaos.compute_mechanism_map(chain_mechanism(chain, np.zeros(2)), resolution=5,
                                                            t_max=2.0, step=0.01)
    reference = chaos_map.compute_map(chain, resolution=5, t_max=2.0, step=0.01)
    assert messages == [] and times.shape == (5, 5)
    flipped = reference > 0
    assert flipped.any() and np.array_equal(flipped, times > 0)
    np.testing.assert_allclose(times[flipped], reference[flipped], atol=0.021)
    assert np.all(np.isnan(times[reference == chaos_map.FORBIDDEN]))


def test_a_closed_pose_holds_the_two_angles_and_closes_every_joint(double_file):
    mechanism = mechanism_cases.load_case(file=str(double_file))
    constraints = mechanism_chaos.Constraints(mechanism)
    q = mechanism_chaos.pose_with_angles(constraints, constraints.sketch_pose(), (2, 5), (1.0, -2.0), 1.0)
    assert q is not None and q[2] == pytest.approx(1.0) and q[5] == pytest.approx(-2.0)
    assert np.max(np.abs(constraints.residual(q))) < 1e-12
    # the tip of the upper bar at (sin 1, -cos 1): the pose is the pendulum's, not just any closed one
    np.testing.assert_allclose(mechanism_cases.point_path(mechanism, q, "upper.A")[0], [np.sin(1.0), -np.cos(1.0)])


def test_chaos_map_of_a_mechanism_file_on_the_command_line(tmp_path, double_file):
    out, data = tmp_path / "map.png", tmp_path / "map.npy"
    assert chaos_map.main(["--mechanism", str(double_file), "--coordinates", "lower,upper", "--resolution", "2",
                           "--t-max", "0.3", "--workers", "1", "--no-progress", "--out", str(out),
                           "--data", str(data)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and np.load(data).shape == (2, 2)


@pytest.mark.parametrize("args, needle", [
    (["--preset", "slider-crank"], "mobility 1"),
    (["--preset", "jansen-leg"], "mobility 0"),
    (["--coordinates", "upper,upper"], "different bodies"),
    (["--coordinates", "upper,hip"], "'hip'"),
    (["--resolution", "3000"], "resolution"),
    (["--links", "3"], "--links"),
])
def test_chaos_map_of_a_mechanism_refuses_in_one_line(args, needle, tmp_path, double_file):
    source = [] if "--preset" in args else ["--mechanism", str(double_file)]
    with pytest.raises(LinkageError, match=needle):
        chaos_map.main([*source, *args, "--workers", "1", "--out", str(tmp_path / "m.png")])


def test_chaos_map_refuses_coordinates_for_a_chain(tmp_path):
    with pytest.raises(LinkageError, match="--coordinates"):
        chaos_map.main(["--preset", "double", "--coordinates", "bar1,bar2", "--out", str(tmp_path / "m.png")])


# ------------------------------------------------------------------------------------------------
# 4. The ensemble


def test_an_ensemble_of_the_double_pendulum_as_a_mechanism_fans_open():
    preset = get_preset("double")
    mechanism = chain_mechanism(preset.chain, np.zeros(2))
    q0, qdot0 = chain_state(preset.chain, np.zeros(2), preset.theta0, preset.omega0)
    ensemble = MechanismEnsemble(mechanism, count=3, spread=1e-9, t_end=8.0, samples=9, q0=q0, qdot0=qdot0).run()
    spread = ensemble.tip_spread()
    assert ensemble.alive.all() and list(ensemble.alive_counts()) == [3] * 9
    assert 0 < spread[0] < 1e-8 and spread[-1] > 10 * spread[0]  # a chaotic start: the fan opens
    assert np.max(ensemble.energy_drift()) < 1e-8  # no motor: each copy keeps its energy
    # copy 0 is the plain run from the same start: the ensemble adds nothing to a copy's physics
    alone = simulate_mechanism(mechanism, 8.0, 9, q0=q0, qdot0=qdot0)
    np.testing.assert_allclose(ensemble.tips()[0], mechanism_cases.point_path(mechanism, alone.q, "bar2.D"),
                               atol=1e-12)


def test_an_ensemble_document_has_the_chain_ensembles_keys():
    ensemble = MechanismEnsemble(MECHANISM_PRESETS["slider-crank"](), count=3, spread=1e-6, t_end=0.5,
                                 samples=6).run()
    document = ensemble.document()
    for key in ("method", "count", "spread", "t", "tip_spread", "alive", "energy_drift", "message", "final_tips"):
        assert key in document, key
    assert document["probe"] == "piston.B" and document["mobility"] == 1 and document["message"] == "ok"
    assert len(document["t"]) == len(document["tip_spread"]) == 6 and np.array(document["final_tips"]).shape == (3, 2)
    assert json.loads(json.dumps(document)) == document
    outlines = ensemble.outlines()
    assert outlines.shape == (3, 5, 2) and np.all(np.isfinite(outlines))  # crank O, A; rod A, B; piston B
    picture = fan_picture(outlines, ensemble.alive, size=100)  # what `ensemble --out fan.png` draws
    assert picture.shape == (100, 100, 3) and (picture < 255).any()
    outlines[1] = np.nan  # a failed copy's outline: left out, and the others still drawn to scale
    np.testing.assert_array_equal(fan_picture(outlines, np.array([True, False, True]), size=100)[:, :, 0] < 255,
                                  fan_picture(outlines[[0, 2]], np.array([True, True]), size=100)[:, :, 0] < 255)


def test_an_ensemble_of_a_fully_driven_mechanism_says_why_its_fan_stays_shut():
    ensemble = MechanismEnsemble(MECHANISM_PRESETS["jansen-leg"](), count=3, spread=1e-6, t_end=0.5,
                                 samples=6).run()
    assert ensemble.mobility == 0 and "mobility 0" in ensemble.note
    assert np.max(ensemble.tip_spread()) < 1e-9


@pytest.mark.parametrize("kwargs, field", [({"count": 0}, "count"), ({"count": 1001}, "count"),
                                           ({"spread": 2.0}, "spread"), ({"method": "x"}, "method"),
                                           ({"t_end": -1.0}, "t_end"), ({"samples": 1}, "samples")])
def test_a_mechanism_ensemble_names_a_bad_argument(kwargs, field):
    with pytest.raises(LinkageError, match=field):
        MechanismEnsemble(MECHANISM_PRESETS["slider-crank"](), **kwargs)
