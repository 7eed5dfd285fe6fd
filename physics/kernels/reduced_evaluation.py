"""The reduced model's evaluation in one joint coordinate, on a mechanism's generated DAE code.

:mod:`physics.mechanism.reduced_partition` integrates a mobility-1 mechanism in one joint coordinate ``s``;
each evaluation at ``(t, s, sdot)`` solves the positions by Newton's method, the velocities and the
accelerations. Here that whole evaluation is one compiled call on the DAE's generated functions (the
``constraints`` of :mod:`physics.kernels.abi` for ``Phi``, ``Phi_q`` and ``nu``; ``assemble`` for the applied
forces ``Q`` and ``gamma``, the rows of its ``b``), so no constraint is evaluated in Python.

A *joint coordinate* is described by arrays, one row per joint that offers one (a pin's relative angle, a
slider's travel; a gear offers none), in the order the Python side names them:

* ``kinds[j]``: :data:`ANGLE` or :data:`TRAVEL`;
* ``ends[j] = (a, b)``: the bodies by index, -1 the ground; an angle is ``phi_b - phi_a``; a travel is body
  ``a``'s point along body ``b``'s guide;
* ``geometry[j] = (arm_a.x, arm_a.y, arm_b.x, arm_b.y, u.x, u.y, drawn)``: for a travel, the sliding point on
  ``a`` and the guide's through point on ``b`` (from each body's sketch centre of mass; a ground point as its
  coordinates), the guide's unit direction in the sketch and the travel the sketch draws (unused for an angle).

The travel is ``U . (p_a - p_b) - drawn`` with ``U = R(phi_b) u``; its gradient and its curvature
``gamma_c = -(d/dt c_q) qdot`` are written out below as :mod:`physics.mechanism.joint_coordinates` writes them
in numpy. A status says what failed (:data:`OK`, :data:`NOT_CONVERGED`, :data:`NOT_FINITE`, :data:`SINGULAR`);
the caller turns it into its sentence.
"""

import math

import numpy as np
from numba import njit

from . import disk_cache  # noqa: F401  (numba's cache locator, before any kernel here is defined)
from .abi import LAYOUT_ACCELERATION, LAYOUT_CONSTRAINTS, LAYOUT_COORDINATES, LAYOUT_TIME, LAYOUT_UNKNOWNS
from .linear import lu_factor, lu_factor_solve
from .system import constraints_into, equations_into

ANGLE = 0
TRAVEL = 1

OK = 0
NOT_CONVERGED = 1  # Newton's residual stayed above the failure level (a dead centre passed between two steps)
NOT_FINITE = 2  # the bordered Jacobian has a non-finite entry
SINGULAR = 3  # the bordered Jacobian has an exactly zero pivot (numpy's inv would raise LinAlgError)

# Slots of ``numbers`` (what the caller passes in) and of ``scalars`` (what comes back).
NUMBER_T, NUMBER_S, NUMBER_SDOT, NUMBER_LENGTH = 0, 1, 2, 3
NUMBER_STEP_TOLERANCE, NUMBER_NOISE, NUMBER_CHORD_RATE, NUMBER_FAILURE, NUMBER_STEPS = 4, 5, 6, 7, 8
NUMBERS = 9
REFERENCE_T, REFERENCE_S, REFERENCE_SDOT, REFERENCE_SDDOT = 0, 1, 2, 3
SCALAR_MASS, SCALAR_SDDOT, SCALAR_RESIDUAL, SCALAR_SHARE = 0, 1, 2, 3
SCALARS = 4
# Rows of a state's ``(4, n)`` array: the pose, velocities, accelerations and the velocity map B = dq/ds.
ROW_Q, ROW_QDOT, ROW_QDDOT, ROW_MAP = 0, 1, 2, 3


@njit(cache=True, error_model="numpy", nogil=True)
def _angle(q, body):
    return 0.0 if body < 0 else q[3 * body + 2]


@njit(cache=True, error_model="numpy", nogil=True)
def _point(q, body, x, y):
    """The point at arm ``(x, y)`` of ``body`` (the ground's: the point itself)."""
    if body < 0:
        return x, y
    c, s = math.cos(q[3 * body + 2]), math.sin(q[3 * body + 2])
    return q[3 * body] + c * x - s * y, q[3 * body + 1] + s * x + c * y


@njit(cache=True, error_model="numpy", nogil=True)
def coordinate_value(kinds, ends, geometry, which, q):
    """Joint coordinate ``which`` at pose ``q``."""
    a, b = ends[which, 0], ends[which, 1]
    if kinds[which] == ANGLE:
        return _angle(q, b) - _angle(q, a)
    g = geometry[which]
    c, s = math.cos(_angle(q, b)), math.sin(_angle(q, b))
    ux, uy = c * g[4] - s * g[5], s * g[4] + c * g[5]
    pax, pay = _point(q, a, g[0], g[1])
    pbx, pby = _point(q, b, g[2], g[3])
    return ux * (pax - pbx) + uy * (pay - pby) - g[6]


