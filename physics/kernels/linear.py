"""Dense linear solves for the formulations' small systems, with a cheap singularity estimate.

Every solve returns the ratio of the largest to the smallest pivot: it grows like 1/delta at a distance delta
from a singular position, so it doubles as the detector that stops a run before its answers are noise.
"""

import numpy as np
from numba import njit

from . import disk_cache  # noqa: F401  (numba's cache locator, before any kernel here is defined)
from .constants import RELATIVE_NOISE


@njit(cache=True, error_model="numpy", nogil=True)
def column_weight(params, offset, i):
    """The weight of coordinate ``i``: ``params[offset + i]``, or 1 when ``offset < 0`` (unit weights)."""
    return 1.0 if offset < 0 else params[offset + i]


@njit(cache=True, error_model="numpy", nogil=True)
def gram_into(G, J, r, params, offset, rows):
    """``G[:r, :r] = J W J^T`` of the constraints' Jacobian ``J`` (``r`` rows), ``W`` the diagonal weights at
    ``offset`` of ``params`` (:func:`column_weight`; unit when ``offset < 0``).

    Summed column by column over each column's non-zeros (a mechanism's constraint touches at most two bodies,
    so a column has a few): the same numbers as the dense triple loop for about ``r`` times less work (which
    cost as much as a six-bar's whole solve). The upper triangle is summed and mirrored, so ``G`` is exactly
    symmetric. ``rows`` (at least ``r`` long) holds a column's non-zero rows meanwhile."""
    n = J.shape[1]
    for i in range(r):
        for j in range(r):
            G[i, j] = 0.0
    for c in range(n):
        count = 0
        for i in range(r):
            if J[i, c] != 0.0:
                rows[count] = i
                count += 1
        weight = column_weight(params, offset, c)
        for a in range(count):
            row_a = int(rows[a])
            value = J[row_a, c] * weight
            for b in range(a, count):
                row_b = int(rows[b])
                G[row_a, row_b] += value * J[row_b, c]
    for i in range(r):
        for j in range(i + 1, r):
            G[j, i] = G[i, j]


@njit(cache=True, error_model="numpy", nogil=True)
def lu_solve(A, b, x):
    """Solve A x = b by Gaussian elimination with partial pivoting, overwriting A and b (the fast path).

    Returns the ratio of the largest to the smallest pivot magnitude, infinite when a pivot vanishes.
    """
    k = A.shape[0]
    largest = 0.0
    smallest = np.inf
    for col in range(k):
        pivot_row = col
        pivot_abs = abs(A[col, col])
        for row in range(col + 1, k):
            value = abs(A[row, col])
            if value > pivot_abs:
                pivot_abs = value
                pivot_row = row
        if pivot_abs == 0.0 or not np.isfinite(pivot_abs):
            for i in range(k):
                x[i] = np.nan
            return np.inf
        if pivot_row != col:
            for j in range(col, k):
                tmp = A[col, j]
                A[col, j] = A[pivot_row, j]
                A[pivot_row, j] = tmp
            tmp = b[col]
            b[col] = b[pivot_row]
            b[pivot_row] = tmp
        largest = max(largest, pivot_abs)
        smallest = min(smallest, pivot_abs)
        inv = 1.0 / A[col, col]
        for row in range(col + 1, k):
            factor = A[row, col] * inv
            if factor != 0.0:
                for j in range(col + 1, k):
                    A[row, j] -= factor * A[col, j]
                b[row] -= factor * b[col]
    for i in range(k - 1, -1, -1):
        acc = b[i]
        for j in range(i + 1, k):
            acc -= A[i, j] * x[j]
        x[i] = acc / A[i, i]
    return largest / smallest


@njit(cache=True, error_model="numpy", nogil=True)
def ldlt_solve(A, b, x):
    """Solve A x = b for a symmetric positive definite A by A = L D L^T (its lower triangle is read; overwritten).

    Half the work of LU, no pivoting and no square roots: Lagrange's mass matrix is SPD by construction (kinetic
    energy). Returns the ratio of the largest to the smallest entry of D, which are the pivots of the LU
    factorisation without pivoting; infinite when A is not positive definite (singular, or wrongly signed).
    """
    ratio = ldlt_factor(A)
    if not ratio < np.inf:
        for i in range(A.shape[0]):
            x[i] = np.nan
        return ratio
    k = A.shape[0]
    for i in range(k):
        total = b[i]
        for p in range(i):
            value = A[i, p]
            if value != 0.0:
                total -= value * x[p]
        x[i] = total
    for i in range(k - 1, -1, -1):
        total = x[i] / A[i, i]
        for p in range(i + 1, k):
            value = A[p, i]
            if value != 0.0:
                total -= value * x[p]
        x[i] = total
    return ratio


