"""Sessions on a real server: controls change the simulation and the scene; errors stay in their session.

Every chain preset is hosted by the one session (app/session.py, ``Session.for_chain``): its
panel's controls are driven by assigning ``handle.value``, which runs the same callbacks as a browser's slider (a
knob's slider is ``session._knob_handles[name]``, named as the chain's ``--set``: ``m2``, ``L1``, ``theta1``, ``g``).
"""

from __future__ import annotations

import gc
import json
import math
import time
import weakref

import numpy as np
import pytest

import physics
from app.equations import equations_html, equations_tex
from app.server import LabServer
from conftest import BrowserStandIn, wait_until


def test_a_browser_gets_its_own_animating_session(lab, connect):
    client, session = connect()
    assert wait_until(lambda: session.snapshot()["time"] > 0.3)
    snap = session.snapshot()
    json.dumps(snap)  # JSON-able as promised
    n = snap["parameters"]["links"]
    names = set(snap["scene"]["names"])
    expected = {f"/linkage/bar_{k}" for k in range(1, n + 1)} | {f"/linkage/joint_{k}" for k in range(n + 1)}
    expected |= {f"/linkage/com_{k}" for k in range(1, n + 1)} | {"/linkage/ground", "/linkage/trace"}
    assert expected <= names
    # the browser receives pose updates of the bars, one per displayed frame
    assert client.wait_for(lambda c: c.bar_updates() >= 20)
    # the tip in the scene is where the simulation says it is
    tip_node = snap["scene"]["nodes"][f"/linkage/joint_{n}"]["position"]
    assert tip_node[1] == 0.0  # the mechanism lives in the vertical x-z plane
    energy = snap["energy"]
    assert math.isclose(energy["total"], energy["kinetic"] + energy["potential"], rel_tol=1e-9, abs_tol=1e-12)


def test_mass_slider_changes_the_motion(connect):
    _, session = connect()
    assert session.goto_time(2.0)
    before = session.snapshot()
    handle = session._knob_handles["m2"]
    handle.value = 3.0  # as the browser's slider does
    assert session.params.m[1] == 3.0
    assert session.goto_time(2.0)
    after = session.snapshot()
    assert after["parameters"]["bars"][1]["m"] == 3.0
    assert before["time"] == pytest.approx(2.0) and after["time"] == pytest.approx(2.0)
    assert not np.allclose(before["theta"], after["theta"], atol=1e-6)
    bar_3 = "/linkage/bar_3"
    assert before["scene"]["nodes"][bar_3]["position"] != after["scene"]["nodes"][bar_3]["position"]


def test_a_change_mid_run_continues_from_the_displayed_state(connect):
    _, session = connect()
    session.play()
    assert wait_until(lambda: session.snapshot()["time"] > 1.0)
    session.pause()
    assert session.player.wait_idle(120)
    t_before = session.snapshot()["time"]
    session._knob_handles["g"].value = 2.5
    assert session.player.wait_idle(120)
    snap = session.snapshot()
    assert snap["parameters"]["g"] == 2.5
    assert snap["time"] == pytest.approx(t_before, abs=1.5 / 60)  # not back to zero
    session.play()
    assert wait_until(lambda: session.snapshot()["time"] > t_before + 0.5)


def test_method_dropdown_switches_formulation(connect):
    _, session = connect()
    session.method.value = "DAE"
    assert session.params.method == "dae"
    assert session.player.wait_idle(120)
    session.play()
    assert wait_until(lambda: session.snapshot()["time"] > 0.5)
    snap = session.snapshot()
    assert snap["runs"][0]["method"] == "dae"
    history = session.history()
    # the DAE run reports joint reactions; a chain hanging from O is held up by reaction 0
    assert np.any(np.abs(history["reactions"]) > 1e-6)


def test_length_slider_resizes_the_bar_and_caps_d(connect):
    _, session = connect()
    handles = session._knob_handles
    handles["L1"].value = 0.4
    assert session.params.L[0] == pytest.approx(0.4)
    assert session.params.d[0] <= 0.4 + 1e-12
    assert handles["d1"].max == pytest.approx(0.4)
    assert handles["d1"].value <= 0.4 + 1e-12
    bars = session.scene._bars  # noqa: SLF001 - the scene's batched bar mesh, as the browser receives it
    assert bars.batched_scales[0][0] == pytest.approx(0.4)
    assert session.player.wait_idle(120)
    joints = np.array(session.snapshot()["joints"])
    assert np.linalg.norm(joints[1] - joints[0]) == pytest.approx(0.4, rel=1e-6)


