"""The Analysis folder of a general mechanism (issue 24; app/mechanism_analysis.py): the studies the command line
runs for a mechanism, computed in workers for the one shown, each refused in one line where it does not apply,
and never drawn for a mechanism that has been replaced meanwhile."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from app.mechanism_analysis import (
    CHAIN_ENSEMBLE_COUNTS,
    CHAOS_RESOLUTION,
    ENSEMBLE_COUNTS,
    ENSEMBLE_RATE,
    ENSEMBLE_SECONDS,
    ENSEMBLE_SPREAD,
)
from app.session import Session
from conftest import lab_of, wait_until
from physics.ensemble import Ensemble, MechanismEnsemble
from physics.mechanism.constraints import Constraints

ROOT = Path(__file__).resolve().parents[2]
slider_lab = lab_of("slider-crank")
rocker_lab = lab_of("crank-rocker")


def flat_double_pendulum() -> bytes:
    """docs/examples' double pendulum sketched horizontal: released from there it moves chaotically."""
    text = (ROOT / "docs/examples/double-pendulum.toml").read_text()
    for old, new in (("A = [0.0, -1.0]", "A = [1.0, 0.0]"), ("B = [0.0, -2.0]", "B = [2.0, 0.0]"),
                     ("com = [0.0, -0.5]", "com = [0.5, 0.0]"), ("com = [0.0, -1.5]", "com = [1.5, 0.0]")):
        assert old in text
        text = text.replace(old, new)
    return text.encode()


def titles(analysis, since: int = 0) -> list[str]:
    return [title for title, _ in analysis.notices[since:]]


def test_studies_that_do_not_apply_are_refused_in_one_line_each(rocker_lab, connect):
    _, session = connect(rocker_lab)
    assert isinstance(session, Session) and session.mobility == 0
    analysis = session.analysis
    session.guard(analysis.chaos_map)
    assert titles(analysis) == ["Chaos map refused"]
    assert "mobility 0" in analysis.notices[0][1] and "mobility >= 2" in analysis.notices[0][1]
    assert "Chaos map refused" in (session.notices.text or "") and analysis.image_handle is None
    session.guard(lambda: analysis.set_ensemble(True))
    assert titles(analysis, 1) == ["Ensemble refused"] and "mobility 0" in analysis.notices[1][1]
    assert analysis.ensemble_box.value is False and analysis.ensemble_node is None
    session.guard(analysis.equilibria)  # a speed motor fixes every body: no rest pose
    assert titles(analysis, 2) == ["Rest poses refused"] and "nothing is free" in analysis.notices[2][1]
    assert not analysis._jobs  # nothing was started


def test_chaos_map_is_refused_for_mobility_one(slider_lab, connect):
    _, session = connect(slider_lab)
    assert session.mobility == 1
    session.guard(session.analysis.chaos_map)
    assert titles(session.analysis) == ["Chaos map refused"]
    assert "mobility 1" in session.analysis.chaos_status.content and "mobility >= 2" in session.analysis.notices[0][1]


@pytest.mark.slow
def test_work_precision_chart_has_points_for_every_method(slider_lab, connect):
    _, session = connect(slider_lab)
    analysis = session.analysis
    session.guard(analysis.work_precision_chart)
    assert "**Computing**" in analysis.chart_status.content
    analysis.wait("chart")
    assert titles(analysis) == ["Computing", "Done"], analysis.notices
    # issue 26: "Computing the work-precision chart" stayed on screen after the chart appeared
    assert not (session.notices.text or "").startswith("Computing"), session.notices.text
    svg = analysis.chart_html.content
    assert svg.count("<svg") == 1 and 'width="100%"' in svg  # drawn at the panel's width, as the chain's
    # a curve per method of a mobility-1 mechanism, each with one marked point per tolerance swept
    for method in ("newton_euler", "lagrange", "dae", "reduced"):
        assert f"{method} / DOP853" in svg
        for tolerance in ("0.0001", "1e-06", "1e-08"):
            assert f"{method} / DOP853 ({'position analysis' if method == 'reduced' else 'projection'}) " \
                   f"tolerance={tolerance}:" in svg, (method, tolerance)
    assert "0 failed runs" in analysis.chart_status.content


