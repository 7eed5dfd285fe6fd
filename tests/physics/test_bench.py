"""The work-precision benchmark command (physics.studies.bench, physics.studies.work_precision) and the chart writer
(physics.studies.charts).

Speed itself is never asserted here (it is measured by the command and recorded in BENCHMARKS.md); these tests
check that ``python -m physics bench --quick`` runs and that what it writes is sane."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from physics import LinkageError, get_preset
from physics.studies import work_precision
from physics.studies.charts import Series, colormap, html_page, line_chart

ROOT = Path(__file__).resolve().parents[2]


def _run(*args, timeout=400):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "physics", "bench", *args], capture_output=True, text=True,
                          cwd=ROOT, env=env, timeout=timeout)


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    result = _run("--quick", "--out", str(out))
    assert result.returncode == 0, result.stderr[-2000:]
    return out, result


@pytest.mark.slow  # the quick_run fixture runs `bench --quick` (about a minute)
def test_quick_bench_writes_json_svg_html(quick_run):
    out, result = quick_run
    document = json.loads((out / "work_precision.json").read_text())
    case = document["cases"]["triple-c"]
    assert case["horizon"] == 5.0 and case["reference"]["uncertainty"] < 1e-11
    labels = [c["label"] for c in case["curves"]]
    for integrator in ("RK45", "DOP853", "Radau", "LSODA", "midpoint", "variational"):
        assert any(integrator in label for label in labels)
    for curve in case["curves"] + case["baseline"]:
        points = curve["points"]
        assert all(p["seconds"] > 0 for p in points)
        errors = [p["error"] for p in points]
        assert all(e is not None and np.isfinite(e) for e in errors), curve["label"]
        # Loosest setting first: tightening the tolerance (or the step) must buy accuracy.
        assert errors[-1] < 1e-2 * errors[0], (curve["label"], errors)
    svg = (out / "work_precision_triple-c.svg").read_text()
    assert svg.startswith("<svg") and svg.count('<path d="M') >= len(labels)
    html = (out / "work_precision.html").read_text()
    assert html.count("<svg") == 1 and "Headline" in html
    assert not re.search(r"""(src|href)=["']?(https?:)?//""", html)  # self-contained
    assert "work-precision" in result.stderr  # the progress bar


@pytest.mark.slow  # the quick_run fixture runs `bench --quick` (about a minute)
def test_quick_bench_headline_compares_with_the_baseline(quick_run):
    out, result = quick_run
    document = json.loads((out / "work_precision.json").read_text())
    rows = [row for row in document["headline"] if row["speedup"] is not None]
    assert len(rows) >= 3
    for row in rows:
        assert row["ours"]["error"] <= row["accuracy"] and row["baseline"]["error"] <= row["accuracy"]
        assert row["speedup"] == pytest.approx(row["baseline"]["seconds"] / row["ours"]["seconds"])
    assert "| accuracy | ours |" in result.stdout  # the Markdown summary BENCHMARKS.md quotes


def _curve(label, points):
    return {"label": label, "points": [dict(tolerance=t, error=e, seconds=s, status=0) for t, e, s in points]}


def test_winners_pick_the_fastest_point_reaching_each_accuracy():
    fast_loose = _curve("fast", [(1e-3, 1e-3, 0.001), (1e-6, 1e-6, 0.002)])
    slow_tight = _curve("slow", [(1e-3, 1e-5, 0.010), (1e-9, 1e-10, 0.020)])
    rows = work_precision.winners([fast_loose, slow_tight], (1e-3, 1e-5, 1e-8, 1e-12), uncertainty=1e-13)
    assert [r["winner"] for r in rows] == ["fast", "fast", "slow", None]  # 1e-12 < 10 x uncertainty: not judged
    assert rows[0]["runner_up"] == "slow" and rows[1]["seconds"] == 0.002 and rows[2]["seconds"] == 0.020
    failed = _curve("failed", [(1e-3, 1e-9, 0.0001)])
    failed["points"][0]["status"] = -1
    assert work_precision.winners([failed], (1e-3,), 1e-13)[0]["winner"] is None


@pytest.mark.parametrize(
    "args, needle",
    [(["--preset", "nope"], "--preset"), (["--tolerances", "1"], "--tolerances"), (["--suite", "x"], "suite"),
     (["--repeats", "0"], "--repeats")],
)
def test_bad_arguments_fail_with_one_line(args, needle):
    result = _run(*args, timeout=60)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0] and "Traceback" not in result.stderr


def test_log_chart_leaves_out_what_a_log_axis_cannot_show():
    svg = line_chart([Series("a", [1e-3, 1e-2, 1e-1], [1e-6, 0.0, 1e-2]), Series("b", [1, 2], [float("nan"), 3])],
                     title="t", x_label="x", y_label="y", log_x=True, log_y=True)
    assert svg.count("<circle") == 2 + 1 + 2  # 2 + 1 drawable points, plus one legend marker per series
    assert "nan" not in svg.lower().replace("nan(", "")
    assert ">1e-6<" in svg.replace("1e-06", "1e-6") or "1e-6" in svg


def test_html_page_and_colormap():
    page = html_page("Title <x>", [("Part", "<p>body</p>")], intro="intro")
    assert page.startswith("<!DOCTYPE html>") and "Title &lt;x&gt;" in page and "<p>body</p>" in page
    rgb = colormap(np.array([0.0, 1.0, np.nan]))
    assert rgb.dtype == np.uint8 and rgb.shape == (3, 3)
    assert tuple(rgb[2]) == (0, 0, 0) and tuple(rgb[0]) != tuple(rgb[1])


def test_work_precision_for_any_chain_as_the_app_asks():
    preset = get_preset("four-bar")  # closed: the error is measured on the coupler point, the tip being pinned
    case, svg = work_precision.work_precision_chain(preset.chain, preset.theta0, preset.omega0, trace=preset.trace,
                                           horizon=2.0, integrators=("DOP853",), tolerances=(1e-4, 1e-8))
    assert case["probe"] == "coupler point" and case["horizon"] == 2.0
    (curve,) = [c for c in case["curves"] if c["integrator"] == "DOP853" and c["formulation"] == "lagrange"]
    loose, tight = (p["error"] for p in curve["points"])
    assert 0.0 < tight < 1e-2 * loose
    assert svg.startswith("<svg") and "coupler point" in svg
    with pytest.raises(LinkageError, match="horizon"):
        work_precision.work_precision_chain(preset.chain, preset.theta0, preset.omega0, horizon=-1.0)
