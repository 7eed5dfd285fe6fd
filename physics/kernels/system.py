"""A mechanism's equations ``A x = b`` solved through its generated ``assemble``: the one right-hand side of
every integrator, and the batched entry points Python calls (accelerations, reactions, matrices).

A *system* is the tuple ``(assemble, layout, A, b, x, col_scale, J, v, G, g, lam)``: the address of the
generated function (see :mod:`physics.kernels.abi`), the mechanism's layout array and the scratch arrays the
solve and the constraints reuse, allocated once per integration instead of once per call.
"""

import math

import numpy as np
from numba import njit

from . import disk_cache  # noqa: F401  (numba's cache locator, before any kernel here is defined)
from .abi import (
    LAYOUT_ACCELERATION,
    LAYOUT_CONSTRAINT_FUNCTION,
    LAYOUT_CONSTRAINTS,
    LAYOUT_COORDINATES,
    LAYOUT_SOLVE,
    LAYOUT_SYMMETRIC,
    LAYOUT_TIME,
    LAYOUT_UNKNOWNS,
    call_native,
    call_native_ratio,
    data_pointer,
)
from .arrays import copy_matrix, copy_row, state_row
from .constants import RESCALE_ABOVE
from .linear import gram_into, ldlt_factor, ldlt_solve, lu_solve, lu_solve_equilibrated


@njit(cache=True, error_model="numpy", nogil=True)
def make_system(assemble, layout):
    """The system tuple with fresh scratch arrays for a mechanism of ``layout``: ``A, b, x, col_scale`` of the
    solve, and ``J (r, n), v (2 r), G (r, r), g (r), lam (r)`` of the constraints (one row at least, so that
    their pointers are valid when r = 0)."""
    k = layout[LAYOUT_UNKNOWNS]
    n = layout[LAYOUT_COORDINATES]
    r = max(layout[LAYOUT_CONSTRAINTS], 1)
    return (assemble, layout, np.zeros((k, k)), np.zeros(k), np.zeros(k), np.ones(k),
            np.zeros((r, n)), np.zeros(2 * r), np.zeros((r, r)), np.zeros(r), np.zeros(r))


@njit(cache=True, error_model="numpy", nogil=True)
def has_constraints(system):
    return system[1][LAYOUT_CONSTRAINTS] != 0


@njit(cache=True, error_model="numpy", nogil=True)
def set_time(system, params, t):
    """Write ``t`` into the parameter slot the generated code reads it from (speed motors), if there is one."""
    slot = system[1][LAYOUT_TIME]
    if slot >= 0:
        params[slot] = t


@njit(cache=True, error_model="numpy", nogil=True)
def load_state(layout, params, t, y, theta, omega):
    """The state ``y = [theta, omega]`` at time ``t`` as the generated code reads it: ``t`` into its parameter
    slot (if there is one), ``y`` split into the contiguous (n,) arrays ``theta`` and ``omega``."""
    slot = layout[LAYOUT_TIME]
    if slot >= 0:
        params[slot] = t
    n = theta.shape[0]
    for i in range(n):
        theta[i] = y[i]
        omega[i] = y[n + i]


@njit(cache=True, error_model="numpy", nogil=True)
def constraints_into(layout, J, v, theta, omega, params):
    """The generated ``constraints`` into ``J`` (r, n) and ``v = [phi, phi_dot]`` (2 r)."""
    J[:, :] = 0.0
    call_native(layout[LAYOUT_CONSTRAINT_FUNCTION], data_pointer(theta), data_pointer(omega), data_pointer(params),
                data_pointer(J), data_pointer(v))


@njit(cache=True, error_model="numpy", nogil=True)
def constraint_values(system, theta, omega, params):
    """The generated ``constraints`` into the system's ``J`` (r, n) and ``v = [phi, phi_dot]`` (2 r)."""
    constraints_into(system[1], system[6], system[7], theta, omega, params)


