"""The projection's and the per-sample loops of :mod:`physics.codegen.projection_ir`, compiled once per process
(the machine code kept in the cache) and called through ctypes.

Each function takes the arguments of the numba kernel it replaces (:func:`physics.kernels.projection.project_states`,
:func:`physics.kernels.system.native_states`) and fills the same outputs with the same bits, so that a driven
mechanism's position analysis and every mechanism's samples need no numba compilation; :func:`driven_sequence`
runs that position analysis row after row in one call, as a loop of :func:`project_states` calls would.
Arrays are checked before any pointer is handed over (a wrong one is a programming error: ``ValueError``).
"""

from __future__ import annotations

import ctypes
import time

import numpy as np

from ..kernels.layout import LAYOUT_CONSTRAINTS, LAYOUT_COORDINATES
from .ir_shapes import states_scratch_length as scratch_length
from .machine_code import compile_module, sources_digest
from .native_integrators import SPECIALISED_VARIANT, _compiled, _lock, ctypes_functions, ir_builder
from .native_integrators import checked_address as _pointer

_P = ctypes.c_void_p
_I = ctypes.c_int64
_SIGNATURES = {
    "project_states": ctypes.CFUNCTYPE(ctypes.c_double, _P, _I, _P, _P, _P, _P, _P),
    "native_states": ctypes.CFUNCTYPE(None, _I, _P, _I, _P, _P, _P, _P, _I, _I, _P, _P),
}
_BUILD = ir_builder("projection_ir", "states_ir")
_DRIVEN_SIGNATURE = ctypes.CFUNCTYPE(ctypes.c_int64, _P, _I, _I, ctypes.c_double, _P, _P, _P, _P, _P)
_driven: list = []  # (ctypes function, the engine that owns its machine code), once made


def _function(name: str):
    return ctypes_functions("states", _BUILD, _SIGNATURES)[name]


def _driven_function():
    """The ctypes function of ``driven_sequence`` (:func:`physics.codegen.projection_ir.driven_ir`), its module
    compiled through LLVM's O2 pipeline at code generation level 2, as the drivers specialised for a system are
    (:data:`~physics.codegen.native_integrators.SPECIALISED_VARIANT`), or loaded from the machine-code cache
    under its own key and the codegen sources' digest (the same trust rules): once per installation, about
    0.5 s, for a sequence about 4.5 times as fast as the states module's short compilation makes it (Jansen's
    leg, 601 samples: 6 ms against 28). No pass of that pipeline reassociates or contracts floating-point
    arithmetic (the IR has no fast-math flags), so the bits are those of :func:`project_states` row by row."""
    if not _driven:
        from . import native  # noqa: PLC0415  (its O2 pipeline and target machine, as for the generated systems)

        start = time.perf_counter()
        with _lock, native._lock:  # LLVM's global context is not to be shared between two compilations at once
            if not _driven:
                engine = compile_module(ir_builder("projection_ir", "driven_ir"), SPECIALISED_VARIANT,
                                        native._optimize, native._target_machine,
                                        key=f"driven_sequence\n{sources_digest()}")
                _driven.append((_DRIVEN_SIGNATURE(engine.get_function_address("driven_sequence")), engine))
                _compiled["seconds"] = _compiled.get("seconds", 0.0) + time.perf_counter() - start
    return _driven[0][0]


def project_states(layout, t, theta, omega, params) -> float:
    """:func:`physics.kernels.projection.project_states`: rows of ``theta``, ``omega`` (K, n) projected in place
    at times ``t`` (K,) (a copy of ``params`` takes each time); the largest position residual left."""
    n, r = int(layout[LAYOUT_COORDINATES]), int(layout[LAYOUT_CONSTRAINTS])
    rows = theta.shape[0]
    own_params = np.array(params, dtype=np.float64)  # the time slot is written
    scratch = np.empty(scratch_length(n, r))
    return float(_function("project_states")(
        _pointer(layout, (None,), np.int64), rows, _pointer(t, (rows,)), _pointer(theta, (rows, n)),
        _pointer(omega, (rows, n)), _pointer(own_params, (None,)), scratch.ctypes.data))


def driven_sequence(layout, t, xs, vs, params, start: int, tolerance: float) -> int:
    """A driven mechanism's position analysis from row ``start`` (>= 1) of ``xs``, ``vs`` (K, n) at times ``t``
    (K,) on, in one call: each row ``k`` written as row ``k - 1`` moved on by its velocity (``xs[k-1] +
    vs[k-1] (t[k] - t[k-1])``, velocity ``vs[k-1]``) and projected as :func:`project_states` projects it (a copy
    of ``params`` takes each time), until a row whose residual (as :func:`project_states` returns it) is not
    below ``tolerance`` or whose position is not finite: that row's index is returned (its contents are the
    failed attempt, for the caller to replace), or K when every row was kept. One call instead of a
    :func:`project_states` call per row: the per-row Python and argument checks were most of a driven run."""
    n = int(layout[LAYOUT_COORDINATES])
    rows = xs.shape[0] if isinstance(xs, np.ndarray) and xs.ndim == 2 else -1
    if not 1 <= int(start):
        raise ValueError(f"start must be at least 1 (row start - 1 is the first prediction's), not {start}")
    addresses = (_pointer(layout, (None,), np.int64), _pointer(t, (rows,)), _pointer(xs, (rows, n)),
                 _pointer(vs, (rows, n)))
    if int(start) >= rows:
        return rows
    own_params = np.array(params, dtype=np.float64)  # the time slot is written
    scratch = np.empty(scratch_length(n, int(layout[LAYOUT_CONSTRAINTS])))
    return int(_driven_function()(
        addresses[0], rows, int(start), float(tolerance), addresses[1], addresses[2], addresses[3],
        _pointer(own_params, (None,)), scratch.ctypes.data))


def native_states(function: int, layout, t, theta, omega, params, matrix_out, vector_out) -> None:
    """:func:`physics.kernels.system.native_states`: the generated ``function`` (``constraints``, ``kinematics``)
    at each row of ``theta``, ``omega`` (K, n) and time ``t`` (K,): its matrix into ``matrix_out`` (K, rows,
    columns; zeroed first) and its vector into ``vector_out`` (K, m)."""
    n = int(layout[LAYOUT_COORDINATES])
    rows = theta.shape[0]
    if matrix_out.ndim != 3 or vector_out.ndim != 2:
        raise ValueError("matrix_out must be (K, rows, columns) and vector_out (K, m)")
    own_params = np.array(params, dtype=np.float64)  # the time slot is written
    _function("native_states")(
        int(function), _pointer(layout, (None,), np.int64), rows, _pointer(t, (rows,)), _pointer(theta, (rows, n)),
        _pointer(omega, (rows, n)), _pointer(own_params, (None,)), matrix_out.shape[1] * matrix_out.shape[2],
        vector_out.shape[1], _pointer(matrix_out, (rows, None, None)), _pointer(vector_out, (rows, None)))
