"""The kernels' projection onto the constraints (:mod:`physics.kernels.projection`) written as LLVM IR, operation
for operation, and the per-sample loops a mechanism's run calls beside it: with these, a run held by
projection (the four-bar's and every general mechanism's default), a driven mechanism's position analysis and
its samples' constraints need no numba kernel.

:class:`ProjectionFunctions` adds the internal functions to a module: ``correct`` (the least weighted change
``W J^T (J W J^T)^-1 gap``), ``onto`` (positions by Gauss-Newton, then velocities) and ``project`` (a state
``y = [theta, omega]`` in place, the integrators' ``project_state``). :func:`states_ir` is a module of its own
with two entry points (C calling convention)::

    double project_states(i64* layout, i64 rows, double* t, double* theta, double* omega, double* params,
                          double* scratch)
    void native_states(i64 function, i64* layout, i64 rows, double* t, double* theta, double* omega,
                       double* params, i64 matrix_size, i64 vector_size, double* matrix_out, double* vector_out)

the kernels' :func:`~physics.kernels.projection.project_states` (rows projected in place; the largest position
residual left) and :func:`~physics.kernels.system.native_states` (a generated ``constraints`` or ``kinematics``
at each row). :func:`driven_ir` is another, with one::

    i64 driven_sequence(i64* layout, i64 rows, i64 start, double tolerance, double* t, double* xs, double* vs,
                        double* params, double* scratch)

a driven mechanism's position analysis from row ``start`` on (each row predicted from the one before and
projected as ``project_states`` projects it; the first row it cannot keep, or ``rows``), a module of its own so
that it is compiled through LLVM's O2 pipeline (:mod:`physics.codegen.native_states`) while the other two keep
their short compilation. ``params`` is the caller's copy (the time slot is written); ``scratch`` holds
:func:`~physics.codegen.ir_shapes.states_scratch_length` doubles.
"""

from __future__ import annotations

from llvmlite import ir

from ..kernels.constants import PROJECTION_MAX_ITERATIONS, PROJECTION_TOLERANCE, SINGULAR_CONDITION_NUMBER
from ..kernels.layout import LAYOUT_CONSTRAINTS, LAYOUT_COORDINATES, LAYOUT_TIME, LAYOUT_WEIGHTS
from .ir_code import _BOOL, _DOUBLE, _DOUBLE_POINTER, _I64, _I64_POINTER, _Code, _double, _int
from .linear_ir import LinearFunctions, add_linear_functions, gram_into, load_state

_TRUE = ir.Constant(_BOOL, 1)
_FALSE = ir.Constant(_BOOL, 0)
_NATIVE_CALL = ir.FunctionType(ir.VoidType(), [_DOUBLE_POINTER] * 5)  # theta, omega, params, matrix, vector


def _function(module: ir.Module, name: str, result, arguments, linkage: str = "internal") -> _Code:
    function = ir.Function(module, ir.FunctionType(result, arguments), name)
    if linkage:
        function.linkage = linkage
    return _Code(function)


