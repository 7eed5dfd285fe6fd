"""Numeric kinematics and energies of a planar chain, vectorised over time.

Angles are absolute from the downward vertical, counter-clockwise positive, so bar i points along
``(sin theta_i, -cos theta_i)``. Every function accepts ``theta`` of shape ``(n,)`` or ``(T, n)``
and returns arrays with the same leading shape. ``params`` is the layout of ``Chain.params()``.
"""

from __future__ import annotations

import numpy as np


def split_params(params: np.ndarray):
    """``(L, d, m, I, g, pin)`` views of the flat vector ``[L, d, m, I, g, pin_x, pin_y, damping]``."""
    params = np.asarray(params, dtype=float)
    n = (params.shape[-1] - 4) // 4
    L, d, m, I = (params[..., k * n : (k + 1) * n] for k in range(4))
    return L, d, m, I, params[..., 4 * n], params[..., 4 * n + 1 : 4 * n + 3]


def _along(theta):
    return np.sin(theta), -np.cos(theta)


def joint_positions(L, theta) -> np.ndarray:
    """Joints O, 1, ..., n (the tip): shape ``theta.shape[:-1] + (n + 1, 2)``."""
    theta = np.asarray(theta, dtype=float)
    sx, sy = _along(theta)
    out = np.zeros(theta.shape[:-1] + (theta.shape[-1] + 1, 2))
    out[..., 1:, 0] = np.cumsum(L * sx, axis=-1)
    out[..., 1:, 1] = np.cumsum(L * sy, axis=-1)
    return out


def point_on_bar(L, theta, bar: int, along: float, across: float = 0.0) -> np.ndarray:
    """Position of a point fixed on bar ``bar`` (1-based): ``along`` it from its proximal joint and ``across``
    it to the counter-clockwise side. Shape ``theta.shape[:-1] + (2,)``."""
    theta = np.asarray(theta, dtype=float)
    joints = joint_positions(L, theta)
    th = theta[..., bar - 1]
    sx, sy = _along(th)
    # counter-clockwise normal of the bar direction (sx, sy) is (-sy, sx)
    x = joints[..., bar - 1, 0] + along * sx - across * sy
    y = joints[..., bar - 1, 1] + along * sy + across * sx
    return np.stack([x, y], axis=-1)


def com_positions(params, theta) -> np.ndarray:
    """Centres of mass, shape ``theta.shape[:-1] + (n, 2)``."""
    L, d, *_ = split_params(params)
    theta = np.asarray(theta, dtype=float)
    joints = joint_positions(L, theta)
    sx, sy = _along(theta)
    return np.stack([joints[..., :-1, 0] + d * sx, joints[..., :-1, 1] + d * sy], axis=-1)


def com_velocities(params, theta, omega) -> np.ndarray:
    """Centre-of-mass velocities, shape ``theta.shape[:-1] + (n, 2)``."""
    L, d, *_ = split_params(params)
    theta = np.asarray(theta, dtype=float)
    omega = np.asarray(omega, dtype=float)
    # d/dt (sin th, -cos th) = omega (cos th, sin th)
    cx, cy = np.cos(theta) * omega, np.sin(theta) * omega
    jx = np.cumsum(L * cx, axis=-1) - L * cx  # velocity of the proximal joint of each bar
    jy = np.cumsum(L * cy, axis=-1) - L * cy
    return np.stack([jx + d * cx, jy + d * cy], axis=-1)


def tip_velocity(L, theta, omega) -> np.ndarray:
    theta = np.asarray(theta, dtype=float)
    omega = np.asarray(omega, dtype=float)
    return np.stack(
        [np.sum(L * np.cos(theta) * omega, axis=-1), np.sum(L * np.sin(theta) * omega, axis=-1)], axis=-1
    )


def energies(params, theta, omega):
    """``(kinetic, potential, total)``; potential energy zero at the height of O."""
    _, _, m, I, g, _ = split_params(params)
    v = com_velocities(params, theta, omega)
    kinetic = 0.5 * np.sum(m * (v[..., 0] ** 2 + v[..., 1] ** 2) + I * np.asarray(omega) ** 2, axis=-1)
    potential = np.sum(m * g * com_positions(params, theta)[..., 1], axis=-1)
    return kinetic, potential, kinetic + potential


def lever_arms(L, d) -> np.ndarray:
    """``lever[k, i]``: how far bar i's angle moves bar k's centre of mass (``L_i`` for i < k, ``d_k`` for i = k,
    0 beyond), so centre of mass k sits at ``sum_i lever[k, i] (sin theta_i, -cos theta_i)``."""
    L, d = np.asarray(L, dtype=float), np.asarray(d, dtype=float)
    n = L.size
    return np.tril(np.broadcast_to(L, (n, n)), -1) + np.diag(d)


def potential_energy(L, d, m, g, theta) -> np.ndarray:
    """``V = sum m_k g y_Gk`` (zero at the height of O) from the bar parameters alone; batched over leading axes
    of ``theta`` (the rest-position searches evaluate it without a parameter vector)."""
    weight = np.asarray(m, dtype=float) @ lever_arms(L, d)
    return -g * np.sum(weight * np.cos(np.asarray(theta, dtype=float)), axis=-1)


def mass_matrix(params, theta) -> np.ndarray:
    """Numeric mass matrix ``sum_i m_i J_i^T J_i + diag(I)`` of the open chain at one configuration.

    Used to validate inputs and to check the derivations, never on the hot path of a simulation.
    """
    L, d, m, I, _, _ = split_params(params)
    theta = np.asarray(theta, dtype=float)
    n = theta.shape[-1]
    c, s = np.cos(theta), np.sin(theta)
    M = np.diag(I.astype(float))
    levers = lever_arms(L, d)
    for i in range(n):
        lever = levers[i]
        jac = np.stack([lever * c, lever * s])  # 2 x n: d(r_Gi)/d(theta)
        M = M + m[i] * jac.T @ jac
    return M


def loop_jacobian(L, theta) -> np.ndarray:
    """d(tip)/d(theta), shape ``theta.shape[:-1] + (2, n)``."""
    theta = np.asarray(theta, dtype=float)
    return np.stack([L * np.cos(theta), L * np.sin(theta)], axis=-2)


def com_accelerations(L, d, theta, omega, theta_ddot) -> np.ndarray:
    """Centre-of-mass accelerations, shape ``theta.shape[:-1] + (n, 2)``.

    Each bar direction ``(sin th, -cos th)`` has second derivative ``theta_ddot (cos th, sin th) +
    omega^2 (-sin th, cos th)``; a centre of mass adds its own bar's share at ``d`` to every earlier bar's at
    ``L``."""
    theta = np.asarray(theta, dtype=float)
    omega = np.asarray(omega, dtype=float)
    theta_ddot = np.asarray(theta_ddot, dtype=float)
    ax = theta_ddot * np.cos(theta) - omega**2 * np.sin(theta)
    ay = theta_ddot * np.sin(theta) + omega**2 * np.cos(theta)
    jx = np.cumsum(L * ax, axis=-1) - L * ax  # acceleration of the proximal joint of each bar
    jy = np.cumsum(L * ay, axis=-1) - L * ay
    return np.stack([jx + d * ax, jy + d * ay], axis=-1)
