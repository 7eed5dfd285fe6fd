"""The samples' pass of :mod:`physics.codegen.samples_ir`, compiled once per process and called through ctypes.

Each function takes the arguments of the numba kernel it replaces (:mod:`physics.kernels.system`,
:mod:`physics.kernels.observables`) and fills the same outputs with the same bits. Arrays must be C-contiguous
float64 of the kernel's shapes: the callers (:mod:`physics.simulate.build`,
:class:`physics.codegen.cache.CompiledSystem`) build them so; a wrong one is a programming error and raises ``ValueError`` before any pointer is handed over.
"""

from __future__ import annotations

import ctypes
import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from ..kernels.layout import LAYOUT_CONSTRAINTS, LAYOUT_COORDINATES, LAYOUT_UNKNOWNS
from .ir_shapes import SAMPLES_PASS_NAME, SAMPLES_SOLVE_NAME
from .ir_shapes import samples_pass_scratch_length as pass_scratch_length
from .ir_shapes import samples_scratch_length as scratch_length
from .native_integrators import checked_address as _pointer
from .native_integrators import ctypes_functions, ir_builder, layout_address, specialised_engine, specialised_key

_P = ctypes.c_void_p
_I = ctypes.c_int64
_D = ctypes.c_double
_SIGNATURES = {
    "solve_states": ctypes.CFUNCTYPE(None, _I, _P, _I, _P, _P, _P, _D, _D, _P, _P, _P),
    "assemble_states": ctypes.CFUNCTYPE(None, _I, _P, _I, _P, _P, _P, _P, _P),
    "chain_observables": ctypes.CFUNCTYPE(None, _I, _I, _P, _P, _P, _P, _P, _P, _D, _I, _D, _D, _P, _P, _P, _P, _P),
    "chain_joint_reactions": ctypes.CFUNCTYPE(None, _I, _I, _P, _P, _P, _P, _P, _P, _D, _I, _P, _P),
    "samples_pass": ctypes.CFUNCTYPE(None, _I, _P, _I, _P, _P, _D, _D, _P, _D, _I, _D, _D, _P, _P, _I, _P, _P),
}
_BUILD = ir_builder("samples_ir", "samples_ir")


def _function(name: str):
    return ctypes_functions("samples", _BUILD, _SIGNATURES)[name]


def generic_samples_pass():
    """The ctypes function of the generic ``samples_pass`` (compiled or loaded once per process)."""
    return _function("samples_pass")


def specialised_solve(layout: np.ndarray, assemble: int, system_digest: str):
    """``(functions, engine)``: ``solve_states`` and ``samples_pass`` specialised for one system (its ``layout``,
    the one for one evaluation at a time), a :class:`SpecialisedSamples` of ctypes functions of the generic
    ones' signatures valid while ``engine`` lives; the same bits as the generic ones. Compiled at O2 or loaded
    from the machine-code cache."""
    shape, key = specialised_key("samples", layout, system_digest)

    def ir_text() -> str:
        from .specialised_ir import specialised_samples_ir  # noqa: PLC0415  (llvmlite.ir: only on a cache miss)

        return specialised_samples_ir(shape, system_digest)

    engine = specialised_engine(ir_text, layout, assemble,
                                system_digest, key)
    functions = SpecialisedSamples(_SIGNATURES["solve_states"](engine.get_function_address(SAMPLES_SOLVE_NAME)),
                                   _SIGNATURES["samples_pass"](engine.get_function_address(SAMPLES_PASS_NAME)))
    return functions, engine


def solve_states(assemble: int, layout, theta, omega, params, alpha, beta, x_out, cond_out) -> None:
    """:func:`physics.kernels.system.solve_states`: all unknowns ``x_out`` (K, k) and ``cond_out`` (K,)."""
    n, k, r = int(layout[LAYOUT_COORDINATES]), int(layout[LAYOUT_UNKNOWNS]), int(layout[LAYOUT_CONSTRAINTS])
    rows = theta.shape[0]
    scratch = np.empty(scratch_length(n, k, r))
    _function("solve_states")(
        int(assemble), _pointer(layout, (None,), np.int64), rows, _pointer(theta, (rows, n)),
        _pointer(omega, (rows, n)), _pointer(params, (None,)), float(alpha), float(beta), _pointer(x_out, (rows, k)),
        _pointer(cond_out, (rows,)), scratch.ctypes.data)


def assemble_states(assemble: int, layout, theta, omega, params, A_out, b_out) -> None:
    """:func:`physics.kernels.system.assemble_states`: ``A_out`` (K, k, k) and ``b_out`` (K, k)."""
    n, k = int(layout[LAYOUT_COORDINATES]), int(layout[LAYOUT_UNKNOWNS])
    rows = theta.shape[0]
    _function("assemble_states")(
        int(assemble), _pointer(layout, (None,), np.int64), rows, _pointer(theta, (rows, n)),
        _pointer(omega, (rows, n)), _pointer(params, (None,)), _pointer(A_out, (rows, k, k)),
        _pointer(b_out, (rows, k)))


