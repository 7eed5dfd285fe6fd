"""Array copies written as loops, for the kernels' hot and first-compiled paths."""

from numba import njit

from . import disk_cache  # noqa: F401  (numba's cache locator, before any kernel here is defined)


@njit(cache=True, error_model="numpy", nogil=True)
def copy_row(source, target, row):
    """``target[row, :] = source`` as a plain loop: numba's slice assignment checks shapes with a formatted
    error message whose compilation costs about 2 s of every empty-cache run (the shapes agree by construction)."""
    for j in range(source.shape[0]):
        target[row, j] = source[j]


@njit(cache=True, error_model="numpy", nogil=True)
def copy_matrix(source, target, row):
    """``target[row, :, :] = source`` as a plain loop (see :func:`copy_row`)."""
    for i in range(source.shape[0]):
        for j in range(source.shape[1]):
            target[row, i, j] = source[i, j]


@njit(cache=True, error_model="numpy", nogil=True)
def state_row(theta, omega, row, theta_row, omega_row):
    """State ``row`` of a batch ``theta``, ``omega`` (K, n) into the contiguous (n,) arrays the generated code
    reads (a plain loop, see :func:`copy_row`)."""
    for i in range(theta_row.shape[0]):
        theta_row[i] = theta[row, i]
        omega_row[i] = omega[row, i]


@njit(cache=True, error_model="numpy", nogil=True)
def stage_sum_into(y, h, K, weights, count, out):
    """``out = y + h * sum_{r < count} weights[r] K[r]``: a Runge-Kutta stage's or step's state from the stage
    derivatives in the rows of ``K`` (each component summed in stage order, as scipy does)."""
    for j in range(y.shape[0]):
        total = 0.0
        for r in range(count):
            total += K[r, j] * weights[r]
        out[j] = y[j] + h * total
