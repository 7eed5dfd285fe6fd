"""The samples' solve of a run written as LLVM IR: no numba.

After an integration, a run solves its system once per sample (the reactions and the condition estimate,
:func:`physics.kernels.system.solve_states`); a pinned chain's condition number needs its plain matrices
(:func:`physics.kernels.system.assemble_states`). In numba these kernels cost an empty cache seconds of
compilation; emitted here operation for operation (the general solve from :mod:`physics.codegen.linear_ir`, no
fast-math), they compile with the IR drivers' pipeline in a fraction of a second and give the kernels' very bits.
The mechanism engine's samples (:mod:`physics.codegen.mechanism_samples`) call them.

Entry points (C calling convention)::

    void solve_states(i64 assemble, i64* layout, i64 rows, double* theta, double* omega, double* params,
                      double alpha, double beta, double* x_out, double* cond_out, double* scratch)
    void solve_pose_states(i64 sample, i64* layout, i64 rows, double* theta, double* omega, double* params,
                           double alpha, double beta, double* x_out, double* cond_out, double* scratch,
                           double* pose_jacobian_out, double* pose_vector_out, i64 jacobian_size, i64 vector_size)
    void assemble_states(i64 assemble, i64* layout, i64 rows, double* theta, double* omega, double* params,
                         double* A_out, double* b_out)

Arrays are row-major and C-contiguous; ``scratch`` holds
:func:`physics.codegen.ir_shapes.samples_scratch_length` doubles (``solve_pose_states``: plus ``jacobian_size +
vector_size``).
"""

from __future__ import annotations

from llvmlite import ir

from ..kernels.layout import LAYOUT_CONSTRAINTS, LAYOUT_COORDINATES, LAYOUT_UNKNOWNS
from .ir_code import _DOUBLE, _DOUBLE_POINTER, _I64, _I64_POINTER, _Code, _int
from .linear_ir import LinearFunctions, _fill

_POINTER_CALL = ir.FunctionType(ir.VoidType(), [_DOUBLE_POINTER] * 5)


def _external(module: ir.Module, name: str, arguments) -> _Code:
    return _Code(ir.Function(module, ir.FunctionType(ir.VoidType(), arguments), name))


class _SolveScratch:
    """make_system's fresh arrays in ``scratch`` (``A`` zeroed and ``col_scale`` set to one, once for all rows, as
    the kernel makes them) and the sizes read from the layout."""

    def __init__(self, code: _Code, layout, scratch, after_b=None) -> None:
        b = code.b
        self.n = code.load(layout, _int(LAYOUT_COORDINATES))
        self.k = code.load(layout, _int(LAYOUT_UNKNOWNS))
        self.r = code.load(layout, _int(LAYOUT_CONSTRAINTS))
        r_rows = b.select(b.icmp_signed(">", self.r, _int(1)), self.r, _int(1))
        self.A = scratch
        self.b_vector = code.at(self.A, b.mul(self.k, self.k))
        # ``after_b`` doubles right after b (the kinematics' part of a generated ``sample``'s output), zeroed
        after_b = _int(0) if after_b is None else after_b
        self.after_b = code.at(self.b_vector, self.k)
        _fill(code, self.after_b, after_b, 0.0, "zero_after_b")
        self.x = code.at(self.after_b, after_b)
        self.col_scale = code.at(self.x, self.k)
        self.J = code.at(self.col_scale, self.k)
        self.v = code.at(self.J, b.mul(r_rows, self.n))
        self.G = code.at(self.v, b.mul(_int(2), r_rows))
        self.end = code.at(self.G, b.mul(r_rows, r_rows))  # where the scratch of samples_states ends
        _fill(code, self.A, b.mul(self.k, self.k), 0.0, "zero_matrix")
        _fill(code, self.col_scale, self.k, 1.0, "unit_scale")


def _solve_row(code: _Code, linear: LinearFunctions, parts: _SolveScratch, assemble, layout, row, theta_row,
               omega_row, params, alpha, beta, x_out, cond_out) -> None:
    """One row of system.solve_states: solve_system (unknowns_into, and the constraints' geometric test when
    there are constraints, the larger ratio kept as numba's ``max``), ``x`` copied to row ``row`` of ``x_out``."""
    b = code.b
    ratio = b.call(linear.unknowns, [assemble, layout, parts.A, parts.b_vector, parts.x, parts.col_scale, parts.J,
                                     parts.v, theta_row, omega_row, params, alpha, beta])
    result = code.var(ratio)
    with b.if_then(b.icmp_signed("!=", parts.r, _int(0))):
        geometric = b.call(linear.constraint_ratio, [layout, parts.J, parts.v, parts.G, theta_row, omega_row, params])
        code.set(result, code.maximum(ratio, geometric))
    code.store(code.get(result), cond_out, row)
    with code.loop(parts.k, "copy") as j:
        code.store(code.load(parts.x, j), x_out, b.add(b.mul(row, parts.k), j))