def test_invalid_value_shows_a_notice_and_keeps_the_last_valid_chain(connect):
    _, session = connect()
    handles = session._knob_handles
    handles["I3"].value = 0.0
    handles["m3"].value = 0.0  # with I = 0 too, bar 3 has no inertia: refused
    assert session.params.m[2] > 0.0
    assert session.notice is not None and "bar 3" in session.notice
    session.play()
    t0 = session.snapshot()["time"]
    assert wait_until(lambda: session.snapshot()["time"] > t0 + 0.2)  # still running


def test_closed_loop_unreachable_angle_keeps_the_last_valid_start(connect):
    _, session = connect()
    session.set_mechanism("four-bar")
    assert session.params.pinned
    theta_before = session.params.theta0.copy()
    slider = session._knob_handles["theta1"]
    slider.value = 60.0  # the seed four-bar's crank reaches only about [89.4°, 366°]
    assert np.allclose(session.params.theta0, theta_before)
    assert session.notice is not None and "cannot close" in session.notice
    # theta2 and theta3 are assembled, not set: shown greyed ("follows the loop"), with no box to type in
    for name in ("theta2", "theta3"):
        assert session._knob_handles[name].disabled and name not in session._typed_boxes
    slider.value = 150.0
    assert math.degrees(session.params.theta0[0]) == pytest.approx(150.0)
    residual = physics.loop_closure.loop_residual(session.params.L, session.params.theta0, session.params.pin)
    assert np.hypot(*residual) < 1e-9


def test_singular_start_pauses_with_a_notice_and_reset_recovers(connect):
    _, session = connect()
    session.menu.value = "change-point"
    assert session.player.wait_idle(120)
    session.play()
    assert wait_until(lambda: session.snapshot()["time"] > 0.2)
    good_theta = session.params.theta0.copy()
    session._knob_handles["theta1"].value = 90.0  # all four links on one line: singular
    assert wait_until(lambda: session.notice is not None and "singular" in session.notice)
    assert not session.player.playing
    snap = session.snapshot()
    assert snap["runs"][0]["failed"]
    assert "/linkage/bar_1" in snap["scene"]["nodes"]  # the scene still shows the linkage
    session.transport.value = "Reset"
    assert session.player.wait_idle(120)
    assert np.allclose(session.params.theta0, good_theta)
    session.play()
    assert wait_until(lambda: session.snapshot()["time"] > 0.3)
    assert session.notice is None
    assert session.snapshot()["runs"][0]["failed"] is None


def test_two_sessions_do_not_affect_each_other(connect):
    client_a, a = connect()
    client_b, b = connect()
    assert a is not b and a.target is not b.target
    a._knob_handles["m1"].value = 4.0
    a.method.value = "Newton-Euler"
    assert b.params.m[0] != 4.0
    assert b.params.method != "newton_euler" or a.params.method == b.params.method == "newton_euler"
    b.play()
    t_b = b.snapshot()["time"]
    a.pause()
    assert wait_until(lambda: b.snapshot()["time"] > t_b + 0.3)
    # each browser receives only its own session's poses
    count_b = client_b.counts.bar_updates()
    assert client_b.wait_for(lambda c: c.bar_updates() > count_b + 5)


def test_closing_a_browser_releases_its_session(lab, connect):
    client, session = connect()
    # an earlier test's browser may still be leaving: its session is counted closed before its seat is freed
    # (app/server.py _disconnect), so once the seats match the sessions every departure is counted
    assert wait_until(lambda: lab.seats.count == len(lab.sessions), timeout=30)
    closed_before = lab.closed_sessions
    assert session.id in {s.id for s in lab.sessions.values()}
    client.close()
    assert wait_until(lambda: session.id not in {s.id for s in lab.sessions.values()})
    assert session.closed
    assert wait_until(lambda: not session.player.alive, timeout=5)
    assert wait_until(lambda: lab.closed_sessions == closed_before + 1, timeout=10)