class ProjectionFunctions:
    """The IR functions of :mod:`physics.kernels.projection`, added to one module."""

    def __init__(self, module: ir.Module, linear: LinearFunctions) -> None:
        self.module = module
        self.linear = linear
        self.correct = self._correct()
        self.onto = self._onto()
        self.project = self._project()

    def _correct(self) -> ir.Function:
        """``i1 correct(i64 n, i64 r, double* J, double* G, double* lam, double* params, i64 offset, double* gap,
        double* coordinates)``: ``projection._correct``: ``coordinates -= W J^T (J W J^T)^-1 gap``, the weights
        at ``offset`` of params (unit when < 0); ``J W J^T`` summed as ``linear.gram_into`` sums it, solved in
        closed form for two rows and by L D L^T otherwise; false (nothing changed) where it is singular to
        working precision (SINGULAR_CONDITION_NUMBER)."""
        code = _function(self.module, "correct", _BOOL, [_I64, _I64] + [_DOUBLE_POINTER] * 4 + [_I64]
                         + [_DOUBLE_POINTER] * 2)
        n, r, J, G, lam, params, offset, gap, coordinates = code.function.args
        b = code.b

        def weight(column):
            """linear.column_weight: ``params[offset + column]``, or 1 when ``offset < 0`` (read only then)."""
            value = code.var(_double(1.0))
            with b.if_then(b.icmp_signed(">=", offset, _int(0))):
                code.set(value, code.load(params, b.add(offset, column)))
            return code.get(value)

        gram_into(code, G, J, n, r, weight)
        with b.if_else(b.icmp_signed("==", r, _int(2))) as (two_rows, more_rows):
            with two_rows:
                a, off_diagonal, c2 = code.load(G, _int(0)), code.load(G, _int(1)), code.load(G, _int(3))
                det = b.fsub(b.fmul(a, c2), b.fmul(off_diagonal, off_diagonal))
                trace = b.fadd(a, c2)
                threshold = b.fdiv(b.fmul(trace, trace), _double(SINGULAR_CONDITION_NUMBER))
                with b.if_then(b.not_(b.fcmp_ordered(">", det, threshold))):
                    b.ret(_FALSE)
                gap0, gap1 = code.load(gap, _int(0)), code.load(gap, _int(1))
                code.store(b.fdiv(b.fsub(b.fmul(c2, gap0), b.fmul(off_diagonal, gap1)), det), lam, _int(0))
                code.store(b.fdiv(b.fsub(b.fmul(a, gap1), b.fmul(off_diagonal, gap0)), det), lam, _int(1))
            with more_rows:  # ldlt_solve reads the right-hand side without writing it (the kernel's copy g)
                ratio = b.call(self.linear.ldlt_solve, [r, G, gap, lam])
                with b.if_then(b.not_(b.fcmp_ordered("<=", ratio, _double(SINGULAR_CONDITION_NUMBER)))):
                    b.ret(_FALSE)
        with code.loop(n, "apply") as c:
            total = code.var(_double(0.0))
            with code.loop(r, "apply_row") as i:
                term = b.fmul(code.load(J, b.add(b.mul(i, n), c)), code.load(lam, i))
                code.set(total, b.fadd(code.get(total), term))
            target = code.at(coordinates, c)
            b.store(b.fsub(b.load(target), b.fmul(weight(c), code.get(total))), target)
        b.ret(_TRUE)
        code.seal()
        return code.function

    def _onto(self) -> ir.Function:
        """``double onto(i64* layout, double* theta, double* omega, double* params, double* J, double* v,
        double* G, double* lam)``: ``position_onto`` (Gauss-Newton until ``|phi|`` < PROJECTION_TOLERANCE or
        PROJECTION_MAX_ITERATIONS, or a singular ``J W J^T``), then ``velocity_onto`` with the constraints of
        the final positions (every exit follows an evaluation at them: the kernel's ``project_velocity`` would
        evaluate the same again). Returns the final ``|phi|``. ``params`` holds the time already."""
        code = _function(self.module, "onto", _DOUBLE, [_I64_POINTER] + [_DOUBLE_POINTER] * 7)
        layout, theta, omega, params, J, v, G, lam = code.function.args
        b = code.b
        n = code.load(layout, _int(LAYOUT_COORDINATES))
        r = code.load(layout, _int(LAYOUT_CONSTRAINTS))
        offset = code.load(layout, _int(LAYOUT_WEIGHTS))
        iteration, residual = code.var(_int(0)), code.var(_double(0.0))
        body, positioned = code.block("position.body"), code.block("position.done")
        b.branch(body)
        b.position_at_end(body)  # range(PROJECTION_MAX_ITERATIONS + 1): each pass ends in a break or a correction
        b.call(self.linear.constraints_into, [layout, J, v, theta, omega, params])
        total = code.var(_double(0.0))
        with code.loop(r, "residual") as i:
            value = code.load(v, i)
            code.set(total, b.fadd(code.get(total), b.fmul(value, value)))
        code.set(residual, code.sqrt(code.get(total)))
        count = code.get(iteration)
        finished = b.or_(b.fcmp_ordered("<", code.get(residual), _double(PROJECTION_TOLERANCE)),
                         b.icmp_signed("==", count, _int(PROJECTION_MAX_ITERATIONS)))
        with b.if_then(finished):
            code.jump(positioned)
        corrected = b.call(self.correct, [n, r, J, G, lam, params, offset, v, theta])
        with b.if_then(b.not_(corrected)):
            code.jump(positioned)
        code.set(iteration, b.add(count, _int(1)))
        b.branch(body)
        b.position_at_end(positioned)
        velocity_offset = b.select(b.icmp_signed("<", offset, _int(0)), offset, b.add(offset, n))
        b.call(self.correct, [n, r, J, G, lam, params, velocity_offset, code.at(v, r), omega])
        b.ret(code.get(residual))
        code.seal()
        return code.function

    def _project(self) -> ir.Function:
        """``i1 project(i64* layout, double t, double* y, double* params, double* theta, double* omega,
        double* J, double* v, double* G, double* lam)``: ``projection.project_state`` for r != 0: load_state,
        :meth:`_onto`, ``y`` written back; false when it is not finite (the integrators' NOT_FINITE)."""
        code = _function(self.module, "project", _BOOL, [_I64_POINTER, _DOUBLE] + [_DOUBLE_POINTER] * 8)
        layout, t, y, params, theta, omega, J, v, G, lam = code.function.args
        b = code.b
        n = load_state(code, layout, t, y, params, theta, omega)
        b.call(self.onto, [layout, theta, omega, params, J, v, G, lam])
        with code.loop(n, "write_back") as i:
            code.store(code.load(theta, i), y, i)
            code.store(code.load(omega, i), y, b.add(n, i))
        finite = code.var(_TRUE)
        with code.loop(b.mul(_int(2), n), "finite") as i:
            with b.if_then(b.not_(code.finite(code.load(y, i)))):
                code.set(finite, _FALSE)
        b.ret(code.get(finite))
        code.seal()
        return code.function


