"""Projection onto the constraints the integrator holds, ``phi(theta, t) = 0`` (a pinned chain's tip on its pin,
a mechanism's closed loops and speed motors): positions, then velocities, by the least (weighted) change.

The constraints come from the mechanism's generated ``constraints`` function (:mod:`physics.kernels.abi`):
``J`` and ``[phi, phi_dot]``. Weights: unit, or the mechanism's own (``LAYOUT_WEIGHTS``: for maximal
coordinates, rotations weighed by the sketch's size for positions and the inverse mass matrix for velocities,
so the velocity correction is the one nearest in kinetic energy).
"""

import math

import numpy as np
from numba import njit

from . import disk_cache  # noqa: F401  (numba's cache locator, before any kernel here is defined)
from .abi import LAYOUT_CONSTRAINTS, LAYOUT_WEIGHTS
from .arrays import state_row
from .common import all_finite
from .constants import PROJECTION_MAX_ITERATIONS, PROJECTION_TOLERANCE, SINGULAR_CONDITION_NUMBER
from .linear import column_weight, gram_into, ldlt_solve
from .system import constraints_into, load_state, make_system, set_time


@njit(cache=True, error_model="numpy", nogil=True)
def _correct(layout, J, G, g, lam, params, offset, gap, coordinates):
    """``coordinates -= W J^T (J W J^T)^-1 gap`` with the weights at ``offset`` of params (unit when < 0);
    left unchanged (returns False) where ``J W J^T`` is singular to working precision.

    ``J W J^T`` by :func:`~physics.kernels.linear.gram_into`; ``lam`` holds its scratch rows meanwhile (it is
    the solve's output afterwards)."""
    r = layout[LAYOUT_CONSTRAINTS]
    n = J.shape[1]
    gram_into(G, J, r, params, offset, lam)
    if r == 2:
        a = G[0, 0]
        b = G[0, 1]
        c2 = G[1, 1]
        det = a * c2 - b * b
        if not det > (a + c2) * (a + c2) / SINGULAR_CONDITION_NUMBER:
            return False
        lam[0] = (c2 * gap[0] - b * gap[1]) / det
        lam[1] = (a * gap[1] - b * gap[0]) / det
    else:
        for i in range(r):
            g[i] = gap[i]
        if not ldlt_solve(G, g, lam) <= SINGULAR_CONDITION_NUMBER:
            return False
    for c in range(n):
        total = 0.0
        for i in range(r):
            total += J[i, c] * lam[i]
        coordinates[c] -= column_weight(params, offset, c) * total
    return True


@njit(cache=True, error_model="numpy", nogil=True)
def position_onto(layout, J, v, G, g, lam, theta, omega, params):
    """:func:`project_position` with the system's arrays one by one (handing the system tuple down costs more
    than the work here, see :func:`physics.kernels.system.unknowns_into`). On return ``J`` and ``v`` hold the
    constraints at the final ``theta`` (every exit follows an evaluation that left ``theta`` as it is)."""
    r = layout[LAYOUT_CONSTRAINTS]
    offset = layout[LAYOUT_WEIGHTS]
    residual = 0.0
    for iteration in range(PROJECTION_MAX_ITERATIONS + 1):
        constraints_into(layout, J, v, theta, omega, params)
        total = 0.0
        for i in range(r):
            total += v[i] * v[i]
        residual = math.sqrt(total)
        if residual < PROJECTION_TOLERANCE or iteration == PROJECTION_MAX_ITERATIONS:
            break
        if not _correct(layout, J, G, g, lam, params, offset, v[:r], theta):
            break
    return residual


@njit(cache=True, error_model="numpy", nogil=True)
def velocity_onto(layout, J, v, G, g, lam, theta, omega, params, evaluated):
    """:func:`project_velocity` with the system's arrays one by one; ``evaluated``: ``J`` and ``v`` already
    hold the constraints at ``theta`` and ``omega`` (right after :func:`position_onto`), not evaluated again."""
    r = layout[LAYOUT_CONSTRAINTS]
    offset = layout[LAYOUT_WEIGHTS]
    if not evaluated:
        constraints_into(layout, J, v, theta, omega, params)
    total = 0.0
    for i in range(r):
        total += v[r + i] * v[r + i]
    velocity_offset = offset if offset < 0 else offset + theta.shape[0]
    _correct(layout, J, G, g, lam, params, velocity_offset, v[r : 2 * r], omega)
    return math.sqrt(total)


@njit(cache=True, error_model="numpy", nogil=True)
def project_position(system, theta, omega, params):
    """Move ``theta`` (n,) in place onto ``phi(theta, t) = 0`` by the least change (Gauss-Newton).

    Each iteration applies ``dtheta = -W J^T (J W J^T)^-1 phi``; it stops when ``|phi|`` is below
    PROJECTION_TOLERANCE or after PROJECTION_MAX_ITERATIONS. Near a singular configuration (``J W J^T`` with
    condition above SINGULAR_CONDITION_NUMBER) the correction would be noise, so ``theta`` is left as it is.
    Returns the final ``|phi|``.
    """
    return position_onto(system[1], system[6], system[7], system[8], system[9], system[10], theta, omega, params)


@njit(cache=True, error_model="numpy", nogil=True)
def project_velocity(system, theta, omega, params):
    """Make ``omega`` (n,) satisfy ``phi_dot = J omega + d phi/d t = 0`` by the least (weighted) change:
    ``omega -= W J^T (J W J^T)^-1 phi_dot``.

    Returns ``|phi_dot|`` before the projection. Left unchanged near a singular configuration, as in
    project_position.
    """
    return velocity_onto(system[1], system[6], system[7], system[8], system[9], system[10], theta, omega, params,
                         False)


@njit(cache=True, error_model="numpy", nogil=True)
def project_state(system, t, y, params, theta, omega):
    """Project ``y = [theta, omega]`` at time ``t`` in place (positions, then velocities); False if the result
    is not finite. Nothing to do for a system without constraints."""
    layout = system[1]
    if layout[LAYOUT_CONSTRAINTS] == 0:
        return all_finite(y)
    load_state(layout, params, t, y, theta, omega)
    n = theta.shape[0]
    J, v, G, g, lam = system[6], system[7], system[8], system[9], system[10]
    position_onto(layout, J, v, G, g, lam, theta, omega, params)
    velocity_onto(layout, J, v, G, g, lam, theta, omega, params, True)
    for i in range(n):
        y[i] = theta[i]
        y[n + i] = omega[i]
    return all_finite(y)


@njit(cache=True, error_model="numpy", nogil=True)
def project_states(assemble, layout, t, theta, omega, params):
    """Python's entry point: project rows of ``theta``, ``omega`` (K, n) at times ``t`` (K,) in place (a copy of
    ``params`` takes each time); returns the largest position residual left."""
    system = make_system(assemble, layout)
    local = params.copy()
    worst = 0.0
    n = theta.shape[1]
    theta_row = np.empty(n)
    omega_row = np.empty(n)
    for row in range(theta.shape[0]):
        set_time(system, local, t[row])
        state_row(theta, omega, row, theta_row, omega_row)
        if layout[LAYOUT_CONSTRAINTS] != 0:
            worst = max(worst, project_position(system, theta_row, omega_row, local))
            project_velocity(system, theta_row, omega_row, local)
        for i in range(n):
            theta[row, i] = theta_row[i]
            omega[row, i] = omega_row[i]
    return worst
