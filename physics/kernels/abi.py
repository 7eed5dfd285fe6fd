"""The binary contract between generated code and the once-compiled kernels.

Generated code is straight-line arithmetic, one function per mechanism, compiled to machine code with the C
calling convention (``physics.codegen.native``) and taking raw pointers to float64 arrays. The integration
kernels (:mod:`physics.kernels`) are compiled once with the function's *address* as a plain integer argument and
call it through :func:`call_native`, so a new mechanism costs only the compilation of its own few functions,
never the integrators again, and a call from Python passes an int (numba's fastest argument type).

* ``assemble(theta, omega, params, A, b)``: fills ``A`` (k x k, row-major, zeroed by the caller) and all of
  ``b`` (k,) of ``A x = b`` at one state. ``params`` is the layout of docs/architecture.md.
* ``mass_and_force(theta, omega, params, M, force)``: the Lagrangian's mass matrix (n x n, row-major, zeroed by
  the caller) and force ``dL/dtheta + Q`` (n,), for the variational integrator (Lagrange only).
* ``double solve(A, b, x)``: for a sparse ``A`` (the DAE), Gaussian elimination unrolled over its structural
  non-zeros in a fixed order chosen at generation; returns the pivot ratio (the kernels fall back to a pivoted
  dense solve when it looks singular). Its address travels in the layout (``LAYOUT_SOLVE``).

A mechanism's ``layout`` (an int64 array, :func:`make_layout`) tells the kernels the sizes and where the
angular accelerations and the tip constraint's rows sit in ``x``.
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

_POINTER = types.CPointer(types.float64)
ASSEMBLE_SIGNATURE = types.void(_POINTER, _POINTER, _POINTER, _POINTER, _POINTER)
MASS_AND_FORCE_SIGNATURE = types.void(_POINTER, _POINTER, _POINTER, _POINTER, _POINTER)

# Slots of the layout array.
LAYOUT_LINKS = 0  # n
LAYOUT_UNKNOWNS = 1  # k
LAYOUT_PINNED = 2  # 1 when the tip is pinned
LAYOUT_TIP_ROW_X = 3  # row of A x = b that states the tip's x acceleration (pinned chains), else -1
LAYOUT_TIP_ROW_Y = 4
LAYOUT_SYMMETRIC = 5  # 1 when A is symmetric positive definite (Lagrange's mass matrix): solved by L D L^T
LAYOUT_SOLVE = 6  # address of the generated structured solve of a sparse A (the DAE), 0 when there is none
LAYOUT_THETA_DDOT = 7  # n entries: where each angular acceleration sits in x


def make_layout(
    n: int, n_unknowns: int, pinned: bool, tip_rows, theta_ddot_index, symmetric: bool, solve_address: int = 0
) -> np.ndarray:
    """The int64 layout array the kernels read (slots above)."""
    rows = tuple(tip_rows) if tip_rows is not None and len(tip_rows) else (-1, -1)
    head = [n, n_unknowns, int(bool(pinned)), int(rows[0]), int(rows[1]), int(bool(symmetric)), int(solve_address)]
    return np.array(head + [int(i) for i in theta_ddot_index], dtype=np.int64)


@intrinsic
def data_pointer(typingctx, array):
    """The address of a C-contiguous array's first element, as the pointer generated code takes.

    Only C-contiguous arrays type-check: a strided view would hand generated code the wrong elements."""
    if not isinstance(array, types.Array) or array.layout != "C":
        return None
    signature = types.CPointer(array.dtype)(array)

    def codegen(context, builder, sig, args):
        return context.make_array(array)(context, builder, args[0]).data

    return signature, codegen


@intrinsic
def call_native(typingctx, address, theta, omega, params, matrix, vector):
    """Call the generated function at ``address`` (an integer) with five float64 pointers.

    Both generated functions share this signature (``assemble`` and ``mass_and_force``). The address must come
    from :mod:`physics.codegen.native` (or a ``numba.cfunc`` of the same signature, in tests): it is trusted."""
    pointer = types.CPointer(types.float64)
    if not isinstance(address, types.Integer) or any(arg != pointer for arg in (theta, omega, params, matrix, vector)):
        return None
    signature = types.void(address, pointer, pointer, pointer, pointer, pointer)

    def codegen(context, builder, sig, args):
        double_pointer = ir.DoubleType().as_pointer()
        function_type = ir.FunctionType(ir.VoidType(), [double_pointer] * 5)
        function = builder.inttoptr(args[0], function_type.as_pointer())
        builder.call(function, args[1:])
        return context.get_dummy_value()

    return signature, codegen


@intrinsic
def call_native_solve(typingctx, address, matrix, vector, solution):
    """Call the generated structured ``solve`` at ``address``: ``double solve(double* A, double* b, double* x)``."""
    pointer = types.CPointer(types.float64)
    if not isinstance(address, types.Integer) or any(arg != pointer for arg in (matrix, vector, solution)):
        return None
    signature = types.float64(address, pointer, pointer, pointer)

    def codegen(context, builder, sig, args):
        double_pointer = ir.DoubleType().as_pointer()
        function_type = ir.FunctionType(ir.DoubleType(), [double_pointer] * 3)
        function = builder.inttoptr(args[0], function_type.as_pointer())
        return builder.call(function, args[1:])

    return signature, codegen
