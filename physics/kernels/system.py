"""A mechanism's equations ``A x = b`` solved through its generated ``assemble``: the one right-hand side of
every integrator, and the batched entry points Python calls (accelerations, reactions, matrices).

A *system* is the tuple ``(assemble, layout, A, b, x, col_scale)``: the address of the generated function (see
:mod:`physics.kernels.abi`), the mechanism's layout array and the scratch arrays the solve reuses, allocated
once per integration instead of once per call.
"""

import math

import numpy as np
from numba import njit

from .abi import (
    LAYOUT_LINKS,
    LAYOUT_PINNED,
    LAYOUT_SOLVE,
    LAYOUT_SYMMETRIC,
    LAYOUT_THETA_DDOT,
    LAYOUT_TIP_ROW_X,
    LAYOUT_TIP_ROW_Y,
    LAYOUT_UNKNOWNS,
    call_native,
    call_native_solve,
    data_pointer,
)
from .linear import ldlt_solve, lu_solve, lu_solve_equilibrated

# Above this pivot ratio the fast solve is redone with equilibration (well below the singular threshold).
RESCALE_ABOVE = 1e4


@njit(cache=True, error_model="numpy")
def make_system(assemble, layout):
    """The system tuple with fresh scratch arrays for a mechanism of ``layout``."""
    k = layout[LAYOUT_UNKNOWNS]
    return (assemble, layout, np.zeros((k, k)), np.zeros(k), np.zeros(k), np.ones(k))


@njit(cache=True, error_model="numpy")
def is_pinned(system):
    return system[1][LAYOUT_PINNED] != 0


@njit(cache=True, error_model="numpy")
def assemble_into(system, theta, omega, params, alpha, beta):
    """``A`` and ``b`` of the system at one state, with Baumgarte terms on a pinned chain's tip rows.

    ``theta``, ``omega``, ``params`` must be C-contiguous (the generated code reads them through pointers)."""
    assemble, layout, A, b, x, col_scale = system
    A[:, :] = 0.0
    call_native(
        assemble, data_pointer(theta), data_pointer(omega), data_pointer(params), data_pointer(A), data_pointer(b)
    )
    if layout[LAYOUT_PINNED] != 0 and (alpha != 0.0 or beta != 0.0):
        n = layout[LAYOUT_LINKS]
        tip_x = 0.0
        tip_y = 0.0
        vel_x = 0.0
        vel_y = 0.0
        for i in range(n):
            s = math.sin(theta[i])
            c = math.cos(theta[i])
            tip_x += params[i] * s
            tip_y -= params[i] * c
            vel_x += params[i] * c * omega[i]
            vel_y += params[i] * s * omega[i]
        b[layout[LAYOUT_TIP_ROW_X]] -= 2.0 * alpha * vel_x + beta * beta * (tip_x - params[4 * n + 1])
        b[layout[LAYOUT_TIP_ROW_Y]] -= 2.0 * alpha * vel_y + beta * beta * (tip_y - params[4 * n + 2])


@njit(cache=True, error_model="numpy")
def loop_ratio(theta, params):
    """sigma_max / sigma_min of the 2 x n loop Jacobian d(tip)/d(theta); inf when it loses rank."""
    jxx = 0.0
    jyy = 0.0
    jxy = 0.0
    for i in range(theta.shape[0]):
        cx = params[i] * math.cos(theta[i])
        sy = params[i] * math.sin(theta[i])
        jxx += cx * cx
        jyy += sy * sy
        jxy += cx * sy
    half_trace = 0.5 * (jxx + jyy)
    gap = math.sqrt(max(0.0, half_trace * half_trace - (jxx * jyy - jxy * jxy)))
    smallest = half_trace - gap
    if not smallest > 0.0:
        return np.inf
    return math.sqrt((half_trace + gap) / smallest)


@njit(cache=True, error_model="numpy")
def solve_system(system, theta, omega, params, alpha, beta):
    """All unknowns into the system's ``x`` at one state; returns the condition estimate (inf when singular).

    The fast path is the mechanism's generated structured elimination for a sparse matrix (the DAE), L D L^T
    for a symmetric positive definite one (Lagrange's mass matrix), a pivoted LU otherwise; only when its pivot ratio looks singular is the system rebuilt and solved again equilibrated,
    so that a mere difference of scale (a very light tip, a stiff mass ratio) is not mistaken for a singular
    position. A closed chain's geometric singularity (all links lined up) is judged on the loop Jacobian.
    """
    assemble, layout, A, b, x, col_scale = system
    assemble_into(system, theta, omega, params, alpha, beta)
    if layout[LAYOUT_SOLVE] != 0:
        ratio = call_native_solve(layout[LAYOUT_SOLVE], data_pointer(A), data_pointer(b), data_pointer(x))
    elif layout[LAYOUT_SYMMETRIC] != 0:
        ratio = ldlt_solve(A, b, x)
    else:
        ratio = lu_solve(A, b, x)
    if not ratio <= RESCALE_ABOVE:
        assemble_into(system, theta, omega, params, alpha, beta)
        ratio = lu_solve_equilibrated(A, b, x, col_scale)
    if layout[LAYOUT_PINNED] != 0:
        ratio = max(ratio, loop_ratio(theta, params))
    return ratio


