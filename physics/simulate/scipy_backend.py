"""The scipy back end: scipy.integrate's public solver classes (RK45, DOP853, Radau, LSODA) stepped by hand
on the generated right-hand side.

This module is the scipy boundary of the simulation: ``physics.simulate.run`` imports it only when
``backend = "scipy"`` is asked for, so the compiled path never loads scipy's integrators.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import DOP853, LSODA, RK45, OdeSolver, Radau

from ..kernels.constants import SINGULAR_PIVOT_RATIO
from ..registry import INTEGRATORS
from ..status import Status

# The public solver classes, by the name the integrator registry gives (IntegratorSpec.scipy_solver).
SOLVERS: dict[str, type[OdeSolver]] = {cls.__name__: cls for cls in (RK45, DOP853, Radau, LSODA)}


class _Singular(Exception):
    pass


def integrate_scipy(compiled, y0, t_eval, params, settings, alpha, beta, project, layout=None):
    """scipy's solvers stepped by hand, so a failure keeps the samples so far and projection can act.

    With projection, the solver is restarted from the projected state at every output sample (scipy's
    solvers keep internal state that a projection would invalidate). ``layout``: the kernels' layout of the
    run when it is not the compiled system's own (a mechanism's run: the DAE's projection weights appended to
    ``params``); with it the clock is written into the parameter vector before every evaluation (a speed motor
    follows it), as the compiled kernels do."""
    n = compiled.n
    counter = {"rhs": 0}
    if layout is None:
        accel, project_onto = _untimed(compiled)
    else:
        accel, project_onto, params = _timed(compiled, layout, params)

    def rhs(t, y):
        counter["rhs"] += 1
        theta_ddot, c = accel(y[:n], y[n:], params, alpha, beta, t)
        if not c <= SINGULAR_PIVOT_RATIO:
            raise _Singular(t)
        return np.concatenate([y[n:], theta_ddot])

    y_out = np.full((len(t_eval), y0.size), np.nan)
    solver_name = INTEGRATORS[settings.integrator].scipy_solver
    assert solver_name is not None, settings.integrator  # Settings sends only scipy-capable integrators here
    solver_cls = SOLVERS[solver_name]
    y = y0.copy()
    t_now = float(t_eval[0])
    y_out[0] = y
    next_sample = 1
    n_steps = 0
    status, detail = Status.OK, ""
    segments = [(t_eval[i - 1], t_eval[i]) for i in range(1, len(t_eval))] if project else [(t_eval[0], t_eval[-1])]
    try:
        for seg_start, seg_end in segments:
            solver = solver_cls(rhs, float(seg_start), y, float(seg_end), rtol=settings.rtol, atol=settings.atol)
            while solver.status == "running":
                message = solver.step()
                n_steps += 1
                if solver.status == "failed":
                    status, detail = Status.INTEGRATOR_FAILED, str(message)
                    break
                if n_steps >= settings.max_steps:
                    status = Status.MAX_STEPS
                    break
                if not np.all(np.isfinite(solver.y)):
                    status = Status.NOT_FINITE
                    break
                dense = None
                while next_sample < len(t_eval) and t_eval[next_sample] <= solver.t:
                    if dense is None:
                        dense = solver.dense_output()
                    y_out[next_sample] = dense(t_eval[next_sample])
                    next_sample += 1
            t_now = solver.t
            if status != Status.OK:
                break
            if project:
                y = y_out[next_sample - 1].copy()
                theta, omega = np.ascontiguousarray(y[:n]), np.ascontiguousarray(y[n:])
                project_onto(theta, omega, params, t_eval[next_sample - 1])
                y = np.concatenate([theta, omega])
                y_out[next_sample - 1] = y
    except _Singular as stop:
        status, t_now = Status.SINGULAR, float(stop.args[0])
    y_out[next_sample:] = np.nan
    return y_out, np.empty(0), status, n_steps, counter["rhs"], t_now, detail


def _untimed(compiled):
    """The compiled system's own ``accel`` (a chain's right-hand side reads no clock) and ``project``."""

    def accel(theta, omega, values, alpha, beta, _t):
        return compiled.accel(theta, omega, values, alpha, beta)

    return accel, compiled.project


def _timed(compiled, layout, params):
    """``accel(theta, omega, params, alpha, beta, t)`` and ``project(theta, omega, params, t)`` on ``layout``,
    the clock written into a copy of ``params`` (the layout says where; -1: nothing reads it)."""
    from ..kernels.abi import LAYOUT_TIME  # noqa: PLC0415
    from ..kernels.projection import project_states  # noqa: PLC0415
    from ..kernels.system import accel_states  # noqa: PLC0415

    params = np.array(params, dtype=float)
    slot = int(layout[LAYOUT_TIME])
    n = compiled.n
    theta_ddot, condition = np.empty((1, n)), np.empty(1)

    def accel(theta, omega, values, alpha, beta, t):
        if slot >= 0:
            values[slot] = t
        accel_states(compiled.assemble_function, layout, np.ascontiguousarray(theta).reshape(1, n),
                     np.ascontiguousarray(omega).reshape(1, n), values, float(alpha), float(beta), theta_ddot,
                     condition)
        return theta_ddot[0].copy(), float(condition[0])

    def project(theta, omega, values, t):
        rows_theta, rows_omega = theta.reshape(1, n), omega.reshape(1, n)
        left = project_states(compiled.assemble_function, layout, np.array([float(t)]), rows_theta, rows_omega,
                              values)
        theta[...], omega[...] = rows_theta[0], rows_omega[0]
        return float(left)

    return accel, project, params
