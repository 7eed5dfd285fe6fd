"""A chain's whole compiled RK45/DOP853 run in one buffer: the IR driver's integration, then the samples' pass
over the rows it filled, both reading and writing one array made here.

:func:`integrate_and_sample` is :func:`physics.codegen.native_integrators.integrate` followed by
:func:`physics.codegen.native_samples.trajectory_samples`, with the same functions called with the same
arguments (the same bits), minus what the two did to hand arrays between them: the driver writes its samples
into the buffer and the samples' pass reads them there (no copy of the states, no address looked up for
``y_out``), and every other input (start, sample times, parameters, bars) is copied into the buffer once.
Seed case C spends about as long in the Python around its two native calls as the closed form spends on its
whole run; this is where a run's per-call work is cut (issue 25).
"""

from __future__ import annotations

import math

import numpy as np

from ..kernels.checks import check_arguments
from ..kernels.layout import LAYOUT_CONSTRAINTS, LAYOUT_UNKNOWNS
from .ir_shapes import integrator_scratch_length, samples_pass_scratch_length
from .native_integrators import layout_address
from .native_samples import SampleArrays, _plan, index_address

_NO_CONDITION = np.empty(0)


class RunBuffer:
    """Where each part of a run's buffer starts (in doubles) for one shape of run: worked out once per shape,
    not per call. ``[counts (3 int64), t_reached, y0, t_eval, params (the driver's copy, t written into it),
    the driver's scratch, y_out, the samples' arrays for every row, bars, params (the samples' copy), the
    samples' scratch]``."""

    __slots__ = ("y0", "t_eval", "params", "driver_scratch", "y_out", "samples", "bars", "sample_params",
                 "samples_scratch", "length")

    def __init__(self, method: str, n: int, k: int, r: int, samples: int, n_params: int, pinned: bool) -> None:
        self.y0 = 4
        self.t_eval = self.y0 + 2 * n
        self.params = self.t_eval + samples
        self.driver_scratch = self.params + n_params
        self.y_out = self.driver_scratch + integrator_scratch_length(method, 2 * n, r, k)
        self.samples = self.y_out + samples * 2 * n
        self.bars = self.samples + _plan(samples, n, k, pinned).length
        self.sample_params = self.bars + 4 * n
        self.samples_scratch = self.sample_params + n_params
        self.length = self.samples_scratch + samples_pass_scratch_length(n, k, r)


_buffers: dict[tuple, RunBuffer] = {}
MAX_BUFFERS = 64


def _buffer(method: str, n: int, k: int, r: int, samples: int, n_params: int, pinned: bool) -> RunBuffer:
    key = (method, n, k, r, samples, n_params, pinned)
    plan = _buffers.get(key)
    if plan is None:
        if len(_buffers) >= MAX_BUFFERS:
            _buffers.clear()
        plan = _buffers[key] = RunBuffer(method, n, k, r, samples, n_params, pinned)
    return plan


def integrate_and_sample(driver, samples_pass, assemble: int, integration_layout: np.ndarray, layout: np.ndarray,
                         y0: np.ndarray, t_eval: np.ndarray, params: np.ndarray, rtol, atol, alpha, beta, project,
                         max_steps, bars: np.ndarray, g, trace_bar, trace_along, trace_across, theta_ddot_index,
                         tip_reaction_index, method: str):
    """``(status, n_steps, n_rhs, t_reached, t, y, arrays)`` of a chain's run from ``y0`` over ``t_eval``:
    the driver's counts (as :func:`~physics.codegen.native_integrators.integrate` returns them), then the
    sample times, the states and the samples' :class:`~physics.codegen.native_samples.SampleArrays` of the rows
    that are finite throughout (all of them unless the run failed), views of one buffer.

    ``driver``: a ctypes function of the drivers' signature for ``method`` ("RK45" or "DOP853"; the system's
    specialised one or the generic one) with ``integration_layout``; ``samples_pass`` one of
    ``samples_pass``' signature with ``layout`` (the system's for one evaluation at a time). ``y0``,
    ``t_eval``, ``params`` and ``bars`` C-contiguous float64 (the caller's arrays, each only read); the other
    arguments as the two functions take them. No per-sample condition: the caller asks the kernels for that."""
    n_state, samples, n_params = y0.shape[0], t_eval.shape[0], params.shape[0]
    n = n_state // 2
    k, r = int(layout[LAYOUT_UNKNOWNS]), int(integration_layout[LAYOUT_CONSTRAINTS])
    pinned = len(tip_reaction_index) != 0
    if bars.shape != (4 * n,) or not 0 <= int(trace_bar) < n:
        raise ValueError(f"expected bars ({4 * n},) and a trace bar among the {n} bars")
    if samples == 0:
        raise ValueError("expected at least one sample time")
    accelerations, _held = index_address(theta_ddot_index, n, k, "acceleration")  # held until the calls return
    pin_force, _pin_held = index_address(tip_reaction_index, 2, k, "pin-force") if pinned else (0, None)
    at = _buffer(method, n, k, r, samples, n_params, pinned)
    values = np.empty(at.length)
    y_out = values[at.y_out:at.samples].reshape(samples, n_state)
    check_arguments(integration_layout, y0, float(t_eval[0]), float(t_eval[-1]), t_eval, params, y_out,
                    _NO_CONDITION)
    values[:4] = 0.0  # the driver's three int64 counts (zero: the same bits as 0.0) and t_reached
    values[at.y0:at.t_eval] = y0
    values[at.t_eval:at.params] = t_eval
    values[at.params:at.driver_scratch] = params
    values[at.bars:at.sample_params] = bars
    values[at.sample_params:at.samples_scratch] = params
    y_out.fill(np.nan)
    base = values.ctypes.data
    projecting = bool(project) and integration_layout[LAYOUT_CONSTRAINTS] != 0  # the kernel's _projecting
    status = driver(int(assemble), layout_address(integration_layout), base + 8 * at.y0, float(t_eval[0]),
                    float(t_eval[-1]), base + 8 * at.t_eval, samples, base + 8 * at.params, float(rtol), float(atol),
                    float(alpha), float(beta), int(projecting), int(max_steps), base + 8 * at.y_out,
                    base + 8 * at.driver_scratch, base, base + 24)
    if math.isfinite(float(y_out.sum())):  # physics.simulate.run's rule: the rows finite throughout
        rows = samples
    else:
        rows = int(np.count_nonzero(np.all(np.isfinite(y_out), axis=1)))
    samples_pass(int(assemble), layout_address(layout), rows, base + 8 * at.y_out, base + 8 * at.sample_params,
                 float(alpha), float(beta), base + 8 * at.bars, float(g), int(trace_bar), float(trace_along),
                 float(trace_across), accelerations, pin_force, int(pinned), base + 8 * at.samples,
                 base + 8 * at.samples_scratch)
    plan = _plan(rows, n, k, pinned)
    arrays = SampleArrays.__new__(SampleArrays)
    arrays.offsets, arrays.length = plan.offsets, plan.length
    start = at.samples
    for name, first, stop, shape in plan.views:
        setattr(arrays, name, values[start + first:start + stop].reshape(shape))
    n_steps, n_rhs, _ = values[:3].view(np.int64).tolist()
    return (int(status), n_steps, n_rhs, float(values[3]), values[at.t_eval:at.t_eval + rows], y_out[:rows],
            arrays)
