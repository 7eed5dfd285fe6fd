"""Compare mode's divergence plots (issue 15, honest Figures 12-13; issue 14 item 10, the whole run).

The curves are recomputed here from the runs' stored tips at full resolution, and the reference run is checked
against a single tight run of physics.simulate. The one session measures the divergence at the traced point
(``trace_xy``), which for these presets is the tip (asserted).
"""

from __future__ import annotations

import numpy as np

import physics
from app.divergence import REFERENCE_LABEL, VISIBLE_GAP
from app.mechanism_compare import COMPARE_METHODS
from conftest import wait_until
from physics.model import validated


def tips_at(ring, t):
    return ring.get("trace_xy", ring.index_at(t))


def assert_traces_the_tip(session) -> None:
    p = session.params
    assert (p.trace.bar, p.trace.along, p.trace.across) == (p.n, p.L[-1], 0.0), p.trace


def test_each_method_against_a_converged_run_over_the_whole_run(connect):
    _, session = connect()
    session.set_mechanism("triple-c")
    session.set("integrator", "RK45")
    session.set("rtol", 1e-6)  # the seed report's settings: case C leaves the true motion before 20 s
    assert_traces_the_tip(session)
    session.compare_box.value = True  # as the browser sends it
    plots = session.compare_view.divergence
    assert plots is not None and plots.honest.handle.visible
    assert plots.gap == VISIBLE_GAP  # the chain's visible gap (0.1 m for bars of about 1 m)
    assert session.goto_time(40.0, timeout=300)
    runs = {run.spec.label: run for run in session.player.runs}
    assert set(runs) == {*COMPARE_METHODS, REFERENCE_LABEL}
    plots = session.compare_view.divergence
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
        window = runs[method].ring.window(0, len(runs[method].ring) - 1, names=["t", "trace_xy"])
        ref = reference.window(0, len(reference) - 1, names=["trace_xy"])["trace_xy"]
        gap = np.linalg.norm(window["trace_xy"] - ref[: len(window["t"])], axis=1)
        passing = window["t"][np.flatnonzero(gap > VISIBLE_GAP)[0]]
        shown = plots.passing_times[method]
        assert shown is not None and passing <= shown <= passing + 0.1  # to the plotted sample
        assert 10.0 < passing < 30.0
        assert f"{shown:.2f} s" in plots.passing.content


def test_the_reference_run_is_converged(connect):
    _, session = connect()
    session.set_mechanism("triple-c")
    assert_traces_the_tip(session)
    session.compare_box.value = True
    assert session.goto_time(5.0, timeout=300)
    reference = {run.spec.label: run for run in session.player.runs}[REFERENCE_LABEL]
    p = session.params
    settings = validated(physics.Settings, method="lagrange", integrator="DOP853", rtol=1e-13, atol=1e-13,
                         t_end=5.0, samples=2)
    tight = physics.simulate(p.chain, p.theta0, p.omega0, settings)
    assert np.linalg.norm(tips_at(reference.ring, 5.0) - tight.joints[-1, -1]) < 1e-7


def test_the_plots_are_fed_while_playing_and_hidden_outside_compare_mode(connect):
    _, session = connect()
    assert session.compare_view.divergence is None  # outside compare mode the plots are not in the panel
    session.compare_box.value = True
    session.play()
    plots = session.compare_view.divergence
    assert plots is not None and plots.honest.handle.visible
    assert wait_until(lambda: plots.honest.points_shown > 10)
    assert "converged run" in plots.passing.content
    session.compare_box.value = False
    assert session.compare_view.divergence is None
    assert plots.honest.handle._impl.removed or not plots.honest.handle.visible  # noqa: SLF001
