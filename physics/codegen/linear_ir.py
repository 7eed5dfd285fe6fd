"""The kernels' general linear solve of ``A x = b`` written as LLVM IR, operation for operation.

:mod:`physics.kernels.linear` and :func:`physics.kernels.system.unknowns_into` solve a mechanism's equations at
one state: the generated structured solve (the DAE), L D L^T for Lagrange's symmetric positive definite mass
matrix, a pivoted LU otherwise, and, when the pivot ratio passes ``RESCALE_ABOVE``, the system rebuilt and solved
equilibrated. The same loops are emitted here, in the kernels' order of operations (the same IEEE operations,
numba's ``min``/``max`` as selects, ``!=`` unordered, no fast-math, no FMA), so that a right-hand side evaluated
by these functions has the kernels' very bits. They let the IR drivers (:mod:`physics.codegen.integrator_ir`)
integrate a mechanism without a fused ``rhs`` (Lagrange, Newton–Euler) and the states where the fused ``rhs``
asks for the general path, and let the samples' pass (:mod:`physics.codegen.samples_ir`) run without numba.

Every function is ``internal`` (inlined or called within its module) and takes raw pointers: ``A`` row-major
``k x k``, ``J`` row-major ``r x n``. :func:`add_linear_functions` adds them to a module.
"""

from __future__ import annotations

from contextlib import contextmanager

from llvmlite import ir

from ..kernels.constants import (
    RELATIVE_NOISE,
    RESCALE_ABOVE,
    SINGULAR_PIVOT_RATIO,
    STATUS_NOT_FINITE,
    STATUS_OK,
    STATUS_SINGULAR,
)
from ..kernels.layout import (
    LAYOUT_ACCELERATION,
    LAYOUT_CONSTRAINT_FUNCTION,
    LAYOUT_CONSTRAINTS,
    LAYOUT_COORDINATES,
    LAYOUT_SOLVE,
    LAYOUT_SYMMETRIC,
    LAYOUT_TIME,
    LAYOUT_UNKNOWNS,
)
from .ir_code import _BOOL, _DOUBLE, _DOUBLE_POINTER, _I64, _I64_POINTER, _Code, _double, _int

_INF = float("inf")
_NAN = float("nan")
_TRUE = ir.Constant(_BOOL, 1)
_FALSE = ir.Constant(_BOOL, 0)
_POINTER_CALL = ir.FunctionType(ir.VoidType(), [_DOUBLE_POINTER] * 5)  # assemble, constraints
_RATIO_CALL = ir.FunctionType(_DOUBLE, [_DOUBLE_POINTER] * 3)  # the structured solve


def _function(module: ir.Module, name: str, result, arguments) -> _Code:
    function = ir.Function(module, ir.FunctionType(result, arguments), name)
    function.linkage = "internal"
    return _Code(function)


def _entry(code: _Code, matrix, row, column, columns):
    """``&matrix[row, column]`` of a row-major matrix of ``columns`` columns."""
    b = code.b
    return code.at(matrix, b.add(b.mul(row, columns), column))


def _fill(code: _Code, pointer, count, value: float, name: str) -> None:
    with code.loop(count, name) as i:
        code.store(_double(value), pointer, i)


