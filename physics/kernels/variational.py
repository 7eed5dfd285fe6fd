"""Fixed-step variational integrator in ``(theta, p)``: midpoint discrete Lagrangian, RATTLE for the constraints
(a pinned chain's tip, a mechanism's closed loops)."""


import numpy as np
from numba import njit

from . import disk_cache  # noqa: F401  (numba's cache locator, before any kernel here is defined)
from .abi import LAYOUT_CONSTRAINTS
from .common import all_finite, check_arguments, fixed_steps, initial_samples, ode_rhs, start_rhs, step_status
from .constants import (
    EPSILON,
    FD_RELATIVE_STEP,
    NEWTON_MAX_ITERATIONS,
    NEWTON_TOLERANCE,
    STATUS_INTEGRATOR_FAILED,
    STATUS_NOT_FINITE,
    STATUS_OK,
)
from .linear import lu_factor, lu_factor_solve
from .midpoint import hermite_samples
from .projection import project_state
from .system import constraint_values, has_constraints, lagrangian_pieces, make_system, set_time


@njit(cache=True, error_model="numpy", nogil=True)
def _del_residual(
    system, mass_and_force, theta0, J0, momentum0, unknowns, step, params, theta_mid, velocity, M, force, residual
):
    """Residual of the discrete Euler-Lagrange equation for the step's increment ``q1 - q0 = unknowns[:n]``.

    With ``L_d(q0, q1) = h L((q0 + q1) / 2, (q1 - q0) / h)`` and damping as a midpoint force, the step from
    ``(q0, p0)`` solves ``p0 = -D1 L_d(q0, q1) - (h/2) Q = M v - (h/2) f`` (``f = dL/dq + Q`` at the midpoint).
    Constraints add the force ``J(q0)^T lambda`` (``J0``, r x n) and the rows ``phi(q1) = 0``: the position half
    of RATTLE. The momentum rows are multiplied by ``h`` (and the unknown multiplier is ``h lambda =
    unknowns[n:]``) so that every row and column of the Newton matrix is of order one (``M``, ``G``): unscaled,
    its condition grows like ``1/h`` and rounding keeps Newton from reaching its tolerance. The unknown is the
    increment, not ``q1``, so that ``v = (q1 - q0) / h`` carries the increment's relative precision instead of
    ``|q| * eps / h`` (which at h = 3e-5 s costs more than the method's own error).
    """
    n = theta0.shape[0]
    for i in range(n):
        theta_mid[i] = theta0[i] + 0.5 * unknowns[i]
        velocity[i] = unknowns[i] / step
    lagrangian_pieces(mass_and_force, theta_mid, velocity, params, M, force)
    for i in range(n):
        total = -step * momentum0[i] - 0.5 * step * step * force[i]
        for j in range(n):
            total += M[i, j] * unknowns[j]
        residual[i] = total
    r = system[1][LAYOUT_CONSTRAINTS]
    if r != 0:
        for i in range(n):
            for c in range(r):
                residual[i] -= J0[c, i] * unknowns[n + c]
            theta_mid[i] = theta0[i] + unknowns[i]  # q1, for phi(q1); theta_mid is not read again
        constraint_values(system, theta_mid, velocity, params)
        v = system[7]
        for c in range(r):
            residual[n + c] = v[c]


@njit(cache=True, error_model="numpy", nogil=True)
def _velocity_from_momentum(system, mass_and_force, theta, momentum, params, M, force, pivots, loop_work, omega):
    """``omega = M(theta)^-1 p``; with constraints then the velocity half of RATTLE, which removes the part of
    ``p`` along ``J^T`` so that ``phi_dot = J omega + d phi/d t = 0``. ``momentum`` is updated to match;
    ``loop_work`` (r, n) is scratch. Returns False when the mass matrix or ``J M^-1 J^T`` is singular."""
    n = theta.shape[0]
    for i in range(n):
        omega[i] = 0.0
    lagrangian_pieces(mass_and_force, theta, omega, params, M, force)
    if not lu_factor(M, pivots):
        return False
    for i in range(n):
        omega[i] = momentum[i]
    lu_factor_solve(M, pivots, omega)
    r = system[1][LAYOUT_CONSTRAINTS]
    if r != 0:
        # W = M^-1 J^T (r columns, as rows of loop_work), S = J W (r x r); mu = S^-1 phi_dot; omega -= W mu;
        # p -= J^T mu.
        constraint_values(system, theta, omega, params)
        J = system[6]
        v = system[7]
        S = system[8]
        gap = system[9]
        mu = system[10]
        for c in range(r):
            for i in range(n):
                loop_work[c, i] = J[c, i]
            lu_factor_solve(M, pivots, loop_work[c])
        for a in range(r):
            gap[a] = v[r + a]
            for b in range(r):
                total = 0.0
                for i in range(n):
                    total += J[a, i] * loop_work[b, i]
                S[a, b] = total
        if r == 2:  # Cramer's rule, refused only when exactly singular (a pinned chain's tip, as it always was)
            det = S[0, 0] * S[1, 1] - S[0, 1] * S[1, 0]
            if not abs(det) > 0.0:
                return False
            mu[0] = (S[1, 1] * gap[0] - S[0, 1] * gap[1]) / det
            mu[1] = (S[0, 0] * gap[1] - S[1, 0] * gap[0]) / det
        else:
            for a in range(r):
                mu[a] = gap[a]
            row_pivots = np.empty(r, dtype=np.int64)
            if not lu_factor(S, row_pivots):
                return False
            lu_factor_solve(S, row_pivots, mu)
        for i in range(n):
            for c in range(r):
                omega[i] -= loop_work[c, i] * mu[c]
                momentum[i] -= J[c, i] * mu[c]
    return all_finite(omega)


