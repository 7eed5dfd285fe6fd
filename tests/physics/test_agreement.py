"""The three independently derived formulations agree at random states, and dae's reactions balance momentum."""

from __future__ import annotations

import numpy as np
import pytest

from physics import load_compiled
from physics.kinematics import split_params

from ..conftest import ALL_FORMULATIONS, random_params

STATES = 200


def _com_accelerations(params, theta, omega, theta_ddot):
    """a_Gi from rigid-body kinematics alone (independent of every formulation)."""
    L, d, *_ = split_params(params)
    n = theta.size
    e = np.stack([np.sin(theta), -np.cos(theta)], axis=1)  # along each bar
    t = np.stack([np.cos(theta), np.sin(theta)], axis=1)  # its counter-clockwise normal
    per_bar = lambda arm, k: arm * (theta_ddot[k] * t[k] - omega[k] ** 2 * e[k])  # noqa: E731
    out = np.zeros((n, 2))
    for i in range(n):
        out[i] = sum(per_bar(L[k], k) for k in range(i)) + per_bar(d[i], i)
    return out


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 6])
def test_open_chains_agree_at_random_states(n):
    rng = np.random.default_rng(1000 + n)
    systems = {name: load_compiled(name, n, False) for name in ALL_FORMULATIONS}
    worst = 0.0
    for _ in range(STATES):
        params = random_params(rng, n)
        theta = rng.uniform(-np.pi, np.pi, n)
        omega = rng.uniform(-3.0, 3.0, n)
        results = {name: s.solve_full(theta, omega, params) for name, s in systems.items()}
        accel = {name: x[systems[name].theta_ddot_index] for name, (x, _) in results.items()}
        reference = accel["lagrange"]
        scale = np.max(np.abs(reference)) + 1e-300
        for name in ("newton_euler", "dae"):
            rel = np.max(np.abs(accel[name] - reference)) / scale
            worst = max(worst, rel)
            assert rel < 1e-10, f"{name} vs lagrange, n={n}: relative difference {rel:.2e}"

        # dae reactions: m_i a_Gi = R_{i-1} - R_i + m_i g_vec for every bar
        x_dae = results["dae"][0]
        reactions = x_dae[systems["dae"].reaction_index]
        _, _, m, _, g, _ = split_params(params)
        a_com = _com_accelerations(params, theta, omega, accel["dae"])
        for i in range(n):
            from_next = -reactions[i + 1] if i + 1 < n else np.zeros(2)
            residual = m[i] * a_com[i] - (reactions[i] + from_next + np.array([0.0, -m[i] * g]))
            force_scale = np.max(np.abs(reactions)) + m[i] * g
            assert np.max(np.abs(residual)) < 1e-10 * force_scale, f"bar {i + 1}: LMB residual {residual}"
    assert worst < 1e-10


@pytest.mark.parametrize("n", [2, 3, 4])
def test_pinned_chains_agree_at_random_assembled_states(n):
    """Closed chains (tip pinned where the random configuration puts it): same accelerations and same R_H."""
    rng = np.random.default_rng(2000 + n)
    systems = {name: load_compiled(name, n, True) for name in ALL_FORMULATIONS}
    for _ in range(STATES):
        theta = rng.uniform(-np.pi, np.pi, n)
        base = random_params(rng, n)
        L = base[:n]
        tip = (np.sum(L * np.sin(theta)), -np.sum(L * np.cos(theta)))
        params = base.copy()
        params[4 * n + 1 : 4 * n + 3] = tip
        jac = np.stack([L * np.cos(theta), L * np.sin(theta)])
        if np.linalg.svd(jac, compute_uv=False)[-1] < 0.05 * np.max(L):
            continue  # too close to a singular position for a 1e-10 comparison
        omega = rng.uniform(-2.0, 2.0, n)
        omega -= jac.T @ np.linalg.solve(jac @ jac.T, jac @ omega)  # onto the velocity constraint
        out = {}
        for name, s in systems.items():
            x, cond = s.solve_full(theta, omega, params)
            out[name] = (x[s.theta_ddot_index], x[s.tip_reaction_index])
        acc_ref, rh_ref = out["lagrange"]
        # Natural scales: g / L for accelerations, the weight for forces (a 2-bar loop is rigid: theta_ddot ~ 0).
        g = params[4 * n]
        acc_scale = max(np.max(np.abs(acc_ref)), g / np.max(L))
        force_scale = max(np.max(np.abs(rh_ref)), g * np.sum(params[2 * n : 3 * n]))
        for name in ("newton_euler", "dae"):
            acc, rh = out[name]
            assert np.max(np.abs(acc - acc_ref)) <= 1e-10 * acc_scale, (name, acc, acc_ref)
            assert np.max(np.abs(rh - rh_ref)) <= 1e-10 * force_scale, (name, rh, rh_ref)
