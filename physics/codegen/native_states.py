"""The projection's and the per-sample loops of :mod:`physics.codegen.projection_ir`, compiled once per process
(the machine code kept in the cache) and called through ctypes.

Each function takes the arguments of the numba kernel it replaces (:func:`physics.kernels.projection.project_states`,
:func:`physics.kernels.system.native_states`) and fills the same outputs with the same bits, so that a driven
mechanism's position analysis and every mechanism's samples need no numba compilation. Arrays are checked
before any pointer is handed over (a wrong one is a programming error: ``ValueError``).
"""

from __future__ import annotations

import ctypes

import numpy as np

from ..kernels.layout import LAYOUT_CONSTRAINTS, LAYOUT_COORDINATES
from .ir_shapes import states_scratch_length as scratch_length
from .native_integrators import checked_address as _pointer
from .native_integrators import ctypes_functions, ir_builder

_P = ctypes.c_void_p
_I = ctypes.c_int64
_SIGNATURES = {
    "project_states": ctypes.CFUNCTYPE(ctypes.c_double, _P, _I, _P, _P, _P, _P, _P),
    "native_states": ctypes.CFUNCTYPE(None, _I, _P, _I, _P, _P, _P, _P, _I, _I, _P, _P),
}
_BUILD = ir_builder("projection_ir", "states_ir")


def _function(name: str):
    return ctypes_functions("states", _BUILD, _SIGNATURES)[name]


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
