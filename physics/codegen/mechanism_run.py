"""A mechanism's compiled RK45/DOP853 run and every sample's observables in one buffer: the IR driver's
integration, then over the rows it filled the solve, the kinematics (a tree formulation's), the plain matrices
(when asked for) and :mod:`physics.codegen.mechanism_observables_ir`'s points, energies and reaction rows.

It is :func:`physics.codegen.native_integrators.integrate` followed by
:func:`physics.codegen.mechanism_samples.mechanism_samples` (without the held constraints), the same functions
called with the same arguments (the same bits), minus what the two did to hand arrays between them: every
input is copied into one array made here, whose parts' offsets are worked out once per shape of run, and each
output is a view of it. The chain's run on the mechanism engine (:mod:`physics.simulate.mechanism_route`)
spends most of a short run's time in the Python around its native calls (issue 24).
"""

from __future__ import annotations

import math
import threading

import numpy as np

from ..kernels.checks import check_arguments
from ..kernels.layout import LAYOUT_CONSTRAINTS, LAYOUT_COORDINATES, LAYOUT_UNKNOWNS
from .ir_shapes import integrator_scratch_length, samples_scratch_length
from .mechanism_observables import ObservablesPlan, observables_function, scratch_length
from .native_integrators import layout_address

_NO_CONDITION = np.empty(0)


class _Offsets:
    """Where each part of a run's buffer starts (in doubles) for one shape of run: ``[counts (3 int64),
    t_reached, y0, t_eval, params (the driver's copy), the driver's scratch, y_out, x, v, zeros (the kinematics'
    times), params (the solve's copy), params (the kinematics' copy: its time slot is written), the solve's
    scratch, full, condition, d pose, pose|bias, matrices, right-hand sides, points, velocities, energies,
    reactions, the observables' scratch]``; the per-sample parts sized for every sample."""

    def __init__(self, method: str, n: int, k: int, r: int, r_solve: int, samples: int, n_params: int, size: int,
                 matrices: bool, count: int, reactions: int, bodies: int) -> None:
        self.y0 = 4
        self.t_eval = self.y0 + 2 * n
        self.params = self.t_eval + samples
        self.driver_scratch = self.params + n_params
        self.y_out = self.driver_scratch + integrator_scratch_length(method, 2 * n, r, k)
        self.x = self.y_out + samples * 2 * n
        self.v = self.x + samples * n
        self.zeros = self.v + samples * n
        self.solve_params = self.zeros + samples
        self.kinematics_params = self.solve_params + n_params
        self.solve_scratch = self.kinematics_params + n_params
        self.full = self.solve_scratch + samples_scratch_length(n, k, r_solve)
        self.condition = self.full + samples * k
        self.pose_jacobian = self.condition + samples
        self.pose_vector = self.pose_jacobian + samples * size * n
        self.matrices = self.pose_vector + samples * 2 * size
        self.rhs = self.matrices + samples * k * k * matrices
        self.points = self.rhs + samples * k * matrices
        self.velocities = self.points + samples * 2 * count
        self.energies = self.velocities + samples * 2 * count
        self.reactions = self.energies + 3 * samples
        self.scratch = self.reactions + samples * reactions
        self.length = self.scratch + scratch_length(bodies)


class _Run:
    """What a run of one system, plan and shape reads besides its inputs, worked out on its first call: the
    sizes, the buffer's offsets, the functions' and arrays' addresses (each look-up costs a microsecond or two a
    call). Holds the system, its layout and the plan, so their ids are not reused while it is remembered."""

    def __init__(self, compiled, integration_layout: np.ndarray, plan: ObservablesPlan, method: str, samples: int,
                 n_params: int, matrices: bool) -> None:
        from .mechanism_samples import _assemble_function, _functions  # noqa: PLC0415

        layout = compiled.layout
        self.compiled, self.integration_layout, self.plan = compiled, integration_layout, plan
        self.n, self.k = int(layout[LAYOUT_COORDINATES]), int(layout[LAYOUT_UNKNOWNS])
        self.constraints = int(integration_layout[LAYOUT_CONSTRAINTS])
        self.size = compiled.pose_size if plan.tree else 0
        if samples == 0 or plan.n != self.n or plan.unknowns != self.k or (plan.tree and not self.size):
            raise ValueError("expected at least one sample time and a plan that fits the system")
        self.samples = samples
        self.at = _Offsets(method, self.n, self.k, self.constraints, int(layout[LAYOUT_CONSTRAINTS]), samples,
                           n_params, self.size, matrices, plan.count, plan.reactions, plan.bodies)
        self.assemble = int(compiled.assemble_function)
        self.address = layout_address(layout)
        self.integration_address = layout_address(integration_layout)
        self.kinematics = int(compiled._native("kinematics")) if self.size else 0
        self.kinematics_call = _functions()[1]
        self.assemble_call = _assemble_function()
        self.observables_call = observables_function()
        self.tree = int(plan.tree)


_lock = threading.Lock()
_runs: dict[tuple, _Run] = {}
MAX_SHAPES = 64


class RunObservables:
    """The samples' arrays of :func:`integrate_and_observe`, views of its buffer for the ``T`` rows filled:
    ``full (T, k)`` and ``condition (T,)`` of the solve, ``matrices (T, k, k)`` (``(0, k, k)`` unless asked
    for), ``points`` and ``velocities (T, P, 2)``, ``energies (3, T)`` (kinetic, potential, total) and
    ``reactions (T, R)`` of the plan."""

    __slots__ = ("full", "condition", "matrices", "points", "velocities", "energies", "reactions")
    full: np.ndarray
    condition: np.ndarray
    matrices: np.ndarray
    points: np.ndarray
    velocities: np.ndarray
    energies: np.ndarray
    reactions: np.ndarray