def _layout_and_scratch(code: _Code, layout, scratch):
    """What a row's projection reads of the layout (coordinates ``n``, constraint rows ``r``, the parameter slot
    of the time) and the caller's scratch cut into the projection's four work arrays (``J`` r x n, ``v``, ``G``
    r x r, ``lam``; at least one row each), emitted in one order so the modules' IR text, the machine-code
    cache's key, stays the same."""
    b = code.b
    n = code.load(layout, _int(LAYOUT_COORDINATES))
    r = code.load(layout, _int(LAYOUT_CONSTRAINTS))
    slot = code.load(layout, _int(LAYOUT_TIME))
    held = b.select(b.icmp_signed(">", r, _int(1)), r, _int(1))
    J = scratch
    v = code.at(J, b.mul(held, n))
    G = code.at(v, b.mul(_int(2), held))
    lam = code.at(G, b.mul(held, held))
    return n, r, slot, (J, v, G, lam)


def _project_states(module: ir.Module, projection: ProjectionFunctions) -> None:
    """projection.project_states: per row, the time into the caller's copy of params, then (with constraints)
    positions and velocities projected in place; the largest position residual (numba's ``max``)."""
    code = _function(module, "project_states", _DOUBLE, [_I64_POINTER, _I64] + [_DOUBLE_POINTER] * 5, linkage="")
    layout, rows, t, theta, omega, params, scratch = code.function.args
    b = code.b
    n, r, slot, (J, v, G, lam) = _layout_and_scratch(code, layout, scratch)
    worst = code.var(_double(0.0))
    with code.loop(rows, "rows") as row:
        with b.if_then(b.icmp_signed(">=", slot, _int(0))):
            code.store(code.load(t, row), params, slot)
        with b.if_then(b.icmp_signed("!=", r, _int(0))):
            theta_row, omega_row = code.at(theta, b.mul(row, n)), code.at(omega, b.mul(row, n))
            residual = b.call(projection.onto, [layout, theta_row, omega_row, params, J, v, G, lam])
            code.set(worst, code.maximum(code.get(worst), residual))
    b.ret(code.get(worst))
    code.seal()


