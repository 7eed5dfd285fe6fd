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

A mechanism's ``layout`` (an int64 array, :func:`~physics.kernels.layout.make_layout`, numba-free) tells the kernels the sizes, where the
coordinates' accelerations and the constraints' rows sit in ``x``, where ``t`` goes in ``params``, and the
addresses of the optional functions.
"""

from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from .layout import (  # noqa: F401  (the contract's layout, re-exported: numba-free in its own module)
    LAYOUT_ACCELERATION,
    LAYOUT_CONSTRAINT_FUNCTION,
    LAYOUT_CONSTRAINTS,
    LAYOUT_COORDINATES,
    LAYOUT_PARAMETERS,
    LAYOUT_RHS,
    LAYOUT_SOLVE,
    LAYOUT_SYMMETRIC,
    LAYOUT_TIME,
    LAYOUT_UNKNOWNS,
    LAYOUT_WEIGHTS,
    make_layout,
)

_POINTER = types.CPointer(types.float64)
ASSEMBLE_SIGNATURE = types.void(_POINTER, _POINTER, _POINTER, _POINTER, _POINTER)
MASS_AND_FORCE_SIGNATURE = types.void(_POINTER, _POINTER, _POINTER, _POINTER, _POINTER)


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
