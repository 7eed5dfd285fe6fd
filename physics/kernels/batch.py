"""One classical RK4 step for a batch of states of one mechanism (ensembles and chaos maps)."""

from numba import njit

from . import disk_cache  # noqa: F401  (numba's cache locator, before any kernel here is defined)
from .system import make_system, solve_accel


@njit(cache=True, error_model="numpy", nogil=True)
def rk4_batch_step(assemble, layout, theta, omega, params, h, alpha, beta, work, cond_out):
    """Advance K states by one classical RK4 step of size ``h``, in place.

    theta, omega (K, n): the states; work (RK4_WORK_ROWS, n): scratch; cond_out (K,) receives, per state, the
    largest condition estimate accel returned over the four stages (NaN if any was NaN). One state after another
    in a plain loop: the caller decides about threads. Returns the largest entry of cond_out (NaN wins).
    """
    system = make_system(assemble, layout)
    n_batch = theta.shape[0]
    n = theta.shape[1]
    theta_stage = work[0]
    omega_stage = work[1]
    theta_ddot = work[2]
    k_theta = work[3]
    k_omega = work[4]
    sum_theta = work[5]
    sum_omega = work[6]
    worst_overall = 0.0
    for b in range(n_batch):
        worst = 0.0
        for stage in range(4):
            if stage == 0:
                for i in range(n):
                    theta_stage[i] = theta[b, i]
                    omega_stage[i] = omega[b, i]
            else:
                fraction = h if stage == 3 else 0.5 * h
                for i in range(n):
                    theta_stage[i] = theta[b, i] + fraction * k_theta[i]
                    omega_stage[i] = omega[b, i] + fraction * k_omega[i]
            condition = solve_accel(system, theta_stage, omega_stage, params, alpha, beta, theta_ddot)
            if condition > worst or condition != condition:
                if worst == worst:
                    worst = condition
            weight = 1.0 if stage == 0 or stage == 3 else 2.0
            for i in range(n):
                k_theta[i] = omega_stage[i]
                k_omega[i] = theta_ddot[i]
                if stage == 0:
                    sum_theta[i] = k_theta[i]
                    sum_omega[i] = k_omega[i]
                else:
                    sum_theta[i] += weight * k_theta[i]
                    sum_omega[i] += weight * k_omega[i]
        for i in range(n):
            theta[b, i] += h / 6.0 * sum_theta[i]
            omega[b, i] += h / 6.0 * sum_omega[i]
        cond_out[b] = worst
        if worst > worst_overall or worst != worst:
            if worst_overall == worst_overall:
                worst_overall = worst
    return worst_overall
