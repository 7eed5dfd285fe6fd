"""The implicit midpoint rule on a step too stiff for Newton's iteration from the Euler prediction: the step is
cut into pieces (each at most the fixed step) instead of the run stopping "non-finite at t = 0 s".

Found by the 10,000-example control run (tests/app/test_every_control.py): random edits left a chain whose bar
of length L = 0.05 m (the slider's least) carries a unit mass at its end and almost no inertia of its own; with
the midpoint integrator at a 20 ms step (the slider's largest) the first step's simplified Newton iteration
overflowed, and the app reported a start that cannot move. The motion itself is ordinary: ode45 integrates it.
"""

from __future__ import annotations

import numpy as np
import pytest

import physics
from physics import Bar, Chain, Settings

CHAIN = Chain(bars=[
    Bar(L=1.0, d=5e-324, m=2.370734239739338, I=0.1),
    Bar(L=0.050000000000000655, d=0.050000000000000655, m=1.0, I=1.1e-16),
    Bar(L=1.3373964807666723, d=0.0, m=4.30571629012947, I=0.26417853057147167),
], g=9.81)
THETA0 = np.array([-3.141592653589793, -3.683457607463116, 3.141592653589793])
OMEGA0 = np.array([12.56637061, 0.0, 12.56637061])


@pytest.mark.parametrize("method", ["newton_euler", "lagrange"])
@pytest.mark.parametrize("damping", [0.0, 1000.0])
def test_a_stiff_first_step_of_the_midpoint_rule_is_solved_in_pieces(method, damping):
    horizon = 4 / 60  # four samples as the app asks for them; the step is 20 ms, so 4 whole steps
    midpoint = physics.simulate(CHAIN, THETA0, OMEGA0, Settings(method=method, integrator="midpoint", step=0.02,
                                                                damping=damping, t_end=horizon, samples=5))
    assert midpoint.status == 0, midpoint.message
    assert len(midpoint.t) == 5 and np.all(np.isfinite(midpoint.theta)) and np.all(np.isfinite(midpoint.omega))
    reference = physics.simulate(CHAIN, THETA0, OMEGA0, Settings(method=method, integrator="ode45", rtol=1e-10,
                                                                 atol=1e-10, damping=damping, t_end=horizon, samples=5))
    assert reference.status == 0, reference.message
    # the same motion: a second-order rule at 20 ms steps on bars turning at 12 rad/s is within 0.02 rad of ode45
    # (6.5 mrad measured; a wrong solution of a step is off by whole radians)
    assert np.max(np.abs(midpoint.theta - reference.theta)) < 2e-2, (midpoint.theta, reference.theta)


def test_a_step_newton_solves_whole_is_not_cut():
    """An ordinary start (the triple pendulum preset) takes exactly one step per 20 ms, as before."""
    preset = physics.get_preset("triple-a")
    traj = physics.simulate(preset.chain, preset.theta0, preset.omega0,
                            Settings(integrator="midpoint", step=0.02, t_end=0.2, samples=11))
    assert traj.status == 0 and traj.n_steps == 10
