"""Everything a trajectory reports that follows from its sampled states alone, in one compiled pass.

Joint positions, the traced point, kinetic and potential energy and the tip's velocity, for T samples of an
n-bar chain: the same formulas as docs/physics.md (positions along e_i = (sin, -cos), velocities by
differentiating them), computed sample by sample instead of by a few dozen whole-array numpy operations, so a
short run is not dominated by its post-processing.
"""

import math

from numba import njit

from . import disk_cache  # noqa: F401  (numba's cache locator, before any kernel here is defined)


@njit(cache=True, error_model="numpy", nogil=True)
def chain_observables(
    theta,
    omega,
    L,
    d,
    m,
    inertia,
    g,
    trace_bar,
    trace_along,
    trace_across,
    joints,
    trace_xy,
    kinetic,
    potential,
    tip_velocity,
):
    """Fill ``joints`` (T, n+1, 2), ``trace_xy`` (T, 2), ``kinetic``, ``potential`` (T,), ``tip_velocity`` (T, 2)
    from ``theta``, ``omega`` (T, n). ``trace_bar`` is 0-based; the traced point sits ``trace_along`` along the bar
    and ``trace_across`` to its left (counter-clockwise normal)."""
    samples, n = theta.shape
    for t in range(samples):
        x = 0.0
        y = 0.0
        vx = 0.0
        vy = 0.0
        energy_kinetic = 0.0
        energy_potential = 0.0
        joints[t, 0, 0] = 0.0
        joints[t, 0, 1] = 0.0
        for i in range(n):
            s = math.sin(theta[t, i])
            c = math.cos(theta[t, i])
            w = omega[t, i]
            com_y = y - d[i] * c
            com_vx = vx + d[i] * c * w
            com_vy = vy + d[i] * s * w
            energy_kinetic += 0.5 * (m[i] * (com_vx * com_vx + com_vy * com_vy) + inertia[i] * w * w)
            energy_potential += m[i] * g * com_y
            if i == trace_bar:
                trace_xy[t, 0] = x + trace_along * s + trace_across * c
                trace_xy[t, 1] = y - trace_along * c + trace_across * s
            x += L[i] * s
            y -= L[i] * c
            vx += L[i] * c * w
            vy += L[i] * s * w
            joints[t, i + 1, 0] = x
            joints[t, i + 1, 1] = y
        kinetic[t] = energy_kinetic
        potential[t] = energy_potential
        tip_velocity[t, 0] = vx
        tip_velocity[t, 1] = vy


@njit(cache=True, error_model="numpy", nogil=True)
def chain_joint_reactions(theta, omega, theta_ddot, L, d, m, g, tip_reaction, joint_reactions):
    """Fill ``joint_reactions`` (T, n, 2) from the motion: :func:`physics.reactions.reactions_from_motion`'s
    formulas in its order of operations (centre-of-mass accelerations, ``m_k (a_Gk - g_vec)`` less the pin's
    force on the last bar, running sums from the tip inwards), sample by sample instead of a dozen whole-array
    numpy operations. ``tip_reaction`` (T, 2) is the pin's force on the last bar, ``(0, 2)`` for an open chain."""
    samples, n = theta.shape
    pinned = tip_reaction.shape[0] != 0
    for t in range(samples):
        sum_x = 0.0  # running sums of L_i a_i over the bars so far (the cumulative sums of reactions.py)
        sum_y = 0.0
        for i in range(n):
            s = math.sin(theta[t, i])
            c = math.cos(theta[t, i])
            w2 = omega[t, i] * omega[t, i]
            ax = theta_ddot[t, i] * c - w2 * s
            ay = theta_ddot[t, i] * s + w2 * c
            lever_x = L[i] * ax
            lever_y = L[i] * ay
            sum_x += lever_x
            sum_y += lever_y
            joint_reactions[t, i, 0] = m[i] * ((sum_x - lever_x) + d[i] * ax)
            joint_reactions[t, i, 1] = m[i] * ((sum_y - lever_y) + d[i] * ay) + m[i] * g
        if pinned:
            joint_reactions[t, n - 1, 0] -= tip_reaction[t, 0]
            joint_reactions[t, n - 1, 1] -= tip_reaction[t, 1]
        for i in range(n - 2, -1, -1):
            joint_reactions[t, i, 0] = joint_reactions[t, i + 1, 0] + joint_reactions[t, i, 0]
            joint_reactions[t, i, 1] = joint_reactions[t, i + 1, 1] + joint_reactions[t, i, 1]