def chain_observables(theta, omega, L, d, m, inertia, g, trace_bar, trace_along, trace_across, joints, trace_xy,
                      kinetic, potential, tip_velocity) -> None:
    """:func:`physics.kernels.observables.chain_observables`, the same arguments and outputs."""
    rows, n = theta.shape
    if not 0 <= int(trace_bar) < n:
        raise ValueError(f"trace_bar = {trace_bar}: must index one of the {n} bars")
    _function("chain_observables")(
        rows, n, _pointer(theta, (rows, n)), _pointer(omega, (rows, n)), _pointer(L, (n,)), _pointer(d, (n,)),
        _pointer(m, (n,)), _pointer(inertia, (n,)), float(g), int(trace_bar), float(trace_along),
        float(trace_across), _pointer(joints, (rows, n + 1, 2)), _pointer(trace_xy, (rows, 2)),
        _pointer(kinetic, (rows,)), _pointer(potential, (rows,)), _pointer(tip_velocity, (rows, 2)))


def chain_joint_reactions(theta, omega, theta_ddot, L, d, m, g, tip_reaction, joint_reactions) -> None:
    """:func:`physics.kernels.observables.chain_joint_reactions`; ``tip_reaction`` (K, 2), or (0, 2) for an open
    chain."""
    rows, n = theta.shape
    pinned = tip_reaction.shape[0] != 0
    _function("chain_joint_reactions")(
        rows, n, _pointer(theta, (rows, n)), _pointer(omega, (rows, n)), _pointer(theta_ddot, (rows, n)),
        _pointer(L, (n,)), _pointer(d, (n,)), _pointer(m, (n,)), float(g), int(pinned),
        _pointer(tip_reaction, (rows if pinned else 0, 2)), _pointer(joint_reactions, (rows, n, 2)))



SAMPLE_ARRAYS = ("theta", "omega", "joints", "trace_xy", "kinetic", "potential", "tip_velocity", "x", "cond",
                 "theta_ddot", "tip_reaction", "joint_reactions", "energy")


class SampleArrays:
    """What :func:`trajectory_samples` computes for a run's rows: consecutive views of one buffer, each
    C-contiguous, in the order of :data:`SAMPLE_ARRAYS` (``samples_pass`` of :mod:`physics.codegen.samples_ir`
    finds them at the same offsets); ``offsets[name]`` is where each starts in the buffer (in doubles),
    ``length`` where the last ends."""

    __slots__ = (*SAMPLE_ARRAYS, "offsets", "length")
    theta: np.ndarray
    omega: np.ndarray
    joints: np.ndarray
    trace_xy: np.ndarray
    kinetic: np.ndarray
    potential: np.ndarray
    tip_velocity: np.ndarray
    x: np.ndarray
    cond: np.ndarray
    theta_ddot: np.ndarray
    tip_reaction: np.ndarray
    joint_reactions: np.ndarray
    energy: np.ndarray  # kinetic + potential

    def __init__(self, rows: int, n: int, k: int, pinned: bool) -> None:
        """The offsets and the length only; :meth:`views` gives the arrays their storage."""
        plan = _plan(rows, n, k, pinned)
        self.offsets = plan.offsets
        self.length = plan.length

    @staticmethod
    def _shapes(rows: int, n: int, k: int, pinned: bool) -> tuple:
        return ((rows, n), (rows, n), (rows, n + 1, 2), (rows, 2), (rows,), (rows,), (rows, 2), (rows, k),
                (rows,), (rows, n), (rows if pinned else 0, 2), (rows, n, 2), (rows,))

    def views(self, rows: int, n: int, k: int, pinned: bool, values: np.ndarray) -> None:
        """Each array a view of ``values`` at its offset."""
        for name, start, stop, shape in _plan(rows, n, k, pinned).views:
            setattr(self, name, values[start:stop].reshape(shape))


class _Plan:
    """Where each of :class:`SampleArrays`' arrays sits in the buffer for one ``(rows, n, k, pinned)``: worked
    out once per shape (the app and an ensemble ask for the same shape run after run), not per call. After the
    arrays: the states, the bars, the parameters and the scratch (``inputs``: their offsets)."""

    __slots__ = ("inputs", "length", "offsets", "views")

    def __init__(self, rows: int, n: int, k: int, pinned: bool) -> None:
        self.offsets: dict[str, int] = {}
        views = []
        offset = 0
        for name, shape in zip(SAMPLE_ARRAYS, SampleArrays._shapes(rows, n, k, pinned), strict=True):
            self.offsets[name] = offset
            views.append((name, offset, offset + math.prod(shape), shape))
            offset += math.prod(shape)
        self.views = tuple(views)
        self.length = offset
        # (states, bars, params); the parameters' length is the caller's, so the scratch follows them
        self.inputs = (offset, offset + rows * 2 * n, offset + rows * 2 * n + 4 * n)


_plans: dict[tuple[int, int, int, bool], _Plan] = {}
MAX_PLANS = 64  # shapes remembered at once (a few sample counts of a few systems)


