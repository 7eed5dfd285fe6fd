"""The "cheapest model" study (physics.studies.models) on both routes of a chain: its four-bar table reads the
system each run solved (the chain's own kernel, or the chain written as a mechanism when
physics.simulate.on_mechanism.ENABLED), and its physics columns agree between the two."""

from __future__ import annotations

import pytest

from physics.simulate import on_mechanism
from physics.studies.models import four_bar_models


def test_the_four_bar_table_on_both_routes(monkeypatch):
    tables = []
    for enabled in (False, True):
        monkeypatch.setattr(on_mechanism, "ENABLED", enabled)
        tables.append({row["method"]: row for row in four_bar_models(t_end=2.0, repeats=1)})
    on_kernels, on_engine = tables
    assert on_kernels.keys() == on_engine.keys() and {"dae", "lagrange", "newton_euler"} <= on_kernels.keys()
    # the unknowns of the system solved: the mechanism's tree DAE has a row per body's rotation besides the
    # chain DAE's (17 + 3); the tree formulations solve the chain's five
    assert {m: r["unknowns"] for m, r in on_kernels.items() if m in ("newton_euler", "lagrange", "dae")} == {
        "newton_euler": 5, "lagrange": 5, "dae": 17}
    assert {m: r["unknowns"] for m, r in on_engine.items() if m in ("newton_euler", "lagrange", "dae")} == {
        "newton_euler": 5, "lagrange": 5, "dae": 20}
    for method, row in on_engine.items():
        theirs = on_kernels[method]
        assert row["status"] == theirs["status"] == 0
        assert row["n_rhs"] == theirs["n_rhs"]
        # rounding apart (measured over these 2 s: the same tip gaps, 3e-15; energy drifts 1e-10 apart by 5e-16)
        assert row["tip_gap"] == pytest.approx(theirs["tip_gap"], rel=0, abs=1e-15)
        assert row["energy_drift"] == pytest.approx(theirs["energy_drift"], rel=0, abs=1e-14)