def _solve_states(module: ir.Module, linear: LinearFunctions) -> None:
    """system.solve_states: make_system's fresh arrays, then per row solve_system."""
    code = _external(module, "solve_states", [_I64, _I64_POINTER, _I64] + [_DOUBLE_POINTER] * 3
                     + [_DOUBLE, _DOUBLE] + [_DOUBLE_POINTER] * 3)
    assemble, layout, rows, theta, omega, params, alpha, beta, x_out, cond_out, scratch = code.function.args
    b = code.b
    parts = _SolveScratch(code, layout, scratch)
    with code.loop(rows, "row") as row:
        _solve_row(code, linear, parts, assemble, layout, row, code.at(theta, b.mul(row, parts.n)),
                   code.at(omega, b.mul(row, parts.n)), params, alpha, beta, x_out, cond_out)
    b.ret_void()
    code.seal()


def add_solve_states(module: ir.Module, linear: LinearFunctions) -> None:
    """``solve_states`` added to ``module`` (:mod:`physics.codegen.specialised_ir` specialises it)."""
    _solve_states(module, linear)


def _solve_pose_states(module: ir.Module, linear: LinearFunctions) -> None:
    """``solve_states`` with a generated ``sample`` in place of ``assemble`` (its output: ``b``, then the
    kinematics' ``d pose/d theta`` and vector, in scratch right after ``b``), each row's kinematics copied out to
    row ``row`` of ``pose_jacobian_out (rows, jacobian_size)`` and ``pose_vector_out (rows, vector_size)``: a
    sample's solve and kinematics in one generated call, which evaluates each angle's sine and cosine once
    (:mod:`physics.codegen.emit`'s ``sample``; the same bits as ``solve_states`` then ``native_states`` with
    ``kinematics``, for a system without a time slot)."""
    code = _external(module, "solve_pose_states", [_I64, _I64_POINTER, _I64] + [_DOUBLE_POINTER] * 3
                     + [_DOUBLE, _DOUBLE] + [_DOUBLE_POINTER] * 5 + [_I64, _I64])
    (sample, layout, rows, theta, omega, params, alpha, beta, x_out, cond_out, scratch, jacobian_out, vector_out,
     jacobian_size, vector_size) = code.function.args
    b = code.b
    parts = _SolveScratch(code, layout, scratch, b.add(jacobian_size, vector_size))
    pose_vector = code.at(parts.after_b, jacobian_size)
    with code.loop(rows, "row") as row:
        _solve_row(code, linear, parts, sample, layout, row, code.at(theta, b.mul(row, parts.n)),
                   code.at(omega, b.mul(row, parts.n)), params, alpha, beta, x_out, cond_out)
        jacobian_row = code.at(jacobian_out, b.mul(row, jacobian_size))
        with code.loop(jacobian_size, "copy_jacobian") as j:
            code.store(code.load(parts.after_b, j), jacobian_row, j)
        vector_row = code.at(vector_out, b.mul(row, vector_size))
        with code.loop(vector_size, "copy_vector") as j:
            code.store(code.load(pose_vector, j), vector_row, j)
    b.ret_void()
    code.seal()


def add_solve_pose_states(module: ir.Module, linear: LinearFunctions) -> None:
    """``solve_pose_states`` added to ``module`` (:mod:`physics.codegen.specialised_ir` specialises it)."""
    _solve_pose_states(module, linear)


def _assemble_states(module: ir.Module) -> None:
    """system.assemble_states: per row, ``A`` zeroed and the generated ``assemble`` (no Baumgarte terms),
    written straight into the row of ``A_out`` and ``b_out`` (the same numbers the kernel copies there)."""
    code = _external(module, "assemble_states", [_I64, _I64_POINTER, _I64] + [_DOUBLE_POINTER] * 5)
    assemble, layout, rows, theta, omega, params, A_out, b_out = code.function.args
    b = code.b
    n = code.load(layout, _int(LAYOUT_COORDINATES))
    k = code.load(layout, _int(LAYOUT_UNKNOWNS))
    function = b.inttoptr(assemble, _POINTER_CALL.as_pointer())
    with code.loop(rows, "row") as row:
        A = code.at(A_out, b.mul(row, b.mul(k, k)))
        _fill(code, A, b.mul(k, k), 0.0, "zero")
        b.call(function, [code.at(theta, b.mul(row, n)), code.at(omega, b.mul(row, n)), params, A,
                          code.at(b_out, b.mul(row, k))])
    b.ret_void()
    code.seal()


def samples_ir() -> str:
    """The module's IR text: the two entry points and the general solve they call."""
    module = ir.Module(name="linkage_lab_samples")
    linear = LinearFunctions(module)
    _solve_states(module, linear)
    _solve_pose_states(module, linear)
    _assemble_states(module)
    return str(module)