@njit(cache=True, error_model="numpy", nogil=True)
def coordinate_gradient(kinds, ends, geometry, which, q, row):
    """``c_q`` of joint coordinate ``which`` at pose ``q`` into ``row`` (3 B,)."""
    for i in range(row.shape[0]):
        row[i] = 0.0
    a, b = ends[which, 0], ends[which, 1]
    if kinds[which] == ANGLE:
        if b >= 0:
            row[3 * b + 2] += 1.0
        if a >= 0:
            row[3 * a + 2] -= 1.0
        return
    g = geometry[which]
    c, s = math.cos(_angle(q, b)), math.sin(_angle(q, b))
    ux, uy = c * g[4] - s * g[5], s * g[4] + c * g[5]
    if a >= 0:
        ca, sa = math.cos(q[3 * a + 2]), math.sin(q[3 * a + 2])
        rx, ry = ca * g[0] - sa * g[1], sa * g[0] + ca * g[1]  # R(phi_a) arm_a
        row[3 * a] += ux
        row[3 * a + 1] += uy
        row[3 * a + 2] += ux * -ry + uy * rx  # U . perp(R arm_a)
    if b >= 0:
        pax, pay = _point(q, a, g[0], g[1])
        pbx, pby = _point(q, b, g[2], g[3])
        gx, gy = pax - pbx, pay - pby
        rx, ry = c * g[2] - s * g[3], s * g[2] + c * g[3]  # R(phi_b) arm_b
        row[3 * b] -= ux
        row[3 * b + 1] -= uy
        row[3 * b + 2] += -(ux * -ry + uy * rx) + (-uy * gx + ux * gy)  # - U . perp(R arm_b) + perp(U) . gap


@njit(cache=True, error_model="numpy", nogil=True)
def coordinate_curvature(kinds, ends, geometry, which, q, qdot):
    """``gamma_c`` of joint coordinate ``which``: ``c_q qddot = gamma_c`` along the motion (zero for an angle)."""
    if kinds[which] == ANGLE:
        return 0.0
    a, b = ends[which, 0], ends[which, 1]
    g = geometry[which]
    c, s = math.cos(_angle(q, b)), math.sin(_angle(q, b))
    ux, uy = c * g[4] - s * g[5], s * g[4] + c * g[5]
    pax, pay = _point(q, a, g[0], g[1])
    pbx, pby = _point(q, b, g[2], g[3])
    gx, gy = pax - pbx, pay - pby
    wa = 0.0 if a < 0 else qdot[3 * a + 2]
    wb = 0.0 if b < 0 else qdot[3 * b + 2]
    # each point's velocity and centripetal acceleration (zero on the ground)
    vax = vay = cax = cay = 0.0
    if a >= 0:
        ca, sa = math.cos(q[3 * a + 2]), math.sin(q[3 * a + 2])
        rx, ry = ca * g[0] - sa * g[1], sa * g[0] + ca * g[1]
        vax, vay = qdot[3 * a] - wa * ry, qdot[3 * a + 1] + wa * rx
        cax, cay = -(wa * wa) * rx, -(wa * wa) * ry
    vbx = vby = cbx = cby = 0.0
    if b >= 0:
        rx, ry = c * g[2] - s * g[3], s * g[2] + c * g[3]
        vbx, vby = qdot[3 * b] - wb * ry, qdot[3 * b + 1] + wb * rx
        cbx, cby = -(wb * wb) * rx, -(wb * wb) * ry
    rate_x, rate_y = vax - vbx, vay - vby
    quadratic = (-(wb * wb) * (ux * gx + uy * gy) + 2.0 * wb * (-uy * rate_x + ux * rate_y)
                 + ux * (cax - cbx) + uy * (cay - cby))
    return -quadratic


@njit(cache=True, error_model="numpy", nogil=True)
def speed_shares(kinds, ends, geometry, speed_scale, q, direction, row, shares):
    """Each joint's rate along the velocity ``direction`` as a speed (angles times ``speed_scale``), divided by
    the largest, into ``shares``: 1 for the fastest joint, 0 for one at a dead centre. ``row``: scratch (3 B,)."""
    largest = 0.0
    for j in range(kinds.shape[0]):
        coordinate_gradient(kinds, ends, geometry, j, q, row)
        rate = 0.0
        for i in range(row.shape[0]):
            rate += row[i] * direction[i]
        shares[j] = abs(rate) * speed_scale[j]
        largest = max(largest, shares[j])
    largest = max(largest, 1e-300)
    for j in range(kinds.shape[0]):
        shares[j] /= largest