@njit(cache=True, error_model="numpy")
def solve_accel(system, theta, omega, params, alpha, beta, theta_ddot):
    """Angular accelerations (n,) at one state; returns the condition estimate."""
    ratio = solve_system(system, theta, omega, params, alpha, beta)
    layout = system[1]
    x = system[4]
    for i in range(theta_ddot.shape[0]):
        theta_ddot[i] = x[layout[LAYOUT_THETA_DDOT + i]]
    return ratio


# ---------------------------------------------------------------------------------------------------------------
# Entry points for Python: a batch of states (K, n) in one call
# ---------------------------------------------------------------------------------------------------------------


@njit(cache=True, error_model="numpy")
def accel_states(assemble, layout, theta, omega, params, alpha, beta, theta_ddot_out, cond_out):
    """``theta_ddot_out`` (K, n) and ``cond_out`` (K,) at the states ``theta``, ``omega`` (K, n)."""
    system = make_system(assemble, layout)
    n = theta.shape[1]
    theta_row = np.empty(n)
    omega_row = np.empty(n)
    theta_ddot = np.empty(n)
    for row in range(theta.shape[0]):
        for i in range(n):
            theta_row[i] = theta[row, i]
            omega_row[i] = omega[row, i]
        cond_out[row] = solve_accel(system, theta_row, omega_row, params, alpha, beta, theta_ddot)
        for i in range(n):
            theta_ddot_out[row, i] = theta_ddot[i]


@njit(cache=True, error_model="numpy")
def solve_states(assemble, layout, theta, omega, params, alpha, beta, x_out, cond_out):
    """All unknowns ``x_out`` (K, k) and ``cond_out`` (K,) at the states ``theta``, ``omega`` (K, n)."""
    system = make_system(assemble, layout)
    n = theta.shape[1]
    x = system[4]
    theta_row = np.empty(n)
    omega_row = np.empty(n)
    for row in range(theta.shape[0]):
        for i in range(n):
            theta_row[i] = theta[row, i]
            omega_row[i] = omega[row, i]
        cond_out[row] = solve_system(system, theta_row, omega_row, params, alpha, beta)
        for j in range(x.shape[0]):
            x_out[row, j] = x[j]


@njit(cache=True, error_model="numpy")
def assemble_states(assemble, layout, theta, omega, params, A_out, b_out):
    """The plain matrices ``A_out`` (K, k, k) and ``b_out`` (K, k) at the states (no Baumgarte terms)."""
    system = make_system(assemble, layout)
    A = system[2]
    b = system[3]
    n = theta.shape[1]
    theta_row = np.empty(n)
    omega_row = np.empty(n)
    for row in range(theta.shape[0]):
        for i in range(n):
            theta_row[i] = theta[row, i]
            omega_row[i] = omega[row, i]
        assemble_into(system, theta_row, omega_row, params, 0.0, 0.0)
        A_out[row, :, :] = A
        b_out[row, :] = b


@njit(cache=True, error_model="numpy")
def lagrangian_pieces(mass_and_force, theta, omega, params, M, force):
    """The generated Lagrangian's mass matrix ``M`` (n, n) and force (n,) at one state (C-contiguous arrays)."""
    M[:, :] = 0.0
    call_native(
        mass_and_force,
        data_pointer(theta),
        data_pointer(omega),
        data_pointer(params),
        data_pointer(M),
        data_pointer(force),
    )


@njit(cache=True, error_model="numpy")
def lagrangian_states(mass_and_force, theta, omega, params, M_out, force_out):
    """``M_out`` (K, n, n) and ``force_out`` (K, n) at the states (K, n)."""
    n = theta.shape[1]
    theta_row = np.empty(n)
    omega_row = np.empty(n)
    M = np.empty((n, n))
    force = np.empty(n)
    for row in range(theta.shape[0]):
        for i in range(n):
            theta_row[i] = theta[row, i]
            omega_row[i] = omega[row, i]
        lagrangian_pieces(mass_and_force, theta_row, omega_row, params, M, force)
        M_out[row, :, :] = M
        force_out[row, :] = force
