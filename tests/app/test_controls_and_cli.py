"""Slider ranges agree with the models; the command line serves or fails in one line; smaller controls."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import urllib.request
from pathlib import Path

import numpy as np
import pytest

import physics
from app import chain_knobs, mechanism_edits, panel_rows, viser_compat
from app.mechanism_runs import MechanismSettings
from app.scene import camera_pose
from app.server import is_loopback
from app.wsclient import BackgroundClient, moves_positions
from conftest import wait_until

ROOT = Path(__file__).resolve().parents[2]


def _inside(spec, low, high):
    lo, lo_open, hi, hi_open = spec.bounds()
    assert (low > lo) if lo_open else (low >= lo), (spec.field, low, lo)
    assert (high < hi) if hi_open else (high <= hi), (spec.field, high, hi)


@pytest.mark.parametrize(
    "spec",
    [*chain_knobs.BAR_SLIDERS.values(), chain_knobs.GRAVITY_SLIDER, chain_knobs.DAMPING_SLIDER,
     panel_rows.SPEED_SLIDER, panel_rows.TRACE_SLIDER, panel_rows.ARROW_SLIDER],
    ids=lambda s: f"{s.model.__name__}.{s.field}",
)
def test_slider_ranges_sit_inside_the_model_bounds(spec):
    low, high = spec.range()
    assert low < high
    _inside(spec, low, high)
    # a preset value beyond the useful range widens the slider, never past the model's bound
    low, high = spec.range(1e9)
    _inside(spec, low, high)


def test_the_run_settings_sliders_map_inside_the_settings_bounds():
    """The Simulation tab's numbers (app/mechanism_edits.settings_knobs): the tolerance's log10 slider, the fixed
    step in ms and the Baumgarte gains stay inside the models' bounds at both ends."""
    rtol = physics.Settings.model_fields["rtol"].metadata
    knobs = {knob.name: knob for knob in mechanism_edits.settings_knobs(MechanismSettings())}
    lo_exp, hi_exp = knobs["rtol"].slider_bounds()
    ge = next(m.ge for m in rtol if hasattr(m, "ge"))  # rtol's floor is inclusive (1e-14, physics.model)
    le = next(m.le for m in rtol if hasattr(m, "le"))
    assert ge <= 10.0**lo_exp and 10.0**hi_exp <= le
    step = physics.Settings.model_fields["step"].metadata
    gt = next(m.gt for m in step if hasattr(m, "gt"))
    le = next(m.le for m in step if hasattr(m, "le"))
    lo_ms, hi_ms = knobs["step"].slider_bounds()
    assert gt < lo_ms * 1e-3 and hi_ms * 1e-3 <= le
    for name in ("baumgarte_alpha", "baumgarte_beta"):
        low, high = knobs[name].slider_bounds()
        bounds = physics.Settings.model_fields[name].metadata
        assert low >= next(m.ge for m in bounds if hasattr(m, "ge")), name
        upper = [m.le for m in bounds if hasattr(m, "le")]
        assert not upper or high <= upper[0], name


def test_dropdowns_offer_the_model_literals(connect):
    _, session = connect()
    assert tuple(session.integrator.options) == tuple(physics.INTEGRATOR_NAMES)
    assert set(session.stabilization.options) == {"none", "baumgarte", "projection"}


def test_a_value_outside_the_model_is_refused_with_its_name(connect):
    _, session = connect()
    before = list(session.params.L)
    session.guard(lambda: session.set("L2", -1.0))
    assert session.params.L == before
    assert session.notice is not None and "L2" in session.notice and "-1" in session.notice
    session.guard(lambda: session.set("nonsense", 3))
    assert "unknown parameter" in session.notice