def test_rest_poses_are_listed_and_cleared_when_the_mechanism_changes(slider_lab, connect):
    _, session = connect(slider_lab)
    analysis = session.analysis
    session.guard(analysis.equilibria)
    analysis.wait("equilibrium")
    assert titles(analysis) == ["Computing", "Done"], analysis.notices
    poses = analysis.poses
    assert poses and poses[0].stable  # lowest potential first: the crank hanging is stable
    constraints = Constraints(session.mechanism)
    for pose in poses:  # every pose listed closes every joint
        assert np.max(np.abs(constraints.residual(pose.q, 0.0))) < 1e-9
    table = analysis.rest_status.content
    rows = [line for line in table.splitlines() if line.startswith("| ") and "°" in line]
    assert len(rows) == len(poses) and all(row.count("°") == len(session.mechanism.bodies) for row in rows)
    assert f"{len(poses)} found" in table
    session.guard(lambda: session.choose("watt-six-bar"))
    assert wait_until(lambda: analysis.rest_status.content == "", timeout=10)  # not another mechanism's list


def test_a_mechanism_change_discards_a_running_study(slider_lab, connect):
    _, session = connect(slider_lab)
    analysis = session.analysis
    session.guard(analysis.work_precision_chart)
    session.guard(lambda: session.choose("watt-six-bar"))
    analysis.wait("chart")
    assert titles(analysis) == ["Computing", "Work-precision chart discarded"], analysis.notices
    assert analysis.chart_html.content == "" and "discarded" in analysis.chart_status.content
    # Reset is a change too: a running study of the run it replaced is not drawn
    session.guard(analysis.equilibria)
    session.guard(session.reset)
    analysis.wait("equilibrium")
    assert titles(analysis, 2) == ["Computing", "Rest poses discarded"], analysis.notices
    assert analysis.poses == []


def test_an_ensemble_called_off_or_outrun_by_a_change_is_never_drawn(slider_lab, connect):
    _, session = connect(slider_lab)
    analysis = session.analysis
    session.guard(lambda: analysis.set_ensemble(True, "100"))
    session.guard(lambda: analysis.set_ensemble(False))  # the box unticked while the copies are computed
    analysis.wait("ensemble")
    assert titles(analysis) == ["Computing"] and analysis.ensemble_node is None and analysis.ensemble is None
    session.guard(lambda: analysis.set_ensemble(True, "100"))
    session.guard(lambda: session.choose("watt-six-bar"))
    analysis.wait("ensemble")
    assert titles(analysis, 1) == ["Computing", "Ensemble discarded"], analysis.notices
    assert analysis.ensemble_node is None and analysis.ensemble_box.value is False
    session.guard(lambda: analysis.set_ensemble(True, "many"))
    assert titles(analysis, 3) == [] and "ensemble copies = 'many': allowed 20, 100" in (session.notices.text or "")


@pytest.mark.slow
def test_ensemble_copies_drawn_over_a_mobility_two_mechanism_diverge(slider_lab, connect):
    _, session = connect(slider_lab)
    session.guard(lambda: session.load_file(None, "flat-double-pendulum.toml", flat_double_pendulum()))
    assert session.mobility == 2 and session.label == "flat-double-pendulum.toml"
    analysis = session.analysis
    session.pause()
    session.guard(lambda: analysis.set_ensemble(True))
    analysis.wait("ensemble")
    assert titles(analysis) == ["Computing", "Done"], analysis.notices
    ensemble = analysis.ensemble
    assert ensemble is not None and ensemble.alive.all() and analysis.ensemble_node is not None
    spread = ensemble.tip_spread()
    # a hair apart at first (every body turned at most (count - 1) x spread; the tip 2 m out), then far apart
    assert spread[1] < 3 * ensemble.count * ENSEMBLE_SPREAD and spread[-1] > 100 * spread[1]
    # the copies drawn in the scene follow the displayed time: near the start they overlap, later they part
    t0, late = analysis._ensemble_t0, ENSEMBLE_SECONDS - 0.5

    def tip_spread_drawn() -> float:
        drawn = np.asarray(analysis.ensemble_node.points).reshape(ensemble.count, -1, 2, 3)
        tips = drawn[:, -1, 1, :]  # the lower bar's free end of every copy
        return float(np.max(np.linalg.norm(tips - tips[0], axis=1)))

    assert session.player.seek(t0 + late, timeout=120)
    assert wait_until(lambda: analysis._ensemble_index == round(late * ENSEMBLE_RATE), timeout=10)
    far = tip_spread_drawn()
    assert session.player.seek(t0, timeout=60)
    assert wait_until(lambda: analysis._ensemble_index == 0, timeout=10)
    near = tip_spread_drawn()
    assert near < 3 * ensemble.count * ENSEMBLE_SPREAD and far > 0.05 and far > 100 * near, (near, far)
    # another run (Reset) takes the copies away: they were of the run replaced
    session.guard(session.reset)
    assert wait_until(lambda: analysis.ensemble_node is None and analysis.ensemble_box.value is False, timeout=10)