def gram_into(code: _Code, G, J, n, r, weight) -> None:
    """``G[:r, :r] = J W J^T`` as :func:`physics.kernels.linear.gram_into` sums it: column by column over the
    column's non-zeros (``!=`` unordered, as numba's), the upper triangle summed and mirrored. ``weight(c)``
    emits column ``c``'s weight (the constant 1 for unit weights). One emitter for the constraints' geometric
    test (:func:`physics.kernels.system.constraint_ratio`) and the projection (``projection._correct``)."""
    b = code.b
    _fill(code, G, b.mul(r, r), 0.0, "gram_zero")
    with code.loop(n, "gram_column") as c:
        column_weight = weight(c)
        with code.loop(r, "gram_row") as i:
            first = b.load(_entry(code, J, i, c, n))
            with b.if_then(b.fcmp_unordered("!=", first, _double(0.0))):
                value = b.fmul(first, column_weight)
                with code.loop(r, "gram_pair", start=i) as j:
                    second = b.load(_entry(code, J, j, c, n))
                    with b.if_then(b.fcmp_unordered("!=", second, _double(0.0))):
                        target = _entry(code, G, i, j, r)
                        b.store(b.fadd(b.load(target), b.fmul(value, second)), target)
    with code.loop(r, "mirror") as i:
        with code.loop(r, "mirror_column", start=b.add(i, _int(1))) as j:
            b.store(b.load(_entry(code, G, i, j, r)), _entry(code, G, j, i, r))


def two_row_ratio(code: _Code, J, n, singular: ir.Block):
    """sigma_max / sigma_min of a two-row ``J`` (2 x n) by :func:`physics.kernels.system.constraint_ratio`'s
    closed form (the eigenvalues of the 2 x 2 Gram matrix): branches to ``singular`` where the smallest is not
    positive (the kernel's inf), else returns the ratio in the block the builder is left in. The one emitter
    of this form, for the samples' pass and the integrators' step test alike."""
    b = code.b
    jxx, jyy, jxy = code.var(_double(0.0)), code.var(_double(0.0)), code.var(_double(0.0))
    with code.loop(n, "gram") as i:
        first, second = code.load(J, i), code.load(J, b.add(n, i))
        code.set(jxx, b.fadd(code.get(jxx), b.fmul(first, first)))
        code.set(jyy, b.fadd(code.get(jyy), b.fmul(second, second)))
        code.set(jxy, b.fadd(code.get(jxy), b.fmul(first, second)))
    xx, yy, xy = code.get(jxx), code.get(jyy), code.get(jxy)
    half_trace = b.fmul(_double(0.5), b.fadd(xx, yy))
    radicand = b.fsub(b.fmul(half_trace, half_trace), b.fsub(b.fmul(xx, yy), b.fmul(xy, xy)))
    gap = code.sqrt(code.maximum(_double(0.0), radicand))
    smallest = b.fsub(half_trace, gap)
    regular = code.block("two_rows.regular")
    b.cbranch(b.fcmp_ordered(">", smallest, _double(0.0)), regular, singular)
    b.position_at_end(regular)
    return code.sqrt(b.fdiv(b.fadd(half_trace, gap), smallest))


def load_state(code: _Code, layout, t, y, params, theta, omega):
    """common.load_state's IR, emitted where a function starts from a state ``y``: ``t`` into ``params`` at the
    layout's time slot (when there is one), ``y`` split into ``theta`` and ``omega``; returns ``n`` (loaded from
    the layout). One emitter for the general rhs and the projection: the text each emits is what each emitted
    before (the machine-code cache keys on it)."""
    b = code.b
    n = code.load(layout, _int(LAYOUT_COORDINATES))
    slot = code.load(layout, _int(LAYOUT_TIME))
    with b.if_then(b.icmp_signed(">=", slot, _int(0))):
        code.store(t, params, slot)
    with code.loop(n, "split") as i:
        code.store(code.load(y, i), theta, i)
        code.store(code.load(y, b.add(n, i)), omega, i)
    return n


@contextmanager
def _downward(code: _Code, count, name: str):
    """``for i in range(count - 1, -1, -1)``: yields ``i`` (as :meth:`_Code.loop` yields its index)."""
    with code.loop(count, name) as m:
        yield code.b.sub(code.b.sub(count, _int(1)), m)


