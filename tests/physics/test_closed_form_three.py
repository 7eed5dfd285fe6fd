"""The three-bar closed-form Dormand-Prince (benchmarks/closed_form_three.py) computes what physics.simulate does.

Issue 25 times ``physics.simulate`` against it; these tests make sure the two solve the same problem the same
way, so the ratio measures speed and nothing else. Not timings.
"""

from __future__ import annotations

import numpy as np
import pytest

import physics
from benchmarks import closed_form, closed_form_three

RTOL = ATOL = 1e-6  # seed case C's tolerances
WINDOW_S = 10.0  # past it the motion is chaotic: rounding differences grow to the size of the motion


@pytest.fixture(scope="module")
def case_c():
    preset = physics.get_preset(closed_form.CASE_C_PRESET)
    return preset.chain, np.array(preset.theta0, dtype=float), np.array(preset.omega0, dtype=float)


def test_three_bar_baseline_agrees_with_simulate_on_seed_case_c(case_c):
    """Same RK45 steps (accepted and rejected) as physics.simulate's compiled RK45, and the same tip to within
    the run's tolerance over the first 10 s, for every formulation."""
    chain, theta0, omega0 = case_c
    t, y, n_steps, n_rhs = closed_form_three.run_with_counts(
        chain.params(), theta0, omega0, closed_form.CASE_C_T_END, closed_form.CASE_C_SAMPLES, RTOL, ATOL)
    tip = closed_form.tip_xy(chain.array("L"), y[:, :3])
    window = t <= WINDOW_S + 1e-12
    for method in ("lagrange", "newton_euler", "dae"):
        settings = physics.Settings(method=method, integrator="RK45", rtol=RTOL, atol=ATOL,
                                    t_end=closed_form.CASE_C_T_END, samples=closed_form.CASE_C_SAMPLES)
        ours = physics.simulate(chain, theta0, omega0, settings)
        assert ours.success, ours.message
        np.testing.assert_array_equal(ours.t, t)
        assert (ours.n_steps, ours.n_rhs) == (n_steps, n_rhs), method
        gap = np.max(np.abs(tip[window] - ours.tip_xy[window]))
        assert gap < ATOL, f"{method}: the tip differs by {gap:.2e} m over the first {WINDOW_S:g} s"
    assert np.ptp(tip[:, 0]) > 1.0  # the chain moved: a frozen run on both sides would agree trivially


@pytest.mark.parametrize("damping", [0.0, 0.3])
def test_three_bar_baseline_is_the_generic_one_written_for_three_bars(case_c, damping):
    """The same arithmetic as the generic n-bar closed form, in the same order: the same steps and the same
    states, with and without joint damping."""
    chain, theta0, omega0 = case_c
    params = chain.params(damping=damping)
    _, y_generic, steps_generic, rhs_generic = closed_form._run(params, theta0, omega0, 5.0, 51, RTOL, ATOL)
    _, y_three, steps_three, rhs_three = closed_form_three.run_with_counts(params, theta0, omega0, 5.0, 51, RTOL,
                                                                           ATOL)
    assert (steps_three, rhs_three) == (steps_generic, rhs_generic)
    np.testing.assert_allclose(y_three, y_generic, rtol=0.0, atol=1e-12)


def test_three_bar_baseline_refuses_another_number_of_bars():
    chain = physics.make_chain([1.0, 1.0], [0.5, 0.5], [1.0, 1.0], [0.1, 0.1])
    with pytest.raises(ValueError, match="three-bar"):
        closed_form_three.run_with_counts(chain.params(), [0.1, 0.2], [0.0, 0.0], 1.0, 11, RTOL, ATOL)


def test_the_case_c_timing_runs_each_runner_in_blocks_when_asked():
    """``python -m benchmarks.closed_form --block K``: every runner's calls K at a time, each call timed (so each
    runner has ``repeats * K`` times), and the states and tips still checked. Not a timing."""
    result = closed_form.time_case_c(repeats=2, methods=("lagrange",), block=3)
    assert result["block"] == 3
    assert result["closed_form_three"]["count"] == 6
    assert result["physics_simulate"]["lagrange"]["count"] == 6
    assert result["agree"] and result["three_agree"] and result["same_steps"]