@pytest.mark.slow
def test_chaos_map_of_a_mobility_two_mechanism(slider_lab, connect):
    _, session = connect(slider_lab)
    content = (ROOT / "docs/examples/double-pendulum.toml").read_bytes()
    session.guard(lambda: session.load_file(None, "double-pendulum.toml", content))
    assert session.mobility == 2
    analysis = session.analysis
    session.guard(analysis.chaos_map)
    analysis.wait("chaos", timeout=600)
    assert titles(analysis) == ["Computing", "Done"], analysis.notices
    times = analysis.times
    assert times is not None and times.shape == (CHAOS_RESOLUTION, CHAOS_RESOLUTION)
    # the hanging pendulum started near rest never turns over; started high, it does (as the chain's map)
    middle = CHAOS_RESOLUTION // 2
    assert np.isnan(times[middle, middle]) and np.isnan(times[middle - 1, middle - 1])
    assert np.count_nonzero(times > 0) > CHAOS_RESOLUTION
    status = analysis.chaos_status.content.replace("\\", "")  # markdown_literal escapes the dots
    assert analysis.image_handle is not None and "upper.phi across, lower.phi up" in status


def test_the_studies_follow_the_kind_shown_a_mechanism_or_a_hosted_chain(slider_lab, connect):
    """One Analysis section for every preset: a mechanism's studies (20 or 100 whole runs, a 16 x 16 map), and once
    a chain preset is hosted in the same session the chain tab's (100 or 1000 batched RK4 copies, the double
    pendulum's 64 x 64 map); back to a mechanism, its own again."""
    _, session = connect(slider_lab)
    analysis = session.analysis
    assert session.chain is None
    assert analysis.count_dropdown.options == ENSEMBLE_COUNTS and analysis.ensemble_count == 20
    assert analysis.chaos_button.label == f"Chaos map ({CHAOS_RESOLUTION} x {CHAOS_RESOLUTION})"
    session.guard(lambda: session.set_mechanism("double"))
    assert session.chain is not None
    session.pause()
    session.guard(lambda: analysis.set_ensemble(True))  # at once: the click after the change gets the chain's
    assert analysis.count_dropdown.options == CHAIN_ENSEMBLE_COUNTS and analysis.ensemble_count == 100
    assert analysis.count_dropdown.value == "100"
    assert analysis.chaos_button.label == "Chaos map (double pendulum, 64 x 64)"
    analysis.wait("ensemble", timeout=600)
    assert isinstance(analysis.ensemble, Ensemble) and analysis.ensemble.count == 100, analysis.notices
    assert analysis.ensemble.spread == 1e-9 and np.array(analysis.ensemble_node.points).shape == (100 * 2, 2, 3)
    session.guard(lambda: session.set_mechanism("slider-crank"))  # the chain's copies are not the mechanism's
    assert wait_until(lambda: analysis.ensemble_node is None and analysis.ensemble_box.value is False, timeout=10)
    assert analysis.count_dropdown.options == ENSEMBLE_COUNTS and analysis.ensemble_count == 20
    assert analysis.chaos_button.label == f"Chaos map ({CHAOS_RESOLUTION} x {CHAOS_RESOLUTION})"
    session.guard(lambda: analysis.set_ensemble(True))
    analysis.wait("ensemble")
    assert isinstance(analysis.ensemble, MechanismEnsemble) and analysis.ensemble.count == 20, analysis.notices