def test_pause_holds_time_and_step_advances_one_sample(connect):
    _, session = connect()
    session.pause()
    assert session.player.wait_idle(120)
    t0 = session.snapshot()["time"]
    time.sleep(0.3)  # a paused session's time stands still
    assert session.snapshot()["time"] == t0
    session.transport.value = "Step"
    assert wait_until(lambda: session.snapshot()["time"] > t0)
    assert session.snapshot()["time"] == pytest.approx(t0 + 1 / 60)


def test_compare_mode_runs_three_methods_that_agree_early(connect):
    _, session = connect()
    session.compare_box.value = True
    assert session.compare
    assert session.goto_time(1.0)
    snap = session.snapshot()
    assert [run["method"] for run in snap["runs"]] == list(physics.FORMULATION_NAMES)
    tips = np.array([run["joints"][-1] for run in snap["runs"]])
    assert np.max(np.abs(tips - tips[0])) < 1e-5  # one start, three derivations, same motion early on
    for method in physics.FORMULATION_NAMES:
        assert f"/compare/{method}/bar_1" in snap["scene"]["nodes"]
    # the single mechanism gives way to the three: its nodes are gone, not drawn under theirs
    assert session.scene._bars is None  # noqa: SLF001 - the scene's batched bar mesh
    assert set(session.compare_view.scenes) == set(physics.FORMULATION_NAMES)
    session.compare_box.value = False
    assert session.scene._bars is not None and session.scene._bars.visible  # noqa: SLF001
    assert not session.compare_view.scenes


def test_traced_point_and_trace_length(connect):
    _, session = connect()
    session.set("trace_seconds", 2.0)
    session.trace_menu.value = "joint 1"
    assert session.params.trace.bar == 1
    session.play()
    assert wait_until(lambda: session.trace.points_shown > 60)
    assert session.trace.points_shown <= 2 * 60 + 1
    history = session.history()
    joints = history["joints"][:, 1]
    assert np.allclose(history["trace_xy"], joints, atol=1e-9)


def test_exports(connect):
    _, session = connect()
    assert session.goto_time(1.0)
    csv = session.export_csv().decode()
    header = csv.splitlines()[0].split(",")
    assert header[:2] == ["t", "theta1"] and "energy" in header and "trace_x" in header
    assert len(csv.splitlines()) == 1 + 61  # t = 0 .. 1 s at 60 samples per second
    document = json.loads(session.export_json())
    assert document["columns"]["t"][-1] == pytest.approx(1.0)
    html = session.export_html()
    assert html.lstrip().lower().startswith("<!doctype html") and "__VISER_EMBED_DATA__" in html


DOUBLE = physics.get_preset("double").chain  # two bars, open


def test_equations_panel_renders_mathml():
    html = equations_html(DOUBLE, "newton_euler")
    assert html.count("<math") >= 3
    assert "&#952;" in html  # theta, printed by sympy's MathML printer
    assert "AMB" in html or "angular momentum" in html.lower() or "Newton-Euler" in html


def test_equations_as_latex_document():
    tex = equations_tex(DOUBLE, "dae")
    assert tex.startswith("\\documentclass") and tex.rstrip().endswith("\\end{document}")
    # the DAE a chain's run integrates, 2 bars: 4 LMB + 2 AMB + 4 pin rows + 2 rows of the bars' angles
    assert tex.count("\\item ") == 12
    assert "\\ddot{\\theta}_{1}" in tex


def test_shared_session_is_watched_by_every_browser():
    server = LabServer(port=0, shared=True, warm=False)
    try:
        a, b = BrowserStandIn(server.url), BrowserStandIn(server.url)
        assert a.wait_for(lambda c: c.bar_updates() > 10) and b.wait_for(lambda c: c.bar_updates() > 10)
        assert server.sessions == {} and server.shared_session is not None
        server.shared_session._knob_handles["L1"].value = 0.5
        assert server.shared_session.params.L[0] == 0.5
        a.close()
        b.close()
    finally:
        server.stop()


