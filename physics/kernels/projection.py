"""Projection of a pinned chain onto its loop constraint ``tip(theta) = pin`` (positions, then velocities)."""

import math

from numba import njit

from .common import all_finite
from .constants import PROJECTION_MAX_ITERATIONS, PROJECTION_TOLERANCE, SINGULAR_CONDITION_NUMBER


@njit(cache=True, error_model="numpy")
def _constraint_gram(theta, params):
    """Entries ``(a, b, c)`` of ``J J^T = [[a, b], [b, c]]`` with ``J[0, i] = L_i cos, J[1, i] = L_i sin``."""
    a = 0.0
    b = 0.0
    c = 0.0
    for i in range(theta.shape[0]):
        jx = params[i] * math.cos(theta[i])
        jy = params[i] * math.sin(theta[i])
        a += jx * jx
        b += jx * jy
        c += jy * jy
    return a, b, c


@njit(cache=True, error_model="numpy")
def project_position(theta, params):
    """Move ``theta`` (n,) in place onto ``tip(theta) = pin`` by the least change (Gauss-Newton).

    Each iteration applies ``dtheta = -J^T (J J^T)^-1 Phi``, ``Phi = tip - pin``; it stops when ``|Phi|`` is below
    PROJECTION_TOLERANCE or after PROJECTION_MAX_ITERATIONS. Near a singular configuration (all bars parallel,
    ``J J^T`` with condition above SINGULAR_CONDITION_NUMBER) the correction would be noise, so ``theta`` is left as it is.
    Returns the final ``|Phi|``.
    """
    n = theta.shape[0]
    pin_x = params[4 * n + 1]
    pin_y = params[4 * n + 2]
    residual = 0.0
    for iteration in range(PROJECTION_MAX_ITERATIONS + 1):
        phi_x = -pin_x
        phi_y = -pin_y
        for i in range(n):
            phi_x += params[i] * math.sin(theta[i])
            phi_y -= params[i] * math.cos(theta[i])
        residual = math.sqrt(phi_x * phi_x + phi_y * phi_y)
        if residual < PROJECTION_TOLERANCE or iteration == PROJECTION_MAX_ITERATIONS:
            break
        a, b, c = _constraint_gram(theta, params)
        det = a * c - b * b
        if not det > (a + c) * (a + c) / SINGULAR_CONDITION_NUMBER:
            break
        lambda_x = (c * phi_x - b * phi_y) / det
        lambda_y = (a * phi_y - b * phi_x) / det
        for i in range(n):
            theta[i] -= params[i] * (math.cos(theta[i]) * lambda_x + math.sin(theta[i]) * lambda_y)
    return residual


@njit(cache=True, error_model="numpy")
def project_velocity(theta, omega, params):
    """Remove from ``omega`` (n,) in place its component that moves the tip: ``omega -= J^T (J J^T)^-1 J omega``.

    Returns ``|J omega|`` before the projection (the tip's speed it removed). Left unchanged near a singular
    configuration, as in project_position.
    """
    n = theta.shape[0]
    v_x = 0.0
    v_y = 0.0
    for i in range(n):
        v_x += params[i] * math.cos(theta[i]) * omega[i]
        v_y += params[i] * math.sin(theta[i]) * omega[i]
    a, b, c = _constraint_gram(theta, params)
    det = a * c - b * b
    if det > (a + c) * (a + c) / SINGULAR_CONDITION_NUMBER:
        lambda_x = (c * v_x - b * v_y) / det
        lambda_y = (a * v_y - b * v_x) / det
        for i in range(n):
            omega[i] -= params[i] * (math.cos(theta[i]) * lambda_x + math.sin(theta[i]) * lambda_y)
    return math.sqrt(v_x * v_x + v_y * v_y)


@njit(cache=True, error_model="numpy")
def project_state(y, params, theta, omega):
    """Project ``y = [theta, omega]`` in place (positions, then velocities); False if the result is not finite."""
    n = theta.shape[0]
    for i in range(n):
        theta[i] = y[i]
        omega[i] = y[n + i]
    project_position(theta, params)
    project_velocity(theta, omega, params)
    for i in range(n):
        y[i] = theta[i]
        y[n + i] = omega[i]
    return all_finite(y)
