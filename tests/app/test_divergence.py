"""Compare mode's divergence plots (issue 15, honest Figures 12-13; issue 14 item 10, the whole run).

The curves are recomputed here from the runs' stored tips at full resolution, and the reference run is checked
against a single tight run of physics.simulate.
"""

from __future__ import annotations

import numpy as np

import physics
from app.divergence import REFERENCE_LABEL, VISIBLE_GAP
from app.frame_view import COMPARE_METHODS
from conftest import wait_until
from physics.model import validated


def tips_at(ring, t):
    return ring.get("joints", ring.index_at(t))[-1]


def test_each_method_against_a_converged_run_over_the_whole_run(connect):
    _, session = connect()
    session.set_mechanism("triple-c")
    session.set("integrator", "RK45")
    session.set("rtol", 1e-6)  # the seed report's settings: case C leaves the true motion before 20 s
    session.controls.compare.value = True
    assert session.view.divergence.honest.handle.visible
    assert session.goto_time(40.0, timeout=300)
    runs = {run.spec.label: run for run in session.player.runs}
    assert set(runs) == {*COMPARE_METHODS, REFERENCE_LABEL}
    plots = session.view.divergence
    plots.update(runs, session.player.display_time)  # what the frame view calls a few times a second
    data = [np.asarray(a) for a in plots.honest.handle.data]
    t = data[0]
    assert t[0] == 0.0 and t[-1] > 39.9  # the whole run, not the last 30 s
    between = [np.asarray(a) for a in plots.between_methods.handle.data]
    assert between[0][0] == 0.0 and between[0][-1] > 39.9
    reference = runs[REFERENCE_LABEL].ring
    for k in (len(t) // 10, len(t) // 3, len(t) // 2, len(t) - 1):
        for m, method in enumerate(COMPARE_METHODS):
            error = np.linalg.norm(tips_at(runs[method].ring, t[k]) - tips_at(reference, t[k]))
            assert data[m + 1][k] == np.float64(np.log10(max(error, 1e-16))) or abs(
                data[m + 1][k] - np.log10(max(error, 1e-16))) < 1e-12
        first = np.linalg.norm(tips_at(runs[COMPARE_METHODS[0]].ring, t[k]) - tips_at(runs["lagrange"].ring, t[k]))
        assert abs(between[1][k] - np.log10(max(first, 1e-16))) < 1e-12
    assert np.all(data[4] == np.log10(VISIBLE_GAP))  # the level drawn
    # the time each passes 0.1, from every stored sample
    for method in COMPARE_METHODS:
        window = runs[method].ring.window(0, len(runs[method].ring) - 1, names=["t", "joints"])
        ref = reference.window(0, len(reference) - 1, names=["joints"])["joints"]
        gap = np.linalg.norm(window["joints"][:, -1] - ref[: len(window["t"]), -1], axis=1)
        passing = window["t"][np.flatnonzero(gap > VISIBLE_GAP)[0]]
        shown = plots.passing_times[method]
        assert shown is not None and passing <= shown <= passing + 0.1  # to the plotted sample
        assert 10.0 < passing < 30.0
        assert f"{shown:.2f} s" in plots.passing.content


def test_the_reference_run_is_converged(connect):
    _, session = connect()
    session.set_mechanism("triple-c")
    session.controls.compare.value = True
    assert session.goto_time(5.0, timeout=300)
    reference = {run.spec.label: run for run in session.player.runs}[REFERENCE_LABEL]
    p = session.params
    settings = validated(physics.Settings, method="lagrange", integrator="DOP853", rtol=1e-13, atol=1e-13,
                         t_end=5.0, samples=2)
    tight = physics.simulate(p.chain, p.theta0, p.omega0, settings)
    assert np.linalg.norm(tips_at(reference.ring, 5.0) - tight.joints[-1, -1]) < 1e-7


def test_the_plots_are_fed_while_playing_and_hidden_outside_compare_mode(connect):
    _, session = connect()
    assert not session.view.divergence.honest.handle.visible
    session.controls.compare.value = True
    session.play()
    assert wait_until(lambda: session.view.divergence.honest.points_shown > 10)
    assert "converged run" in session.view.divergence.passing.content
    session.controls.compare.value = False
    assert not session.view.divergence.honest.handle.visible