@njit(cache=True, error_model="numpy", nogil=True)
def equations_into(assemble, layout, A, b, J, v, theta, omega, params, alpha, beta):
    """``A`` and ``b`` at one state, with Baumgarte terms on the constraints' rows:
    ``b[row_i] -= 2 alpha phi_dot_i + beta^2 phi_i`` (``J``, ``v`` are their scratch).

    ``theta``, ``omega``, ``params`` must be C-contiguous (the generated code reads them through pointers)."""
    A[:, :] = 0.0
    structural_into(assemble, layout, A, b, J, v, theta, omega, params, alpha, beta)


@njit(cache=True, error_model="numpy", nogil=True)
def structural_into(assemble, layout, A, b, J, v, theta, omega, params, alpha, beta):
    """:func:`equations_into` without zeroing ``A`` first: the generated ``assemble`` writes only the structural
    non-zeros of ``A``, so the rest must already be zero (the structured solve's path keeps it so, see
    :func:`unknowns_into`)."""
    call_native(
        assemble, data_pointer(theta), data_pointer(omega), data_pointer(params), data_pointer(A), data_pointer(b)
    )
    r = layout[LAYOUT_CONSTRAINTS]
    if r != 0 and (alpha != 0.0 or beta != 0.0):
        constraints_into(layout, J, v, theta, omega, params)
        first_row = LAYOUT_ACCELERATION + layout[LAYOUT_COORDINATES]
        for i in range(r):
            b[layout[first_row + i]] -= 2.0 * alpha * v[r + i] + beta * beta * v[i]


@njit(cache=True, error_model="numpy", nogil=True)
def assemble_into(system, theta, omega, params, alpha, beta):
    """``A`` and ``b`` of the system at one state (:func:`equations_into`)."""
    equations_into(system[0], system[1], system[2], system[3], system[6], system[7], theta, omega, params, alpha,
                   beta)


@njit(cache=True, error_model="numpy", nogil=True)
def constraint_ratio(system, theta, omega, params):
    """sigma_max / sigma_min of the constraints' Jacobian (its rank lost: inf): a closed loop's geometric
    singularity, judged on the loop itself rather than on the (scaled) system. Exact for two rows (a pinned
    chain's tip); for more, the square root of the pivot ratio of ``J J^T``."""
    constraint_values(system, theta, omega, params)
    J = system[6]
    r = system[1][LAYOUT_CONSTRAINTS]
    n = J.shape[1]
    if r == 2:
        jxx = 0.0
        jyy = 0.0
        jxy = 0.0
        for i in range(n):
            jxx += J[0, i] * J[0, i]
            jyy += J[1, i] * J[1, i]
            jxy += J[0, i] * J[1, i]
        half_trace = 0.5 * (jxx + jyy)
        gap = math.sqrt(max(0.0, half_trace * half_trace - (jxx * jyy - jxy * jxy)))
        smallest = half_trace - gap
        if not smallest > 0.0:
            return np.inf
        return math.sqrt((half_trace + gap) / smallest)
    G = system[8]
    lam = system[10]
    gram_into(G, J, r, params, -1, lam)  # G = J J^T (unit weights); lam is its scratch
    ratio = ldlt_factor(G)  # its pivots alone: the ratio needs no solve
    if not ratio < np.inf:
        return np.inf
    return math.sqrt(ratio)