def test_variational_integrator_runs_with_lagrange_and_is_refused_elsewhere(connect):
    _, session = connect()
    session.integrator.value = "variational"  # as the browser sends it
    assert session.params.integrator == "variational" and session.notice is None
    assert session._knob_handles["step"].visible and not session._knob_handles["rtol"].visible  # noqa: SLF001
    assert wait_until(lambda: session.snapshot()["time"] > 1.0)
    # Compare mode needs one integrator for all three methods: refused, the checkbox goes back off.
    session.compare_box.value = True
    assert not session.compare and session.notice is not None and "variational" in session.notice
    assert session.compare_box.value is False
    # Another method with the variational integrator: refused, naming the fix; the dropdown shows the method
    # in force again.
    session.method.value = "DAE"
    assert session.params.method == "lagrange"
    assert "method = Lagrange" in session.notice  # as the menu names it (the model says "lagrange")
    assert session.method.value == "Lagrange"


def test_chain_links_slider_rebuilds_bars_and_scene(connect):
    _, session = connect()
    session.menu.value = "chain"  # as the browser sends it
    links = session._knob_handles["links"]  # noqa: SLF001 - the Bars (chain) slider
    assert session.params.preset == "chain" and links.visible
    links.value = 4
    assert session.params.n == 4
    knobs = session._knob_handles  # noqa: SLF001 - a slider per bar's number and per start angle
    assert {"L4", "m4", "I4", "d4", "theta4", "omega4"} <= set(knobs) and not {"L5", "theta5"} & set(knobs)
    assert session.player.wait_idle(300)
    names = session.snapshot()["scene"]["names"]
    assert "/linkage/bar_4" in names and "/linkage/bar_5" not in names and "/linkage/joint_4" in names


def test_reaction_arrows_follow_the_dae_reactions(connect):
    _, session = connect()
    session.method.value = "DAE"
    session.arrow_box.value = True
    session.play()
    assert wait_until(lambda: session.arrows.handle is not None and session.arrows.handle.visible)
    assert session.arrows.count == session.params.n  # one per joint of an open chain
    session.arrow_box.value = False
    assert not session.arrows.handle.visible


def test_trace_and_plots_are_fed(connect):
    _, session = connect()
    session.play()
    assert wait_until(lambda: session.snapshot()["time"] > 1.0)
    assert session.trace.points_shown > 30
    assert session.energy_plot.points_shown > 30
    t, kinetic, potential, total = session.energy_plot.handle.data
    assert np.all(np.diff(t) > 0) and t[-1] > 0.7  # plots are refreshed 5 times a second
    assert np.allclose(total, kinetic + potential, rtol=1e-9, atol=1e-9)


def test_python_m_app_prints_the_url_it_serves_and_serves_the_client():
    proc = subprocess.Popen(
        [sys.executable, "-m", "app", "--port", "0"], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True,
    )
    try:
        line = proc.stdout.readline()
        match = re.search(r"http://127\.0\.0\.1:(\d+)", line)
        assert match, line
        with urllib.request.urlopen(match.group(0), timeout=30) as response:
            assert response.status == 200 and b"<html" in response.read(2000).lower()
    finally:
        proc.terminate()
        proc.wait(20)


def test_a_busy_port_moves_and_the_printed_url_follows(lab):
    proc = subprocess.Popen(
        [sys.executable, "-m", "app", "--port", str(lab.port)], cwd=ROOT, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True,
    )
    try:
        line = proc.stdout.readline()
        port = int(re.search(r":(\d+)", line.split("http://")[1]).group(1))
        assert port != lab.port
    finally:
        proc.terminate()
        _, err = proc.communicate(timeout=20)
    assert f"port {lab.port} is busy" in err