def integrate_and_observe(driver, solve, compiled, integration_layout: np.ndarray, y0: np.ndarray,
                          t_eval: np.ndarray, params: np.ndarray, rtol, atol, alpha, beta, project, max_steps,
                          method: str, plan: ObservablesPlan, g: float, matrices: bool):
    """``(status, n_steps, n_rhs, t_reached, t, y, observables)`` of a run of ``compiled`` from ``y0`` over
    ``t_eval``: the driver's counts (as :func:`~physics.codegen.native_integrators.integrate` returns them),
    the sample times and states of the rows finite throughout (all unless the run failed) and their
    :class:`RunObservables`.

    ``driver``: a ctypes function of the drivers' signature for ``method`` ("RK45" or "DOP853"; the system's
    specialised one or the generic one) with ``integration_layout`` (the system's own, no projection weights);
    ``solve`` one of ``solve_states``' signature (specialised or generic) with the system's ``layout``; the
    solve has the Baumgarte gains ``alpha``, ``beta`` as the run's right-hand side. ``plan``: what the
    observables are (its ``tree``: the kinematics is evaluated for Newton's law on the bodies); ``matrices``:
    also each sample's plain matrix (a condition number's). ``y0``, ``t_eval`` and ``params`` C-contiguous
    float64 (only read)."""
    key = (id(compiled), id(integration_layout), id(plan), method, t_eval.shape[0], params.shape[0], bool(matrices))
    entry = _runs.get(key)
    if entry is None or entry.compiled is not compiled or entry.integration_layout is not integration_layout \
            or entry.plan is not plan:
        entry = _Run(compiled, integration_layout, plan, method, t_eval.shape[0], params.shape[0], bool(matrices))
        with _lock:
            if len(_runs) >= MAX_SHAPES:
                _runs.clear()
            _runs[key] = entry
    n, k, samples, at = entry.n, entry.k, entry.samples, entry.at
    values = np.empty(at.length)
    y_out = values[at.y_out:at.x].reshape(samples, 2 * n)
    check_arguments(integration_layout, y0, float(t_eval[0]), float(t_eval[-1]), t_eval, params, y_out,
                    _NO_CONDITION)
    values[:4] = 0.0  # the driver's three int64 counts (zero: the same bits as 0.0) and t_reached
    values[at.y0:at.t_eval] = y0
    values[at.t_eval:at.params] = t_eval
    values[at.params:at.driver_scratch] = params
    values[at.solve_params:at.kinematics_params] = params
    values[at.kinematics_params:at.solve_scratch] = params
    y_out.fill(np.nan)
    base = values.ctypes.data
    assemble = entry.assemble
    status = driver(assemble, entry.integration_address, base + 8 * at.y0, float(t_eval[0]), float(t_eval[-1]),
                    base + 8 * at.t_eval, samples, base + 8 * at.params, float(rtol), float(atol), float(alpha),
                    float(beta), int(bool(project) and entry.constraints != 0),  # the kernel's _projecting
                    int(max_steps), base + 8 * at.y_out, base + 8 * at.driver_scratch, base, base + 24)
    if math.isfinite(float(y_out.sum())):  # physics.simulate.run's rule: the rows finite throughout
        rows = samples
    else:
        rows = int(np.count_nonzero(np.all(np.isfinite(y_out), axis=1)))
    states = y_out[:rows]
    values[at.x:at.x + rows * n].reshape(rows, n)[:] = states[:, :n]
    values[at.v:at.v + rows * n].reshape(rows, n)[:] = states[:, n:]
    values[at.zeros:at.zeros + rows] = 0.0
    address = entry.address
    solve(assemble, address, rows, base + 8 * at.x, base + 8 * at.v, base + 8 * at.solve_params, float(alpha),
          float(beta), base + 8 * at.full, base + 8 * at.condition, base + 8 * at.solve_scratch)
    size = entry.size
    if size and rows:
        entry.kinematics_call(entry.kinematics, address, rows, base + 8 * at.zeros, base + 8 * at.x, base + 8 * at.v,
                              base + 8 * at.kinematics_params, size * n, 2 * size, base + 8 * at.pose_jacobian,
                              base + 8 * at.pose_vector)
    if matrices and rows:
        entry.assemble_call(assemble, address, rows, base + 8 * at.x, base + 8 * at.v, base + 8 * at.solve_params,
                            base + 8 * at.matrices, base + 8 * at.rhs)
    shape, indices, constants = plan.addresses
    entry.observables_call(shape, indices, constants, rows, entry.tree, float(g), base + 8 * at.x, base + 8 * at.v,
                           n, base + 8 * at.full, base + 8 * at.pose_jacobian, base + 8 * at.pose_vector,
                           base + 8 * at.scratch, base + 8 * at.points, base + 8 * at.velocities,
                           base + 8 * at.energies, base + 8 * at.reactions)
    count, reactions = plan.count, plan.reactions
    out = RunObservables()
    out.full = values[at.full:at.full + rows * k].reshape(rows, k)
    out.condition = values[at.condition:at.condition + rows]
    out.matrices = values[at.matrices:at.matrices + rows * k * k * matrices].reshape(rows * matrices, k, k)
    out.points = values[at.points:at.points + rows * 2 * count].reshape(rows, count, 2)
    out.velocities = values[at.velocities:at.velocities + rows * 2 * count].reshape(rows, count, 2)
    out.energies = values[at.energies:at.energies + 3 * rows].reshape(3, rows)
    out.reactions = values[at.reactions:at.reactions + rows * reactions].reshape(rows, reactions)
    n_steps, n_rhs, _ = values[:3].view(np.int64).tolist()
    return int(status), n_steps, n_rhs, float(values[3]), values[at.t_eval:at.t_eval + rows], states, out
