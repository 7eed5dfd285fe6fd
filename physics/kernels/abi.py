"""The binary contract between generated code and the once-compiled kernels.

Generated code is straight-line arithmetic, one function per mechanism, compiled to machine code with the C
calling convention (``physics.codegen.native``) and taking raw pointers to float64 arrays. The integration
kernels (:mod:`physics.kernels`) are compiled once with the function's *address* as a plain integer argument and
call it through :func:`call_native`, so a new mechanism costs only the compilation of its own few functions,
never the integrators again, and a call from Python passes an int (numba's fastest argument type).

* ``assemble(theta, omega, params, A, b)``: fills ``A`` (k x k, row-major, zeroed by the caller) and all of
  ``b`` (k,) of ``A x = b`` at one state. ``params`` is the mechanism's parameter vector (docs/architecture.md).
* ``mass_and_force(theta, omega, params, M, force)``: the Lagrangian's mass matrix (n x n, row-major, zeroed by
  the caller) and force ``dL/dtheta + Q`` (n,), for the variational integrator (Lagrange only).
* ``constraints(theta, omega, params, J, v)``: the constraints the integrator holds (a pinned chain's tip, a
  mechanism's closures and speed motors): their Jacobian ``J`` (r x n, row-major, zeroed by the caller) and
  ``v = [phi (r), phi_dot (r)]`` with ``phi_dot = J omega + d phi / d t``. Baumgarte terms, projection and the
  loop's singularity test are written once in the kernels on top of it.
* ``double solve(A, b, x)``: for a sparse ``A`` (the DAE), Gaussian elimination unrolled over its structural
  non-zeros in a fixed order chosen at generation; returns the pivot ratio (the kernels fall back to a pivoted
  dense solve when it looks singular). Its address travels in the layout (``LAYOUT_SOLVE``).
* ``double rhs(double* y, double* params, double* dydt)``: with ``solve``,
  the ODE's right-hand side ``[omega, theta_ddot]`` at ``y = [theta, omega]``, ``assemble`` and ``solve`` in one
  function (no matrix in memory); returns ``solve``'s pivot ratio. Address in ``LAYOUT_RHS``, 0 without.

A mechanism's ``layout`` (an int64 array, :func:`make_layout`) tells the kernels the sizes, where the
coordinates' accelerations and the constraints' rows sit in ``x``, where ``t`` goes in ``params``, and the
addresses of the optional functions.
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

_POINTER = types.CPointer(types.float64)
ASSEMBLE_SIGNATURE = types.void(_POINTER, _POINTER, _POINTER, _POINTER, _POINTER)
MASS_AND_FORCE_SIGNATURE = types.void(_POINTER, _POINTER, _POINTER, _POINTER, _POINTER)

# Slots of the layout array. The kernels know nothing of chains or bodies: only sizes, where the coordinates'
# accelerations and the constraints' rows sit, and the addresses of the generated functions.
LAYOUT_COORDINATES = 0  # n: coordinates (the state is [theta, omega], 2 n)
LAYOUT_UNKNOWNS = 1  # k: unknowns of A x = b (accelerations, and multipliers or reactions)
LAYOUT_CONSTRAINTS = 2  # r: constraints phi(theta, t) = 0 the integrator holds (0: an open tree, no closure)
LAYOUT_TIME = 3  # index of t in params, written by the integrators before each evaluation; -1: nothing uses t
LAYOUT_SYMMETRIC = 4  # 1 when A is symmetric positive definite (Lagrange's mass matrix): solved by L D L^T
LAYOUT_SOLVE = 5  # address of the generated structured solve of a sparse A (the DAE), 0 when there is none
LAYOUT_CONSTRAINT_FUNCTION = 6  # address of the generated constraints(theta, omega, params, J, v), 0 if r = 0
LAYOUT_WEIGHTS = 7  # offset in params of 2 n projection weights (positions, then velocities); -1: unit weights
LAYOUT_PARAMETERS = 8  # number of parameters the generated code reads (params must be at least this long)
LAYOUT_RHS = 9  # address of the generated rhs(y, params, dydt) (assemble and solve fused), 0 when there is none
LAYOUT_ACCELERATION = 10  # n entries: where each coordinate's acceleration sits in x; then r constraint rows


def make_layout(
    n: int,
    n_unknowns: int,
    acceleration_index,
    *,
    n_parameters: int,
    symmetric: bool = False,
    solve_address: int = 0,
    rhs_address: int = 0,
    constraint_rows=(),
    constraint_address: int = 0,
    time_index: int | None = None,
    weights_offset: int | None = None,
) -> np.ndarray:
    """The int64 layout array the kernels read (slots above). ``constraint_rows``: the rows of ``A x = b``
    whose ``(A x - b)[row]`` is the second time derivative of constraint ``i`` (Baumgarte's rows)."""
    rows = [int(row) for row in constraint_rows]
    if rows and not constraint_address:
        raise ValueError("constraint rows need the address of the generated constraints function")
    head = [n, n_unknowns, len(rows), -1 if time_index is None else int(time_index), int(bool(symmetric)),
            int(solve_address), int(constraint_address) if rows else 0,
            -1 if weights_offset is None else int(weights_offset), int(n_parameters), int(rhs_address)]
    return np.array(head + [int(i) for i in acceleration_index] + rows, dtype=np.int64)


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


def _pointer_call(return_type, n_pointers: int):
    """The lowering of a call to a generated function at an address (the call's first argument) taking
    ``n_pointers`` float64 pointers and returning ``return_type`` (LLVM ``void`` or ``double``)."""

    def codegen(context, builder, sig, args):
        double_pointer = ir.DoubleType().as_pointer()
        function_type = ir.FunctionType(return_type, [double_pointer] * n_pointers)
        function = builder.inttoptr(args[0], function_type.as_pointer())
        result = builder.call(function, args[1:])
        return context.get_dummy_value() if isinstance(return_type, ir.VoidType) else result

    return codegen


def _takes_pointers(address, pointers) -> bool:
    """Whether a call's arguments type-check: an integer address, then float64 pointers only."""
    return isinstance(address, types.Integer) and all(arg == _POINTER for arg in pointers)


@intrinsic
def call_native(typingctx, address, theta, omega, params, matrix, vector):
    """Call the generated function at ``address`` (an integer) with five float64 pointers.

    Both generated functions share this signature (``assemble`` and ``mass_and_force``). The address must come
    from :mod:`physics.codegen.native` (or a ``numba.cfunc`` of the same signature, in tests): it is trusted."""
    if not _takes_pointers(address, (theta, omega, params, matrix, vector)):
        return None
    return types.void(address, *[_POINTER] * 5), _pointer_call(ir.VoidType(), 5)


@intrinsic
def call_native_ratio(typingctx, address, first, second, result):
    """Call a generated ``double f(double*, double*, double*)`` at ``address`` and return its pivot ratio:
    the structured ``solve(A, b, x)`` and the fused ``rhs(y, params, dydt)`` share this signature."""
    if not _takes_pointers(address, (first, second, result)):
        return None
    return types.float64(address, *[_POINTER] * 3), _pointer_call(ir.DoubleType(), 3)
