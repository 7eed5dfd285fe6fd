"""The samples' pass of :mod:`physics.codegen.samples_ir`, compiled once per process and called through ctypes.

Each function takes the arguments of the numba kernel it replaces (:mod:`physics.kernels.system`,
:mod:`physics.kernels.observables`) and fills the same outputs with the same bits. Arrays must be C-contiguous
float64 of the kernel's shapes: the callers (:mod:`physics.simulate.build`,
:class:`physics.codegen.cache.CompiledSystem`) build them so; a wrong one is a programming error and raises ``ValueError`` before any pointer is handed over.
"""

from __future__ import annotations

import ctypes

import numpy as np

from ..kernels.layout import LAYOUT_CONSTRAINTS, LAYOUT_COORDINATES, LAYOUT_UNKNOWNS
from .ir_shapes import SAMPLES_FUNCTION_NAMES as FUNCTION_NAMES
from .ir_shapes import samples_scratch_length as scratch_length
from .native_integrators import compile_functions

_P = ctypes.c_void_p
_I = ctypes.c_int64
_D = ctypes.c_double
_SIGNATURES = {
    "solve_states": ctypes.CFUNCTYPE(None, _I, _P, _I, _P, _P, _P, _D, _D, _P, _P, _P),
    "assemble_states": ctypes.CFUNCTYPE(None, _I, _P, _I, _P, _P, _P, _P, _P),
    "chain_observables": ctypes.CFUNCTYPE(None, _I, _I, _P, _P, _P, _P, _P, _P, _D, _I, _D, _D, _P, _P, _P, _P, _P),
    "chain_joint_reactions": ctypes.CFUNCTYPE(None, _I, _I, _P, _P, _P, _P, _P, _P, _D, _I, _P, _P),
}
_functions: dict = {}


def samples_ir() -> str:
    """:func:`physics.codegen.samples_ir.samples_ir`, imported on a machine-code cache miss only (a warm process
    loads the machine code and never needs the IR builders or ``llvmlite.ir``)."""
    from .samples_ir import samples_ir as build  # noqa: PLC0415  (llvmlite.ir: only on a cache miss)

    return build()


def _function(name: str):
    if name not in _functions:
        addresses = compile_functions("samples", samples_ir, FUNCTION_NAMES)
        for each in FUNCTION_NAMES:
            _functions.setdefault(each, _SIGNATURES[each](addresses[each]))
    return _functions[name]


def _pointer(array: np.ndarray, shape: tuple, dtype=np.float64) -> int:
    """The address of ``array``'s data after checking it is what the generated code reads: C-contiguous, of
    ``dtype`` and of ``shape`` (None: any length on that axis)."""
    if not (isinstance(array, np.ndarray) and array.dtype == dtype and array.flags.c_contiguous
            and array.ndim == len(shape) and all(want is None or have == want
                                                 for have, want in zip(array.shape, shape, strict=True))):
        raise ValueError(f"expected a C-contiguous {np.dtype(dtype).name} array of shape {shape}")
    return array.ctypes.data


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