class LinearFunctions:
    """The IR functions of :mod:`physics.kernels.linear` and of the system's solve, added to one module."""

    def __init__(self, module: ir.Module) -> None:
        self.module = module
        self.lu_solve = self._lu_solve()
        self.ldlt_factor = self._ldlt_factor()
        self.ldlt_solve = self._ldlt_solve()
        self.equilibrate = self._equilibrate()
        self.lu_solve_equilibrated = self._lu_solve_equilibrated()
        self.constraints_into = self._constraints_into()
        self.equations = self._equations()
        self.unknowns = self._unknowns()
        self.constraint_ratio = self._constraint_ratio()
        self.general_rhs = self._general_rhs()

    # ------------------------------------------------------------------ physics.kernels.linear
    def _lu_solve(self) -> ir.Function:
        """``double lu_solve(i64 k, double* A, double* b, double* x)``: linear.lu_solve."""
        code = _function(self.module, "lu_solve", _DOUBLE, [_I64] + [_DOUBLE_POINTER] * 3)
        k, A, b_vector, x = code.function.args
        b = code.b
        largest, smallest = code.var(_double(0.0)), code.var(_double(_INF))
        with code.loop(k, "column") as col:
            pivot_row, pivot_abs = code.var(col), code.var(code.fabs(b.load(_entry(code, A, col, col, k))))
            with code.loop(k, "pivot_search", start=b.add(col, _int(1))) as row:
                value = code.fabs(b.load(_entry(code, A, row, col, k)))
                with b.if_then(b.fcmp_ordered(">", value, code.get(pivot_abs))):
                    code.set(pivot_abs, value)
                    code.set(pivot_row, row)
            pivot = code.get(pivot_abs)
            with b.if_then(b.or_(b.fcmp_ordered("==", pivot, _double(0.0)), b.not_(code.finite(pivot)))):
                _fill(code, x, k, _NAN, "singular")
                b.ret(_double(_INF))
            chosen = code.get(pivot_row)
            with b.if_then(b.icmp_signed("!=", chosen, col)):
                with code.loop(k, "swap", start=col) as j:
                    upper, lower = _entry(code, A, col, j, k), _entry(code, A, chosen, j, k)
                    tmp = b.load(upper)
                    b.store(b.load(lower), upper)
                    b.store(tmp, lower)
                tmp = code.load(b_vector, col)
                code.store(code.load(b_vector, chosen), b_vector, col)
                code.store(tmp, b_vector, chosen)
            code.set(largest, code.maximum(code.get(largest), pivot))
            code.set(smallest, code.minimum(code.get(smallest), pivot))
            inverse = b.fdiv(_double(1.0), b.load(_entry(code, A, col, col, k)))
            with code.loop(k, "eliminate", start=b.add(col, _int(1))) as row:
                factor = b.fmul(b.load(_entry(code, A, row, col, k)), inverse)
                with b.if_then(b.fcmp_unordered("!=", factor, _double(0.0))):
                    with code.loop(k, "update", start=b.add(col, _int(1))) as j:
                        target = _entry(code, A, row, j, k)
                        b.store(b.fsub(b.load(target), b.fmul(factor, b.load(_entry(code, A, col, j, k)))), target)
                    b_row = code.at(b_vector, row)
                    b.store(b.fsub(b.load(b_row), b.fmul(factor, code.load(b_vector, col))), b_row)
        with _downward(code, k, "back") as i:
            acc = code.var(code.load(b_vector, i))
            with code.loop(k, "back_row", start=b.add(i, _int(1))) as j:
                code.set(acc, b.fsub(code.get(acc), b.fmul(b.load(_entry(code, A, i, j, k)), code.load(x, j))))
            code.store(b.fdiv(code.get(acc), b.load(_entry(code, A, i, i, k))), x, i)
        b.ret(b.fdiv(code.get(largest), code.get(smallest)))
        code.seal()
        return code.function

    def _ldlt_factor(self) -> ir.Function:
        """``double ldlt_factor(i64 k, double* A)``: linear.ldlt_factor."""
        code = _function(self.module, "ldlt_factor", _DOUBLE, [_I64, _DOUBLE_POINTER])
        k, A = code.function.args
        b = code.b
        largest, smallest = code.var(_double(0.0)), code.var(_double(_INF))
        with code.loop(k, "ldlt") as j:
            pivot = code.var(b.load(_entry(code, A, j, j, k)))
            with code.loop(j, "pivot") as p:
                value = b.load(_entry(code, A, j, p, k))
                with b.if_then(b.fcmp_unordered("!=", value, _double(0.0))):
                    term = b.fmul(b.fmul(value, value), b.load(_entry(code, A, p, p, k)))
                    code.set(pivot, b.fsub(code.get(pivot), term))
            pivot_value = code.get(pivot)
            positive = b.and_(b.fcmp_ordered(">", pivot_value, _double(0.0)), code.finite(pivot_value))
            with b.if_then(b.not_(positive)):
                b.ret(_double(_INF))
            code.set(largest, code.maximum(code.get(largest), pivot_value))
            code.set(smallest, code.minimum(code.get(smallest), pivot_value))
            b.store(pivot_value, _entry(code, A, j, j, k))
            with code.loop(j, "update") as p:
                value = b.load(_entry(code, A, j, p, k))
                with b.if_then(b.fcmp_unordered("!=", value, _double(0.0))):
                    weight = b.load(_entry(code, A, p, p, k))
                    with code.loop(k, "update_row", start=b.add(j, _int(1))) as i:
                        target = _entry(code, A, i, j, k)
                        product = b.fmul(b.fmul(b.load(_entry(code, A, i, p, k)), value), weight)
                        b.store(b.fsub(b.load(target), product), target)
            inverse = b.fdiv(_double(1.0), pivot_value)
            with code.loop(k, "scale_column", start=b.add(j, _int(1))) as i:
                target = _entry(code, A, i, j, k)
                b.store(b.fmul(b.load(target), inverse), target)
        b.ret(b.fdiv(code.get(largest), code.get(smallest)))
        code.seal()
        return code.function

    def _ldlt_solve(self) -> ir.Function:
        """``double ldlt_solve(i64 k, double* A, double* b, double* x)``: linear.ldlt_solve."""
        code = _function(self.module, "ldlt_solve", _DOUBLE, [_I64] + [_DOUBLE_POINTER] * 3)
        k, A, b_vector, x = code.function.args
        b = code.b
        ratio = b.call(self.ldlt_factor, [k, A])
        with b.if_then(b.not_(b.fcmp_ordered("<", ratio, _double(_INF)))):
            _fill(code, x, k, _NAN, "singular")
            b.ret(ratio)
        with code.loop(k, "forward") as i:
            total = code.var(code.load(b_vector, i))
            with code.loop(i, "forward_row") as p:
                value = b.load(_entry(code, A, i, p, k))
                with b.if_then(b.fcmp_unordered("!=", value, _double(0.0))):
                    code.set(total, b.fsub(code.get(total), b.fmul(value, code.load(x, p))))
            code.store(code.get(total), x, i)
        with _downward(code, k, "backward") as i:
            total = code.var(b.fdiv(code.load(x, i), b.load(_entry(code, A, i, i, k))))
            with code.loop(k, "backward_row", start=b.add(i, _int(1))) as p:
                value = b.load(_entry(code, A, p, i, k))
                with b.if_then(b.fcmp_unordered("!=", value, _double(0.0))):
                    code.set(total, b.fsub(code.get(total), b.fmul(value, code.load(x, p))))
            code.store(code.get(total), x, i)
        b.ret(ratio)
        code.seal()
        return code.function

    def _equilibrate(self) -> ir.Function:
        """``i1 equilibrate(i64 k, double* A, double* b, double* col_scale)``: linear.equilibrate."""
        code = _function(self.module, "equilibrate", _BOOL, [_I64] + [_DOUBLE_POINTER] * 3)
        k, A, b_vector, col_scale = code.function.args
        b = code.b
        overall = code.var(_double(0.0))
        with code.loop(k, "overall_row") as row:
            with code.loop(k, "overall") as j:
                code.set(overall, code.maximum(code.get(overall), code.fabs(b.load(_entry(code, A, row, j, k)))))
        largest = code.get(overall)
        with b.if_then(b.not_(b.and_(b.fcmp_ordered(">", largest, _double(0.0)), code.finite(largest)))):
            b.ret(_FALSE)
        noise = b.fmul(_double(RELATIVE_NOISE), largest)
        with code.loop(k, "row") as row:
            biggest = code.var(_double(0.0))
            with code.loop(k, "row_largest") as j:
                code.set(biggest, code.maximum(code.get(biggest), code.fabs(b.load(_entry(code, A, row, j, k)))))
            value = code.get(biggest)
            with b.if_then(b.fcmp_ordered("<=", value, noise)):
                b.ret(_FALSE)
            with b.if_then(code.finite(value)):
                inverse = b.fdiv(_double(1.0), value)
                with code.loop(k, "row_scale") as j:
                    target = _entry(code, A, row, j, k)
                    b.store(b.fmul(b.load(target), inverse), target)
                target = code.at(b_vector, row)
                b.store(b.fmul(b.load(target), inverse), target)
        with code.loop(k, "column") as j:
            biggest = code.var(_double(0.0))
            with code.loop(k, "column_largest") as row:
                code.set(biggest, code.maximum(code.get(biggest), code.fabs(b.load(_entry(code, A, row, j, k)))))
            value = code.get(biggest)
            with b.if_then(b.fcmp_ordered("<=", value, _double(RELATIVE_NOISE))):
                b.ret(_FALSE)
            scale = b.select(code.finite(value), b.fdiv(_double(1.0), value), _double(1.0))
            code.store(scale, col_scale, j)
            with code.loop(k, "column_scale") as row:
                target = _entry(code, A, row, j, k)
                b.store(b.fmul(b.load(target), code.load(col_scale, j)), target)
        b.ret(_TRUE)
        code.seal()
        return code.function

    def _lu_solve_equilibrated(self) -> ir.Function:
        """``double lu_solve_equilibrated(i64 k, double* A, double* b, double* x, double* col_scale)``."""
        code = _function(self.module, "lu_solve_equilibrated", _DOUBLE, [_I64] + [_DOUBLE_POINTER] * 4)
        k, A, b_vector, x, col_scale = code.function.args
        b = code.b
        with b.if_then(b.not_(b.call(self.equilibrate, [k, A, b_vector, col_scale]))):
            _fill(code, x, k, _NAN, "singular")
            b.ret(_double(_INF))
        ratio = b.call(self.lu_solve, [k, A, b_vector, x])
        with code.loop(k, "unscale") as i:
            code.store(b.fmul(code.load(x, i), code.load(col_scale, i)), x, i)
        b.ret(ratio)
        code.seal()
        return code.function

    # ------------------------------------------------------------------ physics.kernels.system
    def _constraints_into(self) -> ir.Function:
        """``void constraints_into(i64* layout, double* J, double* v, double* theta, double* omega,
        double* params)``: system.constraints_into (J, r x n, zeroed first)."""
        code = _function(self.module, "constraints_into", ir.VoidType(), [_I64_POINTER] + [_DOUBLE_POINTER] * 5)
        layout, J, v, theta, omega, params = code.function.args
        b = code.b
        n, r = code.load(layout, _int(LAYOUT_COORDINATES)), code.load(layout, _int(LAYOUT_CONSTRAINTS))
        _fill(code, J, b.mul(r, n), 0.0, "zero")
        address = code.load(layout, _int(LAYOUT_CONSTRAINT_FUNCTION))
        b.call(b.inttoptr(address, _POINTER_CALL.as_pointer()), [theta, omega, params, J, v])
        b.ret_void()
        code.seal()
        return code.function

    def _equations(self) -> ir.Function:
        """``void equations(i64 assemble, i64* layout, double* A, double* b, double* J, double* v, double* theta,
        double* omega, double* params, double alpha, double beta, i1 zero)``: system.equations_into (``zero``)
        or structural_into (A not zeroed)."""
        code = _function(self.module, "equations", ir.VoidType(),
                         [_I64, _I64_POINTER] + [_DOUBLE_POINTER] * 7 + [_DOUBLE, _DOUBLE, _BOOL])
        assemble, layout, A, b_vector, J, v, theta, omega, params, alpha, beta, zero = code.function.args
        b = code.b
        k = code.load(layout, _int(LAYOUT_UNKNOWNS))
        with b.if_then(zero):
            _fill(code, A, b.mul(k, k), 0.0, "zero")
        b.call(b.inttoptr(assemble, _POINTER_CALL.as_pointer()), [theta, omega, params, A, b_vector])
        r = code.load(layout, _int(LAYOUT_CONSTRAINTS))
        gains = b.or_(b.fcmp_unordered("!=", alpha, _double(0.0)), b.fcmp_unordered("!=", beta, _double(0.0)))
        with b.if_then(b.and_(b.icmp_signed("!=", r, _int(0)), gains)):
            b.call(self.constraints_into, [layout, J, v, theta, omega, params])
            first_row = b.add(_int(LAYOUT_ACCELERATION), code.load(layout, _int(LAYOUT_COORDINATES)))
            with code.loop(r, "baumgarte") as i:
                target = code.at(b_vector, code.load(layout, b.add(first_row, i)))
                term = b.fadd(b.fmul(b.fmul(_double(2.0), alpha), code.load(v, b.add(r, i))),
                              b.fmul(b.fmul(beta, beta), code.load(v, i)))
                b.store(b.fsub(b.load(target), term), target)
        b.ret_void()
        code.seal()
        return code.function

    def _unknowns(self) -> ir.Function:
        """``double unknowns(i64 assemble, i64* layout, double* A, double* b, double* x, double* col_scale,
        double* J, double* v, double* theta, double* omega, double* params, double alpha, double beta)``:
        system.unknowns_into (the structured solve, L D L^T or pivoted LU, the equilibrated fallback)."""
        code = _function(self.module, "unknowns", _DOUBLE,
                         [_I64, _I64_POINTER] + [_DOUBLE_POINTER] * 9 + [_DOUBLE, _DOUBLE])
        assemble, layout, A, b_vector, x, col_scale, J, v, theta, omega, params, alpha, beta = code.function.args
        b = code.b
        k = code.load(layout, _int(LAYOUT_UNKNOWNS))

        def equations(zero: bool) -> None:
            b.call(self.equations, [assemble, layout, A, b_vector, J, v, theta, omega, params, alpha, beta,
                                    _TRUE if zero else _FALSE])

        def rescaled():
            equations(True)
            return b.call(self.lu_solve_equilibrated, [k, A, b_vector, x, col_scale])

        solve = code.load(layout, _int(LAYOUT_SOLVE))
        with b.if_then(b.icmp_signed("!=", solve, _int(0))):
            equations(False)
            ratio = b.call(b.inttoptr(solve, _RATIO_CALL.as_pointer()), [A, b_vector, x])
            with b.if_then(b.fcmp_ordered("<=", ratio, _double(RESCALE_ABOVE))):
                b.ret(ratio)
            ratio = rescaled()
            _fill(code, A, b.mul(k, k), 0.0, "rezero")  # the structured path's invariant
            b.ret(ratio)
        equations(True)
        result = code.var(_double(0.0))
        symmetric = b.icmp_signed("!=", code.load(layout, _int(LAYOUT_SYMMETRIC)), _int(0))
        with b.if_else(symmetric) as (ldlt, lu):
            with ldlt:
                code.set(result, b.call(self.ldlt_solve, [k, A, b_vector, x]))
            with lu:
                code.set(result, b.call(self.lu_solve, [k, A, b_vector, x]))
        with b.if_then(b.not_(b.fcmp_ordered("<=", code.get(result), _double(RESCALE_ABOVE)))):
            code.set(result, rescaled())
        b.ret(code.get(result))
        code.seal()
        return code.function

    def _constraint_ratio(self) -> ir.Function:
        """``double constraint_ratio(i64* layout, double* J, double* v, double* G, double* theta, double* omega,
        double* params)``: system.constraint_ratio (the closed form for two rows, else the pivots of J J^T
        summed as linear.gram_into sums it, with unit weights). ``G`` is r x r."""
        code = _function(self.module, "constraint_ratio", _DOUBLE, [_I64_POINTER] + [_DOUBLE_POINTER] * 6)
        layout, J, v, G, theta, omega, params = code.function.args
        b = code.b
        b.call(self.constraints_into, [layout, J, v, theta, omega, params])
        n, r = code.load(layout, _int(LAYOUT_COORDINATES)), code.load(layout, _int(LAYOUT_CONSTRAINTS))
        with b.if_then(b.icmp_signed("==", r, _int(2))):
            singular = code.block("two_rows.singular")
            ratio = two_row_ratio(code, J, n, singular)
            b.ret(ratio)
            b.position_at_end(singular)
            b.ret(_double(_INF))
            b.position_at_end(code.block("two_rows.after"))
        gram_into(code, G, J, n, r, lambda column: _double(1.0))  # unit weights
        ratio = b.call(self.ldlt_factor, [r, G])
        with b.if_then(b.not_(b.fcmp_ordered("<", ratio, _double(_INF)))):
            b.ret(_double(_INF))
        b.ret(code.sqrt(ratio))
        code.seal()
        return code.function

    def _general_rhs(self) -> ir.Function:
        """``i64 general_rhs(i64 assemble, i64* layout, double* A, double* b, double* x, double* col_scale,
        double* J, double* v, double t, double* y, double* params, double* theta, double* omega, double* dydt,
        double alpha, double beta)``: common.rhs_into's general path (load_state, unknowns_into with the
        Baumgarte gains ``alpha``, ``beta``, the accelerations into ``dydt``): OK, SINGULAR or NOT_FINITE."""
        code = _function(self.module, "general_rhs", _I64,
                         [_I64, _I64_POINTER] + [_DOUBLE_POINTER] * 6 + [_DOUBLE] + [_DOUBLE_POINTER] * 5
                         + [_DOUBLE, _DOUBLE])
        (assemble, layout, A, b_vector, x, col_scale, J, v, t, y, params, theta, omega, dydt, alpha,
         beta) = code.function.args
        b = code.b
        n = load_state(code, layout, t, y, params, theta, omega)
        condition = b.call(self.unknowns, [assemble, layout, A, b_vector, x, col_scale, J, v, theta, omega, params,
                                           alpha, beta])
        finite = code.var(b.fcmp_ordered("==", condition, condition))
        with code.loop(n, "accelerations") as i:
            acceleration = code.load(x, code.load(layout, b.add(_int(LAYOUT_ACCELERATION), i)))
            code.store(code.load(omega, i), dydt, i)
            code.store(acceleration, dydt, b.add(n, i))
            with b.if_then(b.not_(code.finite(acceleration))):
                code.set(finite, _FALSE)
        with b.if_then(b.fcmp_ordered(">", condition, _double(SINGULAR_PIVOT_RATIO))):
            b.ret(_int(STATUS_SINGULAR))
        b.ret(b.select(code.get(finite), _int(STATUS_OK), _int(STATUS_NOT_FINITE)))
        code.seal()
        return code.function


def add_linear_functions(module: ir.Module) -> LinearFunctions:
    """The general solve's functions, added to ``module`` (internal: only its own functions call them)."""
    return LinearFunctions(module)