def _plan(rows: int, n: int, k: int, pinned: bool) -> _Plan:
    key = (rows, n, k, pinned)
    plan = _plans.get(key)
    if plan is None:
        if len(_plans) >= MAX_PLANS:
            _plans.clear()
        plan = _plans[key] = _Plan(rows, n, k, pinned)
    return plan


class SpecialisedSamples(NamedTuple):
    """A system's specialised samples' functions (:func:`specialised_solve`): ``solve_states`` and the whole
    pass ``samples_pass``, each of its generic function's signature."""

    solve: Callable
    samples_pass: Callable


_checked_indices: dict[int, tuple[np.ndarray, int, int]] = {}
MAX_INDICES = 64


def index_address(index, count: int, k: int, what: str) -> tuple[int, np.ndarray]:
    """``(address, array)``: ``index`` as ``count`` int64 positions among ``k`` unknowns (ValueError for another
    shape, IndexError for a position outside them, as ``np.take`` raises) and the address of its data, checked
    once per read-only array (a system's index arrays, :class:`physics.codegen.cache.CompiledSystem`), else at
    every call. The caller holds ``array`` until its native call returns (it may be a converted copy)."""
    entry = _checked_indices.get(id(index))
    if entry is not None and entry[0] is index and entry[2] == k:
        return entry[1], index
    array = np.ascontiguousarray(index, dtype=np.int64)
    if array.shape != (count,):
        raise ValueError(f"expected {count} {what} indices")
    if count and not (0 <= int(array.min()) and int(array.max()) < k):
        raise IndexError(f"{what} indices {array.tolist()} outside the {k} unknowns")
    address = int(array.ctypes.data)
    if array is index and not index.flags.writeable:
        if len(_checked_indices) >= MAX_INDICES:
            _checked_indices.clear()
        _checked_indices[id(index)] = (index, address, k)
    return address, array


def trajectory_samples(assemble: int, layout, y, params, alpha, beta, bars, g, trace_bar, trace_along,
                       trace_across, theta_ddot_index, tip_reaction_index, solve=None) -> SampleArrays:
    """The three passes :func:`physics.simulate.build.build_trajectory` makes over a run's samples
    (:func:`solve_states`, :func:`chain_observables`, :func:`chain_joint_reactions`: the same operations, the
    same bits) and the energies, in one native call (``samples_pass``: row by row, each bar's sine and cosine
    computed once per sample) writing every array into one buffer made here (the states, the bars and the
    parameters copied in too, so each pointer is the buffer's address plus an offset).

    ``y``: the states (rows, 2 n); ``bars``: ``[L, d, m, I]`` as one (4 n,) array; ``params`` 1-D;
    ``theta_ddot_index`` (n,) and ``tip_reaction_index`` ((2,) for a pinned chain, else empty): where the
    accelerations and the pin's force sit among the ``k`` unknowns. A pinned chain's ``tip_reaction`` is the
    pin's force at each sample, the input of the joint reactions. ``solve``: the system's
    :class:`SpecialisedSamples` (:func:`specialised_solve`; default the generic functions)."""
    n, k, r = int(layout[LAYOUT_COORDINATES]), int(layout[LAYOUT_UNKNOWNS]), int(layout[LAYOUT_CONSTRAINTS])
    rows = len(y)
    if (type(y) is np.ndarray and type(bars) is np.ndarray and type(params) is np.ndarray  # the usual call
            and y.shape == (rows, 2 * n) and bars.shape == (4 * n,) and params.ndim == 1):
        pass
    elif np.shape(y) != (rows, 2 * n) or np.shape(bars) != (4 * n,) or np.ndim(params) != 1:
        raise ValueError(f"expected states (rows, {2 * n}), bars ({4 * n},) and a 1-D params")
    if not 0 <= int(trace_bar) < n:
        raise ValueError(f"trace_bar = {trace_bar}: must index one of the {n} bars")
    pinned = len(tip_reaction_index) != 0
    accelerations, _held = index_address(theta_ddot_index, n, k, "acceleration")
    pin_force, _pin_held = index_address(tip_reaction_index, 2, k, "pin-force") if pinned else (0, None)
    plan = _plan(rows, n, k, pinned)
    at_states, at_bars, at_params = plan.inputs
    at_scratch = at_params + len(params)
    values = np.empty(at_scratch + pass_scratch_length(n, k, r))
    values[at_states:at_bars].reshape(rows, 2 * n)[...] = y  # a copy: float64 whatever y's type, C-contiguous
    values[at_bars:at_params] = bars
    values[at_params:at_scratch] = params
    arrays = SampleArrays.__new__(SampleArrays)
    arrays.offsets, arrays.length = plan.offsets, plan.length
    for name, start, stop, shape in plan.views:
        setattr(arrays, name, values[start:stop].reshape(shape))
    base = values.ctypes.data
    (_function("samples_pass") if solve is None else solve.samples_pass)(
        int(assemble), layout_address(layout), rows, base + 8 * at_states, base + 8 * at_params, float(alpha),
        float(beta), base + 8 * at_bars, float(g), int(trace_bar), float(trace_along), float(trace_across),
        accelerations, pin_force, int(pinned), base, base + 8 * at_scratch)
    return arrays
