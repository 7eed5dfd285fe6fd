"""Joint reactions from the motion (physics/chain_reactions.py) agree with the DAE's own, for every formulation."""

from __future__ import annotations

import numpy as np
import pytest

from physics import Settings, load_compiled, simulate
from physics.chain_presets import get_preset
from physics.chain_reactions import reactions_from_motion
from physics.kinematics import split_params

from ..conftest import random_params

STATES = 100


def _moment_residuals(params, theta, omega, theta_ddot, reactions, tip_reaction):
    """I alpha about G minus the moments of the joint forces about G, per bar: zero if the reactions are right.
    The reactions come from force balances only, so this is an independent check."""
    L, d, m, I, g, _ = split_params(params)
    n = theta.size
    e = np.stack([np.sin(theta), -np.cos(theta)], axis=1)
    cross = lambda r, f: r[0] * f[1] - r[1] * f[0]  # noqa: E731
    out = np.zeros(n)
    for k in range(n):
        moment = cross(-d[k] * e[k], reactions[k])  # at the proximal joint
        distal = (L[k] - d[k]) * e[k]
        if k + 1 < n:
            moment += cross(distal, -reactions[k + 1])
        elif tip_reaction is not None:
            moment += cross(distal, tip_reaction)
        out[k] = I[k] * theta_ddot[k] - moment
    return out


@pytest.mark.parametrize("n", [1, 2, 3, 5])
def test_open_chain_reactions_match_the_dae_for_every_formulation(n):
    rng = np.random.default_rng(3000 + n)
    systems = {name: load_compiled(name, n, False) for name in ("newton_euler", "lagrange", "dae")}
    for _ in range(STATES):
        params = random_params(rng, n)
        theta = rng.uniform(-np.pi, np.pi, n)
        omega = rng.uniform(-3.0, 3.0, n)
        L, d, m, I, g, _ = split_params(params)
        x_dae, _ = systems["dae"].solve_full(theta, omega, params)
        reference = x_dae[systems["dae"].reaction_index]
        scale = np.max(np.abs(reference)) + g * np.sum(m)
        for name, system in systems.items():
            x, _ = system.solve_full(theta, omega, params)
            theta_ddot = x[system.theta_ddot_index]
            reactions = reactions_from_motion(L, d, m, g, theta, omega, theta_ddot)
            assert np.max(np.abs(reactions - reference)) <= 1e-9 * scale, (name, reactions, reference)
            moments = _moment_residuals(params, theta, omega, theta_ddot, reactions, None)
            assert np.max(np.abs(moments)) <= 1e-9 * scale * np.max(L), (name, moments)


@pytest.mark.parametrize("n", [3, 4])
def test_closed_chain_reactions_match_the_dae_for_every_formulation(n):
    rng = np.random.default_rng(4000 + n)
    systems = {name: load_compiled(name, n, True) for name in ("newton_euler", "lagrange", "dae")}
    checked = 0
    while checked < STATES // 2:
        theta = rng.uniform(-np.pi, np.pi, n)
        params = random_params(rng, n)
        L, d, m, I, g, _ = split_params(params)
        params[4 * n + 1 : 4 * n + 3] = (np.sum(L * np.sin(theta)), -np.sum(L * np.cos(theta)))
        jac = np.stack([L * np.cos(theta), L * np.sin(theta)])
        if np.linalg.svd(jac, compute_uv=False)[-1] < 0.05 * np.max(L):
            continue
        omega = rng.uniform(-2.0, 2.0, n)
        omega -= jac.T @ np.linalg.solve(jac @ jac.T, jac @ omega)
        x_dae, _ = systems["dae"].solve_full(theta, omega, params)
        reference = x_dae[systems["dae"].reaction_index]
        scale = np.max(np.abs(reference)) + g * np.sum(m)
        for name, system in systems.items():
            x, _ = system.solve_full(theta, omega, params)
            theta_ddot, tip = x[system.theta_ddot_index], x[system.tip_reaction_index]
            reactions = reactions_from_motion(L, d, m, g, theta, omega, theta_ddot, tip)
            assert np.max(np.abs(reactions - reference)) <= 1e-9 * scale, (name, reactions, reference)
            moments = _moment_residuals(params, theta, omega, theta_ddot, reactions, tip)
            assert np.max(np.abs(moments)) <= 1e-9 * scale * np.max(L), (name, moments)
        checked += 1


@pytest.mark.parametrize("preset", ["triple-a", "four-bar"])
def test_every_trajectory_carries_joint_reactions_equal_to_the_dae_run(preset):
    """Trajectory.joint_reactions is filled for every method; along the same run it matches the DAE's."""
    setup = get_preset(preset)
    chain = setup.chain
    runs = {}
    for method in ("newton_euler", "lagrange", "dae"):
        settings = Settings(method=method, integrator="DOP853", t_end=2.0, samples=41, rtol=1e-12, atol=1e-12)
        runs[method] = simulate(chain, setup.theta0, setup.omega0, settings)
    reference = runs["dae"].reactions
    assert reference.shape == (41, chain.n, 2)
    scale = np.max(np.abs(reference))
    for method, run in runs.items():
        assert run.joint_reactions.shape == (41, chain.n, 2)
        # different formulations, same tolerance: the runs themselves differ by ~1e-10
        assert np.max(np.abs(run.joint_reactions - reference)) <= 1e-7 * scale, method
    assert np.max(np.abs(runs["dae"].joint_reactions - reference)) <= 1e-9 * scale
