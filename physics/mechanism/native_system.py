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
from types import SimpleNamespace

import numpy as np
import sympy as sp

from ..codegen import llvm_ir
from ..codegen.native import NativeModule

_SIGNATURE = ctypes.CFUNCTYPE(None, *([ctypes.c_void_p] * 5))


class NativeSystem:
    """``system(x, v, params) -> (A, b)`` for the symbols ``coordinates``, ``rates`` and ``parameters`` the
    expressions ``matrix`` (rows x columns) and ``vector`` (rows,) are written in. The returned arrays are
    buffers reused by the next call: use them before calling again."""

    def __init__(self, coordinates, rates, parameters, matrix: sp.Matrix, vector: sp.Matrix) -> None:
        rows, columns = matrix.shape
        entries: list[tuple[tuple, sp.Expr]] = [((row, column), matrix[row, column]) for row in range(rows)
                                                for column in range(columns) if matrix[row, column] != 0]
        entries += [(("v", row), vector[row]) for row in range(rows)]
        symbols = SimpleNamespace(theta=list(coordinates), omega=list(rates), params=list(parameters))
        function = llvm_ir.function_ir("assemble", symbols, entries, columns, "A", "b")
        self._module = NativeModule(llvm_ir.module_ir([function]))  # owns the machine code
        self._function = _SIGNATURE(self._module.addresses["assemble"])
        self.matrix = np.zeros((rows, columns))
        self.vector = np.zeros(max(rows, 1))
        self._x = np.zeros(max(len(coordinates), 1))
        self._v = np.zeros(max(len(rates), 1))
        self._p = np.zeros(max(len(parameters), 1))
        self._addresses = [array.ctypes.data for array in (self._x, self._v, self._p, self.matrix, self.vector)]

    def __call__(self, x, v, parameters) -> tuple[np.ndarray, np.ndarray]:
        self._x[: len(x)] = x
        self._v[: len(v)] = v
        self._p[: len(parameters)] = parameters
        self._function(*self._addresses)
        return self.matrix, self.vector