@njit(cache=True, error_model="numpy", nogil=True)
def unknowns_into(assemble, layout, A, b, x, col_scale, J, v, theta, omega, params, alpha, beta):
    """All unknowns into ``x`` at one state; returns the solve's own condition estimate (inf when singular),
    without the constraints' geometric test (:func:`constraint_ratio`).

    The fast path is the mechanism's generated structured elimination for a sparse matrix (the DAE), L D L^T
    for a symmetric positive definite one (Lagrange's mass matrix), a pivoted LU otherwise; only when its pivot
    ratio looks singular is the system rebuilt and solved again equilibrated, so that a mere difference of scale
    (a very light tip, a stiff mass ratio) is not mistaken for a singular position. This is what an integrator's
    stage needs: the geometric test costs about as much again and is judged once per step instead.

    The structured path does not zero ``A`` before assembling it (zeroing the Watt six-bar's 29 x 29 matrix
    cost about a third of the rest of its evaluation, in a micro-benchmark over the states of a run): ``A`` is
    zero from :func:`make_system` and only the structural non-zeros are ever written on this path, since the
    generated solve reads ``A`` without writing it; the dense fallback, which overwrites ``A``, zeroes it after.
    ``A`` must therefore be the system's own, used only through the kernels of this module.

    The system's arrays come one by one, not as the system tuple: each call that receives the tuple cost about
    0.25 us in a micro-benchmark (numba's reference counting of its ten arrays, as far as we can tell), more
    than the slider-crank's whole solve when the tuple was handed down through each right-hand side's calls.
    """
    solve = layout[LAYOUT_SOLVE]
    if solve != 0:
        structural_into(assemble, layout, A, b, J, v, theta, omega, params, alpha, beta)
        ratio = call_native_ratio(solve, data_pointer(A), data_pointer(b), data_pointer(x))
        if ratio <= RESCALE_ABOVE:
            return ratio
        ratio = _rescaled_solve(assemble, layout, A, b, x, col_scale, J, v, theta, omega, params, alpha, beta)
        A[:, :] = 0.0  # the structured path's invariant: nothing but assemble's non-zeros in A
        return ratio
    equations_into(assemble, layout, A, b, J, v, theta, omega, params, alpha, beta)
    if layout[LAYOUT_SYMMETRIC] != 0:
        ratio = ldlt_solve(A, b, x)
    else:
        ratio = lu_solve(A, b, x)
    if not ratio <= RESCALE_ABOVE:
        ratio = _rescaled_solve(assemble, layout, A, b, x, col_scale, J, v, theta, omega, params, alpha, beta)
    return ratio


@njit(cache=True, error_model="numpy", nogil=True)
def _rescaled_solve(assemble, layout, A, b, x, col_scale, J, v, theta, omega, params, alpha, beta):
    """The system rebuilt and solved equilibrated by a pivoted LU (:func:`unknowns_into`'s fallback)."""
    equations_into(assemble, layout, A, b, J, v, theta, omega, params, alpha, beta)
    return lu_solve_equilibrated(A, b, x, col_scale)


@njit(cache=True, error_model="numpy", nogil=True)
def solve_unknowns(system, theta, omega, params, alpha, beta):
    """:func:`unknowns_into` for the system tuple."""
    return unknowns_into(system[0], system[1], system[2], system[3], system[4], system[5], system[6], system[7],
                         theta, omega, params, alpha, beta)


@njit(cache=True, error_model="numpy", nogil=True)
def solve_system(system, theta, omega, params, alpha, beta):
    """All unknowns into the system's ``x`` at one state; returns the condition estimate (inf when singular):
    the solve's (:func:`solve_unknowns`), or a closed loop's geometric singularity (a four-bar's links lined
    up, a dead centre) judged on the constraints' Jacobian when that is worse."""
    ratio = solve_unknowns(system, theta, omega, params, alpha, beta)
    if system[1][LAYOUT_CONSTRAINTS] != 0:
        ratio = max(ratio, constraint_ratio(system, theta, omega, params))
    return ratio


@njit(cache=True, error_model="numpy", nogil=True)
def copy_accelerations(system, theta_ddot):
    """The accelerations (n,) out of the solved unknowns ``x``."""
    layout = system[1]
    x = system[4]
    for i in range(theta_ddot.shape[0]):
        theta_ddot[i] = x[layout[LAYOUT_ACCELERATION + i]]


@njit(cache=True, error_model="numpy", nogil=True)
def solve_accel(system, theta, omega, params, alpha, beta, theta_ddot):
    """Angular accelerations (n,) at one state; returns the condition estimate (with the geometric test)."""
    ratio = solve_system(system, theta, omega, params, alpha, beta)
    copy_accelerations(system, theta_ddot)
    return ratio


# ---------------------------------------------------------------------------------------------------------------
# Entry points for Python: a batch of states (K, n) in one call
# ---------------------------------------------------------------------------------------------------------------