def _driven_sequence(module: ir.Module, projection: ProjectionFunctions) -> None:
    """A driven mechanism's position analysis (:func:`physics.mechanism.engine._position_analysis`), row after
    row in one call: for ``k`` from ``start`` on, row ``k - 1`` moved on by its velocity (``x + v (t_k -
    t_{k-1})``, each operation as numpy does it on the row) with its velocity kept, then projected as
    ``project_states`` projects one row (the time into the caller's copy of params, :meth:`ProjectionFunctions.onto`).
    Stops at the first row it cannot keep, the one Python assembles instead: ``max(0, residual)`` (the figure
    ``project_states`` returns for a row, so a NaN residual reads 0 as it does there) not below ``tolerance``,
    or a position not finite. Returns that row's index, or ``rows`` when every row was kept."""
    code = _function(module, "driven_sequence", _I64, [_I64_POINTER, _I64, _I64, _DOUBLE] + [_DOUBLE_POINTER] * 5,
                     linkage="")
    layout, rows, start, tolerance, t, xs, vs, params, scratch = code.function.args
    b = code.b
    n, r, slot, (J, v, G, lam) = _layout_and_scratch(code, layout, scratch)
    stopped = code.block("stopped")
    stop_row = code.var(rows)
    with code.loop(rows, "rows", start=start) as row:
        previous = b.sub(row, _int(1))
        theta_row, omega_row = code.at(xs, b.mul(row, n)), code.at(vs, b.mul(row, n))
        theta_before, omega_before = code.at(xs, b.mul(previous, n)), code.at(vs, b.mul(previous, n))
        step = b.fsub(code.load(t, row), code.load(t, previous))
        with code.loop(n, "predict") as i:
            velocity = code.load(omega_before, i)
            code.store(b.fadd(code.load(theta_before, i), b.fmul(velocity, step)), theta_row, i)
            code.store(velocity, omega_row, i)
        with b.if_then(b.icmp_signed(">=", slot, _int(0))):
            code.store(code.load(t, row), params, slot)
        left = code.var(_double(0.0))
        with b.if_then(b.icmp_signed("!=", r, _int(0))):
            residual = b.call(projection.onto, [layout, theta_row, omega_row, params, J, v, G, lam])
            code.set(left, code.maximum(_double(0.0), residual))
        kept = code.var(b.fcmp_ordered("<", code.get(left), tolerance))
        with code.loop(n, "finite") as i:
            with b.if_then(b.not_(code.finite(code.load(theta_row, i)))):
                code.set(kept, _FALSE)
        with b.if_then(b.not_(code.get(kept))):
            code.set(stop_row, row)
            code.jump(stopped)
    b.branch(stopped)
    b.position_at_end(stopped)
    b.ret(code.get(stop_row))
    code.seal()


def _native_states(module: ir.Module) -> None:
    """system.native_states: per row, the time into the caller's copy of params, the matrix row zeroed (the
    generated function writes its structural non-zeros only), then the function at the row's state."""
    code = _function(module, "native_states", ir.VoidType(), [_I64, _I64_POINTER, _I64] + [_DOUBLE_POINTER] * 4
                     + [_I64, _I64] + [_DOUBLE_POINTER] * 2, linkage="")
    function, layout, rows, t, theta, omega, params, matrix_size, vector_size, matrix_out, vector_out = (
        code.function.args)
    b = code.b
    n = code.load(layout, _int(LAYOUT_COORDINATES))
    slot = code.load(layout, _int(LAYOUT_TIME))
    native = b.inttoptr(function, _NATIVE_CALL.as_pointer())
    with code.loop(rows, "rows") as row:
        with b.if_then(b.icmp_signed(">=", slot, _int(0))):
            code.store(code.load(t, row), params, slot)
        matrix = code.at(matrix_out, b.mul(row, matrix_size))
        with code.loop(matrix_size, "zero") as i:
            code.store(_double(0.0), matrix, i)
        b.call(native, [code.at(theta, b.mul(row, n)), code.at(omega, b.mul(row, n)), params, matrix,
                        code.at(vector_out, b.mul(row, vector_size))])
    b.ret_void()
    code.seal()


def states_ir() -> str:
    """The module's IR text: ``project_states`` and ``native_states`` with their internal helpers."""
    module = ir.Module(name="linkage_lab_states")
    _project_states(module, ProjectionFunctions(module, add_linear_functions(module)))
    _native_states(module)
    return str(module)


def driven_ir() -> str:
    """The module's IR text: ``driven_sequence`` with its internal helpers (the projection's, as in
    :func:`states_ir`)."""
    module = ir.Module(name="linkage_lab_driven")
    _driven_sequence(module, ProjectionFunctions(module, add_linear_functions(module)))
    return str(module)
