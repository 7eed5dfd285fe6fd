"""The "cheapest model" study (physics.studies.models): its four-bar table reads the system each run solved (the
chain written as a mechanism), and its physics columns are those of runs whose every sample follows the chain's
own formulas (tests/physics/chain_formulas.py)."""

from __future__ import annotations

import numpy as np

from physics import Settings, get_preset, simulate
from physics.studies.models import four_bar_models

from .chain_formulas import assert_run_follows_chain_formulas


def test_the_four_bar_table_reads_runs_that_follow_the_chains_formulas():
    table = {row["method"]: row for row in four_bar_models(t_end=2.0, repeats=1)}
    assert {"dae", "lagrange", "newton_euler"} <= table.keys()
    # the unknowns of the system solved: the mechanism's tree DAE has a row per body's rotation besides the
    # chain DAE's (17 + 3); the tree formulations solve the chain's five
    assert {m: r["unknowns"] for m, r in table.items() if m in ("newton_euler", "lagrange", "dae")} == {
        "newton_euler": 5, "lagrange": 5, "dae": 20}
    preset = get_preset("four-bar")
    for method, row in table.items():
        assert row["status"] == 0
        # the study's run, again: the table's columns are its, and every sample is the chain's formulas'
        settings = Settings(method=method, integrator="DOP853", rtol=1e-9, atol=1e-9, t_end=2.0, samples=1001)
        run = simulate(preset.chain, preset.theta0, preset.omega0, settings)
        assert row["n_rhs"] == run.n_rhs
        assert row["tip_gap"] == float(np.hypot(run.constraint_xy[:, 0], run.constraint_xy[:, 1]).max())
        assert row["energy_drift"] == run.energy_drift()
        assert_run_follows_chain_formulas(preset.chain, settings, run)