@njit(cache=True, error_model="numpy", nogil=True)
def integrate_variational(assemble, mass_and_force, layout, y0, t0, t_end, h, t_eval, params, y_out, cond_out):
    """Fixed-step variational integrator: symplectic and momentum-consistent, order 2 (docs/integrators.md).

    It discretises the Lagrangian itself (``mass_and_force``, generated from T - V by the Lagrange derivation
    only), so it needs the Lagrange formulation's ``mass_and_force``. It advances ``(theta, p)`` with
    ``p = M(theta) omega`` by the midpoint discrete Lagrangian; a pinned chain keeps its tip on the pin exactly
    (to the Newton tolerance) through a discrete multiplier and a velocity projection (RATTLE), so no
    stabilisation gains apply. Because the map is symplectic the energy error stays bounded over long runs
    instead of drifting, even on chaotic motion. Each step is solved by simplified Newton on the unknown angles
    (and multiplier), with a forward-difference Jacobian refreshed per step. Samples come from the cubic Hermite
    interpolant of ``(theta, omega)`` between steps, with ``theta_ddot`` from ``accel``; for a pinned chain they
    are projected onto the loop. Arguments and return value as integrate_midpoint without the stabilisation
    gains; ``n_rhs`` counts evaluations of ``mass_and_force`` and ``accel``.
    """
    check_arguments(layout, y0, t0, t_end, t_eval, params, y_out, cond_out)
    if not (h > 0.0 and h < np.inf):
        raise ValueError("h must be positive and finite")
    system = make_system(assemble, layout)
    n = y0.shape[0] // 2
    n_state = y0.shape[0]
    params = params.copy()  # the integrator writes t into it
    r = layout[LAYOUT_CONSTRAINTS]
    size = n + r
    J0 = np.zeros((max(r, 1), n))
    theta = np.empty(n)
    omega = np.empty(n)
    theta_ddot = np.empty(n)
    theta_mid = np.empty(n)
    velocity = np.empty(n)
    force = np.empty(n)
    M = np.empty((n, n))
    mass_pivots = np.empty(n, dtype=np.int64)
    loop_work = np.empty((max(r, 1), n))
    momentum = np.empty(n)
    momentum_next = np.empty(n)
    unknowns = np.zeros(size)
    probe = np.empty(size)
    residual = np.empty(size)
    residual_probe = np.empty(size)
    newton_matrix = np.empty((size, size))
    pivots = np.empty(size, dtype=np.int64)
    y = y0.copy()
    f = np.empty(n_state)
    y_next = np.empty(n_state)
    f_next = np.empty(n_state)
    y_sample = np.empty(n_state)
    y_out[:, :] = np.nan
    cond_out[:] = np.nan

    t = t0
    n_steps = 0
    n_rhs = 0
    if has_constraints(system) and not project_state(system, t, y, params, theta, omega):
        return STATUS_NOT_FINITE, n_steps, n_rhs, t, 0
    for i in range(n):
        theta[i] = y[i]
        omega[i] = y[n + i]
    lagrangian_pieces(mass_and_force, theta, omega, params, M, force)
    n_rhs += 1
    for i in range(n):
        total = 0.0
        for j in range(n):
            total += M[i, j] * omega[j]
        momentum[i] = total
    status, condition = start_rhs(system, t, y, params, 0.0, 0.0, theta, omega, theta_ddot, f)
    n_rhs += 1
    if status != STATUS_OK:
        return status, n_steps, n_rhs, t, 0
    i_sample = initial_samples(y, t0, t_eval, condition, y_out, cond_out)
    if t_end == t0:
        return STATUS_OK, n_steps, n_rhs, t, i_sample
    n_total, step = fixed_steps(t0, t_end, h)

    for k in range(n_total):
        t_new = t_end if k == n_total - 1 else t0 + (k + 1) * step
        # Predictor: a Taylor step for the angles; the multiplier keeps its last value (it varies slowly).
        for i in range(n):
            unknowns[i] = step * f[i] + 0.5 * step * step * f[n + i]
        if r != 0:  # J(q0) for the constraint force, then phi(q1) at the step's end
            for i in range(n):
                theta[i] = y[i]
                omega[i] = y[n + i]
            set_time(system, params, t)
            constraint_values(system, theta, omega, params)
            J = system[6]
            for i in range(r):  # a loop, not a slice copy (see arrays.copy_row)
                for j in range(n):
                    J0[i, j] = J[i, j]
        set_time(system, params, t_new)
        _del_residual(
            system, mass_and_force, y[:n], J0, momentum, unknowns, step, params, theta_mid, velocity, M, force, residual
        )
        n_rhs += 1
        for j in range(size):
            for i in range(size):
                probe[i] = unknowns[i]
            delta = FD_RELATIVE_STEP * max(1.0, abs(y[j]) if j < n else 0.0)
            probe[j] = unknowns[j] + delta
            delta = probe[j] - unknowns[j]
            _del_residual(
                system,
                mass_and_force,
                y[:n],
                J0,
                momentum,
                probe,
                step,
                params,
                theta_mid,
                velocity,
                M,
                force,
                residual_probe,
            )
            n_rhs += 1
            for i in range(size):
                newton_matrix[i, j] = (residual_probe[i] - residual[i]) / delta
        if not lu_factor(newton_matrix, pivots):
            status = STATUS_INTEGRATOR_FAILED
            break
        # Stop when the correction is below NEWTON_TOLERANCE of the unknowns' size (norm-wise) plus the rounding
        # of the angles themselves (q1 = q0 + increment is stored to eps |q0|; the loop rows' residual is only
        # known to eps L), or when it has stopped shrinking within a thousand times that.
        floor = 0.0
        for i in range(n):
            floor = max(floor, abs(y[i]))
        floor = 4.0 * EPSILON * max(floor, 1.0)
        converged = False
        previous = np.inf
        for iteration in range(NEWTON_MAX_ITERATIONS):
            for i in range(size):
                probe[i] = -residual[i]
            lu_factor_solve(newton_matrix, pivots, probe)
            largest = 0.0
            scale = 0.0
            for i in range(size):
                unknowns[i] += probe[i]
                largest = max(largest, abs(probe[i]))
                scale = max(scale, abs(unknowns[i]))
            _del_residual(
                system, mass_and_force, y[:n], J0, momentum, unknowns, step, params, theta_mid, velocity, M, force, residual
            )
            n_rhs += 1
            if not (np.isfinite(largest) and np.isfinite(scale)):
                status = STATUS_NOT_FINITE
                break
            if largest <= NEWTON_TOLERANCE * scale + floor or (
                largest >= 0.5 * previous and largest <= 1e3 * (NEWTON_TOLERANCE * scale + floor)
            ):
                converged = True
                break
            previous = largest
        if status != STATUS_OK:
            break
        if not converged:
            status = STATUS_INTEGRATOR_FAILED
            break
        # p1 = D2 L_d(q0, q1) + (h/2) Q = M v + (h/2) f at the converged midpoint (the last residual's M, force).
        for i in range(n):
            total = 0.5 * step * force[i]
            for j in range(n):
                total += M[i, j] * velocity[j]
            momentum_next[i] = total
            theta[i] = y[i] + unknowns[i]
        if not _velocity_from_momentum(
            system, mass_and_force, theta, momentum_next, params, M, force, mass_pivots, loop_work, omega
        ):
            status = STATUS_NOT_FINITE
            break
        n_rhs += 1
        for i in range(n):
            y_next[i] = theta[i]
            y_next[n + i] = omega[i]
        status, _ = ode_rhs(system, t_new, y_next, params, 0.0, 0.0, theta, omega, theta_ddot, f_next)
        n_rhs += 1
        if status == STATUS_OK:  # the constraints' geometric test, once per step
            status, _ = step_status(system, t_new, y_next, params, theta, omega)
        if status != STATUS_OK:
            break
        n_steps += 1

        i_sample = hermite_samples(
            system,
            i_sample,
            t,
            t_new,
            y,
            f,
            y_next,
            f_next,
            t_eval,
            params,
            0.0,
            0.0,
            has_constraints(system),
            y_sample,
            theta,
            omega,
            theta_ddot,
            y_out,
            cond_out,
        )
        for i in range(n_state):
            y[i] = y_next[i]
            f[i] = f_next[i]
        for i in range(n):
            momentum[i] = momentum_next[i]
        t = t_new

    return status, n_steps, n_rhs, t, i_sample