@pytest.mark.parametrize(
    "args, fragment",
    [
        (["--port", "70000"], "--port 70000"),
        (["--preset", "pentagon"], "--preset"),
        (["--method", "euler"], "--method"),
        (["--max-sessions", "0"], "--max-sessions 0: allowed range 1 <= max-sessions <= 100"),
        (["--max-sessions", "101"], "--max-sessions 101: allowed range 1 <= max-sessions <= 100"),
        (["--processes", "0"], "--processes 0: allowed range 1 <= processes <= 16"),
        (["--processes", "17"], "--processes 17: allowed range 1 <= processes <= 16"),
        (["--links", "5"], "links"),
        (["--host", "203.0.113.7"], "--host 203.0.113.7"),
        (["--bogus"], "unrecognized arguments"),
    ],
)
def test_bad_flags_fail_in_one_line(args, fragment):
    result = subprocess.run([sys.executable, "-m", "app", *args], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("linkage-lab: error:") and fragment in lines[0], result.stderr
    assert "Traceback" not in result.stderr and result.stdout == ""


def test_loopback_detection():
    assert is_loopback("127.0.0.1") and is_loopback("localhost") and is_loopback("::1")
    assert not is_loopback("0.0.0.0") and not is_loopback("192.168.1.10")


@pytest.mark.slow  # a fresh cache: the app compiles the kernels and derives while the test watches
def test_a_cold_start_shows_the_mechanism_and_a_deriving_notice_then_animates(tmp_path):
    """Empty derivation cache: the page is never blank; it says it is deriving, then the motion starts."""
    env = dict(os.environ, LINKAGE_LAB_CACHE=str(tmp_path / "cold-cache"))
    proc = subprocess.Popen(
        [sys.executable, "-m", "app", "--port", "0", "--preset", "single"], cwd=ROOT, env=env,
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    client = None
    try:
        url = re.search(r"http://\S+", proc.stdout.readline()).group(0)
        client = BackgroundClient(url)
        assert client.wait_for(lambda c: c.bar_updates() >= 1, timeout=60)  # the start pose, before any physics
        assert client.wait_for(lambda c: any("Deriving" in title for _, title in c.notifications), timeout=60)
        assert client.wait_for(lambda c: c.bar_updates() >= 5, timeout=600)  # then it animates
        first_notice = min(t for t, title in client.counts.notifications if "Deriving" in title)
        positions = [t for t, m in client.counts.watched if moves_positions(m)]
        assert positions[0] <= first_notice < positions[1]
    finally:
        if client is not None:
            client.close()
        proc.terminate()
        proc.wait(20)


def test_camera_backs_off_on_a_canvas_narrower_than_tall():
    lengths = np.array([1.0, 1.0, 1.0])
    position, look_at = camera_pose(lengths, None, aspect=1.5)
    wide = np.linalg.norm(position - look_at)
    assert np.linalg.norm(np.subtract(*camera_pose(lengths, None, aspect=1.0))) == pytest.approx(wide)
    assert np.linalg.norm(np.subtract(*camera_pose(lengths, None, aspect=0.5))) == pytest.approx(2.0 * wide)


def test_a_browser_reporting_a_narrow_canvas_gets_its_camera_reframed(connect):
    _, session = connect()
    camera = session.target.camera
    assert wait_until(lambda: id(camera) in session.camera.framed_aspect)  # framed on the first report (1280 x 720)
    wide = np.linalg.norm(np.asarray(camera.position) - np.asarray(camera.look_at))

    class NarrowCanvas:  # what a portrait window reports; position etc. are written by the session
        aspect = 0.5
        position = look_at = up_direction = None

    report = NarrowCanvas()
    for callback in viser_compat.camera_callbacks(camera):  # what viser calls on a browser's camera report
        callback(report)
    assert report.position is not None
    narrow = np.linalg.norm(np.asarray(report.position) - np.asarray(report.look_at))
    assert narrow == pytest.approx(2.0 * wide, rel=1e-9)


@pytest.mark.parametrize(("preset", "links", "words"), [
    ("four-bar", None, "3 bars, closed loop, tip pinned at H; 1 degree of freedom"),
    ("triple-a", None, "3 bars, open chain; 3 degrees of freedom"),
    ("chain", 1, "1 bar, open chain; 1 degree of freedom"),
])
def test_the_chain_panel_counts_its_degrees_of_freedom_in_words(preset, links, words):
    from app.parameters import SessionParameters  # noqa: PLC0415

    assert chain_knobs.facts_line(SessionParameters.from_preset(preset, links=links)).startswith(words)
