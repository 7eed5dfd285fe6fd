"""Joint reactions of any formulation, from the motion alone.

The DAE solves for every joint reaction; the minimal-coordinate formulations (Newton-Euler, Lagrange, the
reduced model) eliminate them. Given the accelerations any of them computes, Newton's second law for each bar
gives them back in closed form, one bar at a time from the tip inwards:

    m_k a_Gk = R_{k-1} - R_k + m_k g_vec  (+ R_tip on the last bar of a closed chain)

where ``R_{k-1}`` is the force ON bar k BY bar k-1 (the ground for k = 1) and ``-R_k`` the force on bar k by
bar k+1 (``R_n = 0``: no bar beyond the tip). The moment balances are not needed: the accelerations already
satisfy them, which is what makes the reactions of a minimal formulation agree with the DAE's (tested to
1e-9 in ``tests/physics/test_reactions.py``). Sign convention as in ``docs/architecture.md``.
"""

from __future__ import annotations

import numpy as np

from .kinematics import com_accelerations


def reactions_from_motion(L, d, m, g: float, theta, omega, theta_ddot, tip_reaction=None) -> np.ndarray:
    """Joint reactions, shape ``theta.shape[:-1] + (n, 2)``: entry k is the force ON bar k+1 BY the ground
    (k = 0) or by bar k. ``tip_reaction`` (``(..., 2)``, closed chains) is the force ON the last bar BY the
    ground at the pin; ``None`` for an open chain."""
    m = np.asarray(m, dtype=float)
    a_com = com_accelerations(L, d, theta, omega, theta_ddot)
    # net force each bar needs, minus gravity's share: m_k (a_Gk - g_vec), with g_vec = (0, -g)
    needed = m[:, None] * a_com
    needed[..., 1] += m * g
    if tip_reaction is not None:
        needed[..., -1, :] -= np.asarray(tip_reaction, dtype=float)
    # R_{k-1} = needed_k + R_k with R_n = 0: a running sum from the tip inwards
    return np.flip(np.cumsum(np.flip(needed, axis=-2), axis=-2), axis=-2)
