"""A formulation's linear system ``A x = b`` as machine code: the sympy expressions of a mechanism's matrix and
right-hand side written as LLVM IR by :mod:`physics.codegen.llvm_ir` and compiled in this process by
:mod:`physics.codegen.native`, as the chains' generated code is.

Between samples the integrator needs the accelerations thousands of times a second; numpy spends tens of
microseconds per call on the overhead of small arrays, machine code a microsecond on the arithmetic itself.
The function writes only the structural non-zeros of ``A`` into a buffer zeroed once, so each call costs the
arithmetic, one ctypes call and numpy's dense solve. Compiling takes a fraction of a second per mechanism and
is done when a run first integrates (a mechanism its motors fully determine never needs it).
"""

from __future__ import annotations

import ctypes
import threading
from types import SimpleNamespace

import numpy as np
import sympy as sp

from ..codegen import llvm_ir
from ..codegen.native import NativeModule

_SIGNATURE = ctypes.CFUNCTYPE(None, *([ctypes.c_void_p] * 5))


class NativeSystem:
    """``system(x, v, params) -> (A, b)`` for the symbols ``coordinates``, ``rates`` and ``parameters`` the
    expressions ``matrix`` (rows x columns) and ``vector`` (rows,) are written in. The returned arrays are
    buffers of the calling thread, reused by its next call: use them before calling again. (One system serves
    every run of its mechanism in the process, so concurrent runs in threads each get their own buffers.)"""

    def __init__(self, coordinates, rates, parameters, matrix: sp.Matrix, vector: sp.Matrix) -> None:
        rows, columns = matrix.shape
        entries: list[tuple[tuple, sp.Expr]] = [((row, column), matrix[row, column]) for row in range(rows)
                                                for column in range(columns) if matrix[row, column] != 0]
        entries += [(("v", row), vector[row]) for row in range(rows)]
        symbols = SimpleNamespace(theta=list(coordinates), omega=list(rates), params=list(parameters))
        function = llvm_ir.function_ir("assemble", symbols, entries, columns, "A", "b")
        self._module = NativeModule(llvm_ir.module_ir([function]))  # owns the machine code
        self._function = _SIGNATURE(self._module.addresses["assemble"])
        self._shape = (rows, columns, len(coordinates), len(rates), len(parameters))
        self._local = threading.local()

    def _buffers(self) -> _Buffers:
        buffers = getattr(self._local, "buffers", None)
        if buffers is None:
            buffers = self._local.buffers = _Buffers(*self._shape)
        return buffers

    def __call__(self, x, v, parameters) -> tuple[np.ndarray, np.ndarray]:
        buffers = self._buffers()
        buffers.x[: len(x)] = x
        buffers.v[: len(v)] = v
        buffers.p[: len(parameters)] = parameters
        self._function(*buffers.addresses)
        return buffers.matrix, buffers.vector


class _Buffers:
    """One thread's arrays for a system: the state and parameters in, ``A`` (zeroed once: only its structural
    non-zeros are ever written) and ``b`` out, and their addresses for the call."""

    def __init__(self, rows: int, columns: int, coordinates: int, rates: int, parameters: int) -> None:
        self.matrix = np.zeros((rows, columns))
        self.vector = np.zeros(rows)
        self.x = np.zeros(max(coordinates, 1))
        self.v = np.zeros(max(rates, 1))
        self.p = np.zeros(max(parameters, 1))
        self.vector_storage = self.vector if rows else np.zeros(1)
        self.addresses = [array.ctypes.data for array in (self.x, self.v, self.p, self.matrix, self.vector_storage)]