@njit(cache=True, error_model="numpy", nogil=True)
def _set_time(layout, params, t):
    slot = layout[LAYOUT_TIME]
    if slot >= 0:
        params[slot] = t


@njit(cache=True, error_model="numpy", nogil=True)
def _closure(layout, params, kinds, ends, geometry, which, q, s, rest, J, v, out):
    """``[Phi(q, t); c(q) - s]`` into ``out`` (the time already in ``params``)."""
    constraints_into(layout, J, v, q, rest, params)
    r = layout[LAYOUT_CONSTRAINTS]
    for i in range(r):
        out[i] = v[i]
    out[r] = coordinate_value(kinds, ends, geometry, which, q) - s


@njit(cache=True, error_model="numpy", nogil=True)
def _invert_bordered(layout, params, kinds, ends, geometry, which, q, rest, J, v, matrix, pivots, inverse, row):
    """``[Phi_q; c_q]^{-1}`` at ``q`` into ``inverse``; the status (:data:`NOT_FINITE`, :data:`SINGULAR`)."""
    n = q.shape[0]
    constraints_into(layout, J, v, q, rest, params)
    r = layout[LAYOUT_CONSTRAINTS]
    coordinate_gradient(kinds, ends, geometry, which, q, row)
    for i in range(r):
        for j in range(n):
            matrix[i, j] = J[i, j]
    for j in range(n):
        matrix[r, j] = row[j]
    for i in range(n):
        for j in range(n):
            if not np.isfinite(matrix[i, j]):
                return NOT_FINITE
    if not lu_factor(matrix, pivots):
        return SINGULAR
    column = np.empty(n)
    for k in range(n):
        for i in range(n):
            column[i] = 0.0
        column[k] = 1.0
        lu_factor_solve(matrix, pivots, column)
        for i in range(n):
            inverse[i, k] = column[i]
    return OK


@njit(cache=True, error_model="numpy", nogil=True)
def bordered_inverse(layout, params, kinds, ends, geometry, which, q, t, inverse):
    """``[Phi_q; c_q]^{-1}`` at pose ``q`` and time ``t`` into ``inverse`` (3 B, 3 B); the status."""
    n = q.shape[0]
    r = max(layout[LAYOUT_CONSTRAINTS], 1)
    _set_time(layout, params, t)
    return _invert_bordered(layout, params, kinds, ends, geometry, which, q, np.zeros(n), np.zeros((r, n)),
                            np.zeros(2 * r), np.empty((n, n)), np.empty(n, dtype=np.int64), inverse, np.empty(n))


@njit(cache=True, error_model="numpy", nogil=True)
def coordinate_state(kinds, ends, geometry, which, q, qdot, out):
    """``(s, sdot)`` of joint coordinate ``which`` at the state ``(q, qdot)`` into ``out`` (2,)."""
    row = np.empty(q.shape[0])
    coordinate_gradient(kinds, ends, geometry, which, q, row)
    rate = 0.0
    for i in range(q.shape[0]):
        rate += row[i] * qdot[i]
    out[0] = coordinate_value(kinds, ends, geometry, which, q)
    out[1] = rate