@njit(cache=True, error_model="numpy", nogil=True)
def ldlt_factor(A):
    """``A = L D L^T`` in place (the lower triangle is read; ``D`` on the diagonal, ``L`` below it) for a
    symmetric positive definite ``A``; returns the ratio of the largest to the smallest entry of ``D``, infinite
    when ``A`` is not positive definite (see :func:`ldlt_solve`).

    Terms of a zero entry of ``L`` are skipped: the constraints' ``J W J^T`` of a six-bar has 35 to 39 non-zeros
    of 91 below its diagonal, so most of the dense loop's products were zeros. The terms that remain are taken in
    the same order, with the same products, as the dense loop: the same numbers (a skipped term could only have
    changed the sign of a zero)."""
    k = A.shape[0]
    largest = 0.0
    smallest = np.inf
    for j in range(k):
        pivot = A[j, j]
        for p in range(j):
            value = A[j, p]
            if value != 0.0:
                pivot -= value * value * A[p, p]
        if not pivot > 0.0 or not np.isfinite(pivot):
            return np.inf
        largest = max(largest, pivot)
        smallest = min(smallest, pivot)
        A[j, j] = pivot
        for p in range(j):
            value = A[j, p]
            if value != 0.0:
                weight = A[p, p]
                for i in range(j + 1, k):
                    A[i, j] -= A[i, p] * value * weight
        inv = 1.0 / pivot
        for i in range(j + 1, k):
            A[i, j] = A[i, j] * inv
    return largest / smallest


@njit(cache=True, error_model="numpy", nogil=True)
def equilibrate(A, b, col_scale):
    """Scale the rows and columns of A x = b to unit largest entry, in place; ``x = col_scale * x_scaled``.

    Returns False when a row or column is rounding noise next to the rest (cos(pi/2) = 6e-17 in a loop
    constraint): scaling it up would hide a singular position behind a solvable matrix.
    """
    k = A.shape[0]
    overall = 0.0
    for row in range(k):
        for j in range(k):
            overall = max(overall, abs(A[row, j]))
    if not (overall > 0.0 and np.isfinite(overall)):
        return False
    noise = RELATIVE_NOISE * overall
    for row in range(k):
        biggest = 0.0
        for j in range(k):
            biggest = max(biggest, abs(A[row, j]))
        if biggest <= noise:
            return False
        if np.isfinite(biggest):
            inv = 1.0 / biggest
            for j in range(k):
                A[row, j] *= inv
            b[row] *= inv
    for j in range(k):
        biggest = 0.0
        for row in range(k):
            biggest = max(biggest, abs(A[row, j]))
        if biggest <= RELATIVE_NOISE:  # rows are now of size 1
            return False
        col_scale[j] = 1.0 / biggest if np.isfinite(biggest) else 1.0
        for row in range(k):
            A[row, j] *= col_scale[j]
    return True


@njit(cache=True, error_model="numpy", nogil=True)
def lu_solve_equilibrated(A, b, x, col_scale):
    """Solve A x = b equilibrated (rows and columns scaled), then by pivoted LU; returns the pivot ratio of the
    equilibrated matrix, so that a mere difference of scale (a very light tip, stiff mass ratios) does not look
    like a singular position. Infinite when singular."""
    if not equilibrate(A, b, col_scale):
        for i in range(A.shape[0]):
            x[i] = np.nan
        return np.inf
    ratio = lu_solve(A, b, x)
    for i in range(A.shape[0]):
        x[i] *= col_scale[i]
    return ratio


@njit(cache=True, error_model="numpy", nogil=True)
def lu_factor(M, pivots):
    """In-place LU factorisation with partial pivoting; False if a pivot is exactly zero."""
    size = M.shape[0]
    for k in range(size):
        best = k
        for i in range(k + 1, size):
            if abs(M[i, k]) > abs(M[best, k]):
                best = i
        pivots[k] = best
        if M[best, k] == 0.0:
            return False
        if best != k:
            for j in range(size):
                swap = M[k, j]
                M[k, j] = M[best, j]
                M[best, j] = swap
        for i in range(k + 1, size):
            M[i, k] /= M[k, k]
            factor = M[i, k]
            if factor != 0.0:
                for j in range(k + 1, size):
                    M[i, j] -= factor * M[k, j]
    return True


@njit(cache=True, error_model="numpy", nogil=True)
def lu_factor_solve(M, pivots, rhs):
    """Solve with the factors of lu_factor, overwriting ``rhs`` with the solution."""
    size = M.shape[0]
    for k in range(size):
        p = pivots[k]
        if p != k:
            swap = rhs[k]
            rhs[k] = rhs[p]
            rhs[p] = swap
    for i in range(size):
        total = rhs[i]
        for j in range(i):
            total -= M[i, j] * rhs[j]
        rhs[i] = total
    for i in range(size - 1, -1, -1):
        total = rhs[i]
        for j in range(i + 1, size):
            total -= M[i, j] * rhs[j]
        rhs[i] = total / M[i, i]
