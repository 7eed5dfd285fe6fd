"""The seed-approach baseline (physics/studies/seed_baseline.py) is a faithful port: same physics as ours.

The speed benchmark compares it with the compiled path; these tests make sure the two compute the same
thing, so the ratio measures speed and not a different problem. Not timings.
"""

from __future__ import annotations

import numpy as np
import pytest

import physics
from physics.studies import seed_baseline

pytestmark = pytest.mark.slow  # the baseline's sympy simplify of the Lagrange system takes several seconds

BASELINE_FORMULATIONS = seed_baseline.FORMULATIONS
T_END = 5.0
SAMPLES = 51


def test_seed_preset_is_the_baseline_case():
    preset = physics.get_preset("triple-a")
    np.testing.assert_array_equal(preset.chain.params()[:13], seed_baseline.SEED_PARAMS)
    np.testing.assert_array_equal(preset.theta0, seed_baseline.SEED_CASES["A"])


@pytest.mark.parametrize("formulation", BASELINE_FORMULATIONS)
def test_seed_case_a_tip_trajectory_matches(formulation):
    """Case A over 5 s at the seed's settings (RK45, rtol = atol = 1e-6): the baseline (solve_ivp with the
    lambdified seed equations) and ours (compiled RK45 on the generated code) take the same steps and trace
    the same tip, to well within the tolerance the run was asked for."""
    preset = physics.get_preset("triple-a")
    baseline = seed_baseline.simulate(formulation, preset.theta0, preset.omega0, t_end=T_END, samples=SAMPLES)
    assert baseline.success, baseline.message
    settings = physics.Settings(
        method=formulation, integrator="RK45", rtol=seed_baseline.SEED_RTOL, atol=seed_baseline.SEED_ATOL,
        t_end=T_END, samples=SAMPLES,
    )
    ours = physics.simulate(preset.chain, preset.theta0, preset.omega0, settings)
    assert ours.success, ours.message
    np.testing.assert_allclose(ours.t, baseline.t, rtol=0, atol=1e-12)
    assert ours.n_rhs == baseline.nfev  # the same RK45 steps, accepted and rejected
    tip_baseline = seed_baseline.tip_xy(baseline.y[:3].T)
    tip_gap = np.max(np.abs(tip_baseline - ours.tip_xy))
    assert tip_gap < seed_baseline.SEED_ATOL, f"tip differs by {tip_gap:.2e}"
    # The tip actually moved (a frozen trajectory on both sides would agree trivially).
    assert np.ptp(ours.tip_xy[:, 0]) > 1.0


@pytest.mark.parametrize("formulation", BASELINE_FORMULATIONS)
def test_baseline_accelerations_match_ours_at_random_states(formulation, rng):
    """Independent of integration: at random states and parameters the port's A \\ b gives our accelerations;
    the DAE's reactions are ours with the seed's sign (the seed's R is the force ON the earlier bar)."""
    for _ in range(20):
        L = rng.uniform(0.3, 2.0, 3)
        d = L * rng.uniform(0.0, 1.0, 3)
        m = rng.uniform(0.2, 3.0, 3)
        I = rng.uniform(0.01, 1.0, 3)
        g = rng.uniform(0.5, 10.0)
        chain = physics.make_chain(L, d, m, I, g=g)
        theta = rng.uniform(-np.pi, np.pi, 3)
        omega = rng.uniform(-3.0, 3.0, 3)
        x = seed_baseline.solve_full(formulation, theta, omega, params=np.concatenate([L, d, m, I, [g]]))
        ours = physics.accelerations(chain, theta, omega, formulation)
        np.testing.assert_allclose(x[[0, 1, 2] if formulation == "lagrange" else [2, 5, 8]], ours["theta_ddot"],
                                   rtol=1e-10, atol=1e-10)
        if formulation == "dae":
            np.testing.assert_allclose(-x[9:].reshape(3, 2), ours["joint_reactions"], rtol=1e-10, atol=1e-10)