@njit(cache=True, error_model="numpy", nogil=True)
def reduced_state(assemble, layout, params, mass, nu, kinds, ends, geometry, speed_scale, which, weights, numbers,
                  reference, reference_numbers, inverse, state, scalars, shares):
    """Everything at ``(t, s, sdot) = numbers[:3]`` in joint coordinate ``which``; the status.

    Positions: Newton on ``[Phi(q, t); c(q) - s] = 0`` from the ``reference`` state (rows q, qdot, qddot, B;
    ``reference_numbers``: its t, s, sdot, sddot) predicted to second order in time and corrected along ``B``,
    chord steps on ``inverse`` (the reference's ``[Phi_q; c_q]^{-1}``) while each step is below the chord rate
    times the one before, a fresh inverse otherwise; it stops when a step (weighted by ``weights``) moves nothing
    by more than the step tolerance times the length, or when steps below the noise level stop shrinking. Then,
    at the converged pose: ``inverse`` afresh, ``B`` its last column, ``qdot = B sdot + A^{-1} [nu; 0]``,
    ``a0 = A^{-1} [gamma; gamma_c]``, ``sddot = B^T (Q - M a0) / (B^T M B)`` and ``qddot = B sddot + a0``, into
    ``state`` (rows as the reference's) and ``scalars`` (generalised mass, sddot, the residual left by a
    failed Newton iteration, the coordinate's share); every joint's speed share along ``B`` into ``shares``.
    ``inverse`` is replaced only when the evaluation succeeds; ``params``' time slot is written with ``t``."""
    n = layout[LAYOUT_COORDINATES]
    r = layout[LAYOUT_CONSTRAINTS]
    k = layout[LAYOUT_UNKNOWNS]
    t, s, sdot, length = numbers[NUMBER_T], numbers[NUMBER_S], numbers[NUMBER_SDOT], numbers[NUMBER_LENGTH]
    rows = max(r, 1)
    rest = np.zeros(n)
    J = np.zeros((rows, n))
    v = np.zeros(2 * rows)
    matrix = np.empty((n, n))
    pivots = np.empty(n, dtype=np.int64)
    row = np.empty(n)
    closure = np.empty(n)
    fresh = np.empty((n, n))
    _set_time(layout, params, t)

    # ---- positions: predicted from the reference, then Newton
    elapsed = t - reference_numbers[REFERENCE_T]
    s_drift = reference_numbers[REFERENCE_SDOT] * elapsed + 0.5 * reference_numbers[REFERENCE_SDDOT] * elapsed**2
    along = s - reference_numbers[REFERENCE_S] - s_drift
    q = np.empty(n)
    for i in range(n):
        drift = reference[ROW_QDOT, i] * elapsed + 0.5 * reference[ROW_QDDOT, i] * elapsed**2
        q[i] = reference[ROW_Q, i] + drift + reference[ROW_MAP, i] * along
    chord = inverse
    previous = np.inf
    converged = False
    for _ in range(int(numbers[NUMBER_STEPS])):
        _closure(layout, params, kinds, ends, geometry, which, q, s, rest, J, v, closure)
        moved = 0.0
        for i in range(n):
            step = 0.0
            for j in range(n):
                step += chord[i, j] * closure[j]
            q[i] -= step
            moved = max(moved, abs(step * weights[i]))
        if moved <= numbers[NUMBER_STEP_TOLERANCE] * length:
            converged = True
            break
        if moved <= numbers[NUMBER_NOISE] * length and moved >= 0.5 * previous:
            converged = True  # the steps no longer shrink: they are rounding noise
            break
        if moved > numbers[NUMBER_CHORD_RATE] * previous:  # the chord steps converge slowly here: a fresh inverse
            status = _invert_bordered(layout, params, kinds, ends, geometry, which, q, rest, J, v, matrix, pivots,
                                      fresh, row)
            if status != OK:
                return status
            chord = fresh
        previous = moved
    if not converged:
        _closure(layout, params, kinds, ends, geometry, which, q, s, rest, J, v, closure)
        residual = 0.0
        for i in range(n):
            residual = max(residual, abs(closure[i]))
        scalars[SCALAR_RESIDUAL] = residual
        if not residual <= numbers[NUMBER_FAILURE] * length:
            return NOT_CONVERGED

    # ---- the bordered Jacobian's inverse at the pose, velocities and accelerations
    status = _invert_bordered(layout, params, kinds, ends, geometry, which, q, rest, J, v, matrix, pivots, fresh, row)
    if status != OK:
        return status
    for i in range(n):
        motor = 0.0
        for j in range(r):
            motor += fresh[i, j] * nu[j]
        state[ROW_Q, i] = q[i]
        state[ROW_MAP, i] = fresh[i, n - 1]
        state[ROW_QDOT, i] = fresh[i, n - 1] * sdot + motor
    qdot = np.empty(n)
    for i in range(n):
        qdot[i] = state[ROW_QDOT, i]
    A = np.empty((k, k))
    b = np.empty(k)
    equations_into(assemble, layout, A, b, J, v, q, qdot, params, 0.0, 0.0)
    first_row = LAYOUT_ACCELERATION + n
    curvature = closure  # reused: [gamma; gamma_c]
    for i in range(r):
        curvature[i] = b[layout[first_row + i]]
    curvature[r] = coordinate_curvature(kinds, ends, geometry, which, q, qdot)
    generalised_mass = 0.0
    generalised_force = 0.0
    drift = row  # reused: a0 = A^{-1} [gamma; gamma_c]
    for i in range(n):
        total = 0.0
        for j in range(n):
            total += fresh[i, j] * curvature[j]
        drift[i] = total
        velocity_map = state[ROW_MAP, i]
        generalised_mass += velocity_map * (mass[i] * velocity_map)
        generalised_force += velocity_map * (b[i] - mass[i] * total)  # the DAE's row i: M qddot + reactions = Q
    sddot = generalised_force / generalised_mass
    for i in range(n):
        state[ROW_QDDOT, i] = state[ROW_MAP, i] * sddot + drift[i]
        for j in range(n):
            inverse[i, j] = fresh[i, j]
    scalars[SCALAR_MASS] = generalised_mass
    scalars[SCALAR_SDDOT] = sddot
    direction = np.empty(n)
    for i in range(n):
        direction[i] = state[ROW_MAP, i]
    speed_shares(kinds, ends, geometry, speed_scale, q, direction, row, shares)
    scalars[SCALAR_SHARE] = shares[which]
    return OK