@njit(cache=True, error_model="numpy", nogil=True)
def accel_states(assemble, layout, theta, omega, params, alpha, beta, theta_ddot_out, cond_out):
    """``theta_ddot_out`` (K, n) and ``cond_out`` (K,) at the states ``theta``, ``omega`` (K, n)."""
    system = make_system(assemble, layout)
    n = theta.shape[1]
    theta_row = np.empty(n)
    omega_row = np.empty(n)
    theta_ddot = np.empty(n)
    for row in range(theta.shape[0]):
        state_row(theta, omega, row, theta_row, omega_row)
        cond_out[row] = solve_accel(system, theta_row, omega_row, params, alpha, beta, theta_ddot)
        for i in range(n):
            theta_ddot_out[row, i] = theta_ddot[i]


@njit(cache=True, error_model="numpy", nogil=True)
def solve_states(assemble, layout, theta, omega, params, alpha, beta, x_out, cond_out):
    """All unknowns ``x_out`` (K, k) and ``cond_out`` (K,) at the states ``theta``, ``omega`` (K, n)."""
    system = make_system(assemble, layout)
    n = theta.shape[1]
    x = system[4]
    theta_row = np.empty(n)
    omega_row = np.empty(n)
    for row in range(theta.shape[0]):
        state_row(theta, omega, row, theta_row, omega_row)
        cond_out[row] = solve_system(system, theta_row, omega_row, params, alpha, beta)
        for j in range(x.shape[0]):
            x_out[row, j] = x[j]


@njit(cache=True, error_model="numpy", nogil=True)
def assemble_states(assemble, layout, theta, omega, params, A_out, b_out):
    """The plain matrices ``A_out`` (K, k, k) and ``b_out`` (K, k) at the states (no Baumgarte terms)."""
    system = make_system(assemble, layout)
    A = system[2]
    b = system[3]
    n = theta.shape[1]
    theta_row = np.empty(n)
    omega_row = np.empty(n)
    for row in range(theta.shape[0]):
        state_row(theta, omega, row, theta_row, omega_row)
        assemble_into(system, theta_row, omega_row, params, 0.0, 0.0)
        copy_matrix(A, A_out, row)
        copy_row(b, b_out, row)


@njit(cache=True, error_model="numpy", nogil=True)
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


@njit(cache=True, error_model="numpy", nogil=True)
def lagrangian_states(mass_and_force, theta, omega, params, M_out, force_out):
    """``M_out`` (K, n, n) and ``force_out`` (K, n) at the states (K, n)."""
    n = theta.shape[1]
    theta_row = np.empty(n)
    omega_row = np.empty(n)
    M = np.empty((n, n))
    force = np.empty(n)
    for row in range(theta.shape[0]):
        state_row(theta, omega, row, theta_row, omega_row)
        lagrangian_pieces(mass_and_force, theta_row, omega_row, params, M, force)
        copy_matrix(M, M_out, row)
        copy_row(force, force_out, row)


@njit(cache=True, error_model="numpy", nogil=True)
def native_states(function, layout, t, theta, omega, params, matrix_out, vector_out):
    """A generated function of the common signature (``constraints``, ``kinematics``) at the states ``theta``,
    ``omega`` (K, n) and times ``t`` (K,): its matrix into ``matrix_out`` (K, rows, columns; zeroed first, as the
    function writes only its structural non-zeros) and its vector into ``vector_out`` (K, m)."""
    local = params.copy()
    slot = layout[LAYOUT_TIME]
    n = theta.shape[1]
    theta_row = np.empty(n)
    omega_row = np.empty(n)
    matrix = np.empty((matrix_out.shape[1], matrix_out.shape[2]))
    vector = np.empty(vector_out.shape[1])
    for row in range(theta.shape[0]):
        if slot >= 0:
            local[slot] = t[row]
        state_row(theta, omega, row, theta_row, omega_row)
        matrix[:, :] = 0.0
        call_native(function, data_pointer(theta_row), data_pointer(omega_row), data_pointer(local),
                    data_pointer(matrix), data_pointer(vector))
        copy_matrix(matrix, matrix_out, row)
        copy_row(vector, vector_out, row)
