"""Compare mode for a general mechanism (issue 24, "one app session"): Newton-Euler, Lagrange and the DAE from
one start, drawn side by side, with the divergence plots of the chain's compare mode and reaction arrows."""

from __future__ import annotations

import numpy as np

from app.divergence import REFERENCE_LABEL, REFERENCE_TOLERANCE
from app.mechanism_compare import COMPARE_METHODS, compare_specs, visible_gap
from app.mechanism_runs import MechanismSettings
from app.session import Session
from conftest import lab_of, wait_until
from physics.mechanism import MECHANISM_PRESETS
from physics.mechanism.simulate import simulate_mechanism

RUNS = [*COMPARE_METHODS, REFERENCE_LABEL]


crank_lab = lab_of("slider-crank")


def _compared(session, seconds: float) -> bool:
    """Every run of compare mode stored up to ``seconds``."""
    return wait_until(lambda: [r.spec.label for r in session.player.runs] == RUNS
                      and all(r.ring.t_last >= seconds for r in session.player.runs), timeout=180)


def test_compare_specs_are_the_three_formulations_and_a_tight_projected_reference():
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    specs = compare_specs(mechanism, MechanismSettings(method="reduced", stabilization="projection"), None)
    assert [s.label for s in specs] == RUNS
    assert [s.settings.method for s in specs] == [*COMPARE_METHODS, "dae"]
    assert all(s.settings.rtol == 1e-10 for s in specs[:3])
    assert specs[-1].settings.rtol == REFERENCE_TOLERANCE and specs[-1].settings.stabilization == "projection"
    baumgarte = compare_specs(mechanism, MechanismSettings(stabilization="baumgarte"), None)
    assert [s.settings.stabilization for s in baumgarte] == ["baumgarte"] * 3 + ["projection"]
    assert visible_gap(0.37) == 0.04 and visible_gap(2.0) == 0.2


def test_compare_mode_runs_three_formulations_side_by_side_and_measures_their_divergence(crank_lab, connect):
    _, session = connect(crank_lab)
    assert isinstance(session, Session)
    session.guard(lambda: session.set_compare(True))
    assert session.notices.text is None, session.notices.text
    assert session.compare and session.method.disabled
    assert _compared(session, 1.0)
    runs = {r.spec.label: r for r in session.player.runs}
    # the runs are what physics computes for each formulation from the assembled start
    mechanism = session.mechanism
    for method in COMPARE_METHODS:
        ring = runs[method].ring
        i = ring.index_at(1.0)
        t = float(ring.get("t", i))
        direct = simulate_mechanism(mechanism, t, 2, method=method, stabilization="projection")
        assert np.allclose(ring.get("q", i), direct.q[-1], atol=1e-8), method
    # from one start, at 1e-10, the formulations agree far below the visible gap over a second
    i = runs["dae"].ring.index_at(1.0)
    tips = {label: runs[label].ring.get("trace_xy", runs[label].ring.index_at(1.0)) for label in RUNS}
    for method in COMPARE_METHODS:
        assert np.linalg.norm(tips[method] - tips[REFERENCE_LABEL]) < 1e-6, method
    assert not np.allclose(runs["dae"].ring.get("trace_xy", i), runs["dae"].ring.get("trace_xy", 0))  # it moved
    # three mechanisms drawn, in the methods' colours, the single one gone; the plots fed
    snapshot = session.snapshot()
    assert snapshot["compare"] and snapshot["runs"] == RUNS
    names = snapshot["scene"]["names"]
    for method in COMPARE_METHODS:
        assert any(name.startswith(f"/compare/{method}/bar_") for name in names), method
    assert not any(name.startswith("/linkage/") for name in names)
    view = session.compare_view
    assert wait_until(lambda: view.between is not None and view.between.points_shown > 5, timeout=60)
    assert wait_until(lambda: set(session.snapshot()["divergence"] or {}) == set(COMPARE_METHODS), timeout=60)
    assert "compare: Newton" in session.status.content
    # off again: one run, one mechanism, plots removed
    session.guard(lambda: session.set_compare(False))
    assert wait_until(lambda: [r.spec.label for r in session.player.runs] == ["main"], timeout=60)
    names = session.snapshot()["scene"]["names"]
    assert any(name.startswith("/linkage/bar_") for name in names)
    assert not any(name.startswith("/compare/") for name in names)
    assert view.between is None and view.divergence is None and not session.method.disabled


def test_an_edit_in_compare_mode_starts_every_formulation_again_with_the_new_value(crank_lab, connect):
    _, session = connect(crank_lab)
    session.guard(lambda: session.set_compare(True))
    assert _compared(session, 0.3)
    session.guard(lambda: session.set("mass:rod", 0.7))
    assert session.notices.text is None, session.notices.text
    assert wait_until(lambda: not session.player.restart_pending and len(session.player.runs) == 4
                      and all(r.spec.mechanism.body("rod").mass == 0.7 for r in session.player.runs), timeout=60)
    assert all(r.ring.t_first == 0.0 for r in session.player.runs)  # all from the same start, at t = 0


def test_reaction_arrows_in_compare_mode_are_the_first_formulations(crank_lab, connect):
    _, session = connect(crank_lab)
    session.guard(lambda: session.set_compare(True))
    session.guard(lambda: session.set_reactions(True))
    pins = sum(1 for joint in session.mechanism.joints if joint.kind == "revolute")
    # compare mode's runs replace the main one when its restart is shown: wait for that, not for the first
    # arrows (the main run's arrows may show before it)
    assert session.player.wait_idle(60)
    assert wait_until(lambda: session.arrows.handle is not None and session.arrows.count == pins, timeout=60)
    assert session.player.runs[0].spec.label == COMPARE_METHODS[0]