def test_a_browser_past_the_cap_is_turned_away_with_a_message():
    server = LabServer(port=0, max_sessions=1, warm=False)
    try:
        first = BrowserStandIn(server.url)
        assert wait_until(lambda: len(server.sessions) == 1)
        second = BrowserStandIn(server.url)
        assert wait_until(lambda: len(server.turned_away) == 1)
        assert second.wait_for(lambda c: c.by_type.get("NotificationShowMessage", 0) >= 1)
        assert len(server.sessions) == 1
        second.close()
        first.close()
        assert wait_until(lambda: len(server.sessions) == 0 and not server.turned_away)
    finally:
        server.stop()


def test_closed_loop_without_stabilisation_runs_on_and_shows_its_drift(connect):
    _, session = connect()
    session.set_mechanism("four-bar")
    session.stabilization.value = "none"
    session._knob_handles["rtol"].value = -6.0  # log10(rtol), loose: the loop visibly drifts open
    assert session.goto_time(12.0)
    snap = session.snapshot()
    assert snap["runs"][0]["failed"] is None and snap["time"] == pytest.approx(12.0)
    drift_open = snap["energy"]["constraint_error"]
    assert drift_open > 1e-8  # chunked simulation kept the drift (it is not re-closed between chunks)
    session.stabilization.value = "projection"
    assert session.goto_time(12.0)
    assert session.snapshot()["energy"]["constraint_error"] < drift_open / 100


def test_a_closed_session_is_garbage(lab, connect):
    client, session = connect()
    ring = weakref.ref(session.player.runs[0].ring)
    ref = weakref.ref(session)
    del session
    client.close()
    assert wait_until(lambda: (gc.collect(), ref() is None)[1], timeout=20)
    assert ring() is None


def test_a_run_that_stops_midway_pauses_with_a_notice_and_reset_recovers(connect):
    _, session = connect()
    session.set_mechanism("four-bar")
    session.method.value = "Reduced, theta1 fixed"  # stops at the four-bar's first dead centre
    assert session.params.method == "reduced_fixed"
    assert session.goto_time(10.0)
    assert wait_until(lambda: session.notice is not None and "collinear" in session.notice)
    snap = session.snapshot()
    t_stop = snap["time"]
    assert 0.0 < t_stop < 10.0 and snap["runs"][0]["failed"] and not snap["playing"]
    session.transport.value = "Reset"
    assert session.player.wait_idle(120)
    assert session.notice is None and session.snapshot()["time"] == 0.0
    session.play()
    assert wait_until(lambda: session.snapshot()["time"] > min(0.5, t_stop / 2))


def test_a_change_right_after_a_new_mechanism_applies_to_the_new_one(connect):
    """Regression: the state to go on from is the pending start, not the previous mechanism's last frame."""
    _, session = connect()
    session.pause()
    session.play()
    assert wait_until(lambda: session.snapshot()["time"] > 0.5)
    session.pause()
    with session.player.lock:  # holds the player thread back: the four-bar's start stays pending
        session.set_mechanism("four-bar")
        session.method.value = "DAE"
        assert session.params.method == "dae" and session.notice is None
    assert session.player.wait_idle(120)
    snap = session.snapshot()
    assert snap["runs"][0]["method"] == "dae"
    assert snap["time"] == 0.0  # still the four-bar's start, not the triple pendulum's time
    assert np.allclose(snap["theta"], physics.get_preset("four-bar").theta0, atol=1e-9)


def test_a_bar_of_next_to_no_inertia_is_refused_with_its_range(connect):
    """The long control run's hang: I1 = 1.2e-38 kg·m² with d1 = 1.8e-313 m (both inside their sliders' ranges)
    on a damped single bar needed more integrator steps for one sample than a run may take, and the restart was
    never shown. Below 1e-9 kg·m² about its joint a bar is refused, naming the bar and the range."""
    _, session = connect()
    handles = session._knob_handles
    handles["d3"].value = 0.0
    handles["m3"].value = 1.0
    handles["I3"].value = 1.17549435082e-38
    assert session.params.I[2] > 1e-9
    assert session.notice is not None and "bar 3" in session.notice and ">= 1e-09 kg·m²" in session.notice
