"""scipy's RK45 and DOP853 drivers with ``t_eval`` sampling, written as LLVM IR: no numba compilation for a run.

numba spends about 20 s of an empty-cache run typing and lowering the integrators
(:func:`physics.kernels.explicit_rk._integrate_explicit_rk`); the same loop emitted here as LLVM IR compiles in a
fraction of a second with llvmlite. The IR is the numba kernel's algorithm, written operation for operation in
the kernel's order: the same IEEE additions, multiplications, divisions, ``sqrt`` and ``pow`` (no fast-math, no
FMA contraction), the same comparisons (numba's ``min``/``max`` are selects on ``<``/``>``, reproduced as such),
so that every sample, step count and status is bit-identical to the kernel's.

Each right-hand side is evaluated as the kernel's ``rhs_into`` evaluates it: without Baumgarte terms, the
mechanism's generated fused ``rhs`` (:mod:`physics.kernels.abi`), called through its address in the layout, and
where the kernel would take its general path instead (no fused ``rhs``: Lagrange, Newton–Euler; a pivot ratio
above ``RESCALE_ABOVE``, or NaN; Baumgarte terms, ``alpha`` or ``beta`` not zero), the general solve written as
IR (:mod:`physics.codegen.linear_ir`: assemble with the Baumgarte terms on the constraints' rows, then the
structured solve, L D L^T or pivoted LU, and the equilibrated fallback). Constraints (a pinned chain's two rows,
a mechanism's joints) are judged at the start and after each accepted step by the kernel's own geometric test
(:func:`physics.kernels.system.constraint_ratio`: its closed form for two rows, the pivots of ``J J^T``
otherwise). A projecting run (``project`` not zero: asked for, and constraints held) projects the start, each
accepted step (with a fresh derivative) and each sample as :func:`physics.kernels.projection.project_state`
does: Gauss-Newton on the positions, then the velocities, by the least (weighted) change, with the kernel's
statuses (NOT_FINITE where a projected state is not finite).

Entry points (C calling convention), one per method::

    i64 integrate_rk45(i64 assemble, i64* layout, double* y0, double t0, double t_end, double* t_eval, i64 n_samples,
                       double* params, double rtol, double atol, double alpha, double beta, i64 project,
                       i64 max_steps, double* y_out, double* scratch, i64* counts, double* t_reached)

``params`` is the caller's copy (the time slot is written), ``y_out`` (n_samples, 2 n) row-major, already NaN,
``scratch`` :func:`physics.codegen.ir_shapes.integrator_scratch_length` doubles; ``counts`` receives
``[n_steps, n_rhs, n_filled]``. Returns the status (:mod:`physics.kernels.constants`).
"""

from __future__ import annotations

from llvmlite import ir

from ..kernels import tables
from ..kernels.constants import (
    MAX_FACTOR,
    MIN_FACTOR,
    RESCALE_ABOVE,
    SAFETY,
    SINGULAR_PIVOT_RATIO,
    STATUS_MAX_STEPS,
    STATUS_NOT_FINITE,
    STATUS_OK,
    STATUS_SINGULAR,
    STATUS_STEP_TOO_SMALL,
)
from ..kernels.layout import (
    LAYOUT_CONSTRAINT_FUNCTION,
    LAYOUT_CONSTRAINTS,
    LAYOUT_COORDINATES,
    LAYOUT_RHS,
    LAYOUT_TIME,
    LAYOUT_UNKNOWNS,
)
from .ir_code import _BOOL, _DOUBLE, _DOUBLE_POINTER, _I64, _I64_POINTER, _Code, _double, _int
from .ir_shapes import INTEGRATOR_FUNCTION_NAMES as FUNCTION_NAMES
from .ir_shapes import WORK_VECTORS as _WORK_VECTORS
from .ir_shapes import stage_rows
from .linear_ir import LinearFunctions, add_linear_functions, gram_into, two_row_ratio
from .projection_ir import ProjectionFunctions

_NOT_FUSED = 1  # the fused rhs's own answer "evaluate by the general path" (physics.kernels.common.NOT_FUSED)

_RHS_TYPE = ir.FunctionType(_DOUBLE, [_DOUBLE_POINTER] * 3)
_CONSTRAINTS_TYPE = ir.FunctionType(ir.VoidType(), [_DOUBLE_POINTER] * 5)
DRIVER_TYPE = ir.FunctionType(_I64, [
    _I64, _I64_POINTER, _DOUBLE_POINTER, _DOUBLE, _DOUBLE, _DOUBLE_POINTER, _I64, _DOUBLE_POINTER, _DOUBLE, _DOUBLE,
    _DOUBLE, _DOUBLE, _I64, _I64, _DOUBLE_POINTER, _DOUBLE_POINTER, _I64_POINTER, _DOUBLE_POINTER,
])


class _Method:
    """One method's tableau, as the numba driver selects it."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.dop853 = name == "DOP853"
        if self.dop853:
            self.A, self.B, self.C = tables.DOP853_A, tables.DOP853_B, tables.DOP853_C
            self.n_stages = tables.DOP853_N_STAGES
            self.n_rows = stage_rows(name)
            order = tables.DOP853_ERROR_ORDER
        else:
            self.A, self.B, self.C = tables.RK45_A, tables.RK45_B, tables.RK45_C
            self.n_stages = tables.RK45_N_STAGES
            self.n_rows = stage_rows(name)
            order = tables.RK45_ERROR_ORDER
        self.error_exponent = -1.0 / (order + 1)
        self.initial_step_exponent = 1.0 / (order + 1)


def _fused_rhs(module: ir.Module) -> ir.Function:
    """``i64 fused(i64 address, i64 slot, i64 n, double t, double* y, double* params, double* dydt)``: the kernel's
    ``fused_rhs``: OK, NOT_FINITE (an acceleration is not finite) or NOT_FUSED (ratio not <= RESCALE_ABOVE)."""
    function = ir.Function(module, ir.FunctionType(_I64, [_I64, _I64, _I64, _DOUBLE] + [_DOUBLE_POINTER] * 3),
                           "fused_rhs")
    function.linkage = "internal"
    function.attributes.add("alwaysinline")
    code = _Code(function)
    address, slot, n, t, y, params, dydt = function.args
    b = code.b
    with b.if_then(b.icmp_signed(">=", slot, _int(0))):
        code.store(t, params, slot)
    rhs = b.inttoptr(address, _RHS_TYPE.as_pointer())
    ratio = b.call(rhs, [y, params, dydt])
    answered, not_fused = code.block("answered"), code.block("not_fused")
    b.cbranch(b.fcmp_ordered("<=", ratio, _double(RESCALE_ABOVE)), answered, not_fused)
    b.position_at_end(not_fused)
    b.ret(_int(_NOT_FUSED))
    b.position_at_end(answered)
    with code.loop(n, "finite") as i:
        with b.if_then(b.not_(code.finite(code.load(dydt, b.add(n, i))))):
            b.ret(_int(STATUS_NOT_FINITE))
    b.ret(_int(STATUS_OK))
    code.seal()
    return function


def _evaluate(module: ir.Module, fused: ir.Function, linear: LinearFunctions) -> ir.Function:
    """``i64 evaluate(i64 rhs, i64 assemble, i64* layout, double* A, double* b, double* x, double* col_scale,
    double* J, double* v, double t, double* y, double* params, double* theta, double* omega, double* dydt,
    double alpha, double beta)``: one right-hand side as the kernel's rhs_into evaluates it: without Baumgarte
    terms (``alpha == beta == 0``) the fused ``rhs`` (at address ``rhs``) when there is one, the general path
    (with the Baumgarte terms) when there is none, it answers NOT_FUSED or the gains are not zero. One function
    called from every stage (not inlined at each: the driver's IR stays about as short as with the fused call
    alone)."""
    function = ir.Function(module, ir.FunctionType(_I64, [_I64, _I64, _I64_POINTER] + [_DOUBLE_POINTER] * 6
                                                   + [_DOUBLE] + [_DOUBLE_POINTER] * 5 + [_DOUBLE, _DOUBLE]),
                           "evaluate")
    function.linkage = "internal"
    code = _Code(function)
    rhs, assemble, layout, A, b_vector, x, col_scale, J, v, t, y, params, theta, omega, dydt, alpha, beta = (
        function.args)
    b = code.b
    fusing = b.and_(b.fcmp_ordered("==", alpha, _double(0.0)), b.fcmp_ordered("==", beta, _double(0.0)))
    with b.if_then(b.and_(b.icmp_signed("!=", rhs, _int(0)), fusing), likely=True):
        slot = code.load(layout, _int(LAYOUT_TIME))
        n = code.load(layout, _int(LAYOUT_COORDINATES))
        status = b.call(fused, [rhs, slot, n, t, y, params, dydt])
        with b.if_then(b.icmp_signed("!=", status, _int(_NOT_FUSED)), likely=True):
            b.ret(status)
    b.ret(b.call(linear.general_rhs, [assemble, layout, A, b_vector, x, col_scale, J, v, t, y, params, theta, omega,
                                      dydt, alpha, beta]))
    code.seal()
    return function


def _two_row_test(module: ir.Module) -> ir.Function:
    """``i64 geometric(i64 address, i64 slot, i64 n, double t, double* y, double* params, double* theta,
    double* omega, double* J, double* v)``: the kernel's ``step_status`` for two constraint rows (load_state,
    the generated constraints into a zeroed J, constraint_ratio's closed form): SINGULAR or OK."""
    function = ir.Function(module, ir.FunctionType(_I64, [_I64, _I64, _I64, _DOUBLE] + [_DOUBLE_POINTER] * 6),
                           "two_row_test")
    function.linkage = "internal"
    function.attributes.add("alwaysinline")
    code = _Code(function)
    address, slot, n, t, y, params, theta, omega, J, v = function.args
    b = code.b
    _load_constraints(code, address, slot, n, _int(2), t, y, params, theta, omega, J, v)
    singular = code.block("singular")
    ratio = two_row_ratio(code, J, n, singular)
    b.ret(b.select(b.fcmp_ordered(">", ratio, _double(SINGULAR_PIVOT_RATIO)), _int(STATUS_SINGULAR),
                   _int(STATUS_OK)))
    b.position_at_end(singular)
    b.ret(_int(STATUS_SINGULAR))  # ratio inf > SINGULAR_PIVOT_RATIO
    code.seal()
    return function


def _load_constraints(code: _Code, address, slot, n, r, t, y, params, theta, omega, J, v) -> None:
    """The kernel's load_state and constraints_into: ``t`` into its slot, ``y`` split into ``theta`` and
    ``omega``, ``J`` (r x n) zeroed, then the generated constraints into ``J`` and ``v``."""
    b = code.b
    with b.if_then(b.icmp_signed(">=", slot, _int(0))):
        code.store(t, params, slot)
    with code.loop(n, "split") as i:
        code.store(code.load(y, i), theta, i)
        code.store(code.load(y, b.add(n, i)), omega, i)
    with code.loop(b.mul(r, n), "zero") as i:
        code.store(_double(0.0), J, i)
    b.call(b.inttoptr(address, _CONSTRAINTS_TYPE.as_pointer()), [theta, omega, params, J, v])


def _gram_test(module: ir.Module) -> ir.Function:
    """``i64 gram_test(i64 address, i64 slot, i64 n, i64 r, double t, double* y, double* params, double* theta,
    double* omega, double* J, double* v, double* G)``: the kernel's ``step_status`` for r != 2 rows: ``G = J J^T``
    summed as ``physics.kernels.linear.gram_into`` sums it (unit weights, column by column over its non-zeros),
    the pivots of ``ldlt_factor(G)``, SINGULAR when their ratio's square root passes SINGULAR_PIVOT_RATIO (or G
    is not positive definite)."""
    function = ir.Function(module, ir.FunctionType(_I64, [_I64, _I64, _I64, _I64, _DOUBLE] + [_DOUBLE_POINTER] * 7),
                           "gram_test")
    function.linkage = "internal"
    code = _Code(function)
    address, slot, n, r, t, y, params, theta, omega, J, v, G = function.args
    b = code.b
    _load_constraints(code, address, slot, n, r, t, y, params, theta, omega, J, v)

    def entry(matrix, row, column, columns):
        return code.at(matrix, b.add(b.mul(row, columns), column))

    gram_into(code, G, J, n, r, lambda column: _double(1.0))  # unit weights
    largest, smallest = code.var(_double(0.0)), code.var(_double(float("inf")))
    singular = code.block("singular")
    with code.loop(r, "ldlt") as j:
        pivot = code.var(b.load(entry(G, j, j, r)))
        with code.loop(j, "pivot") as p:
            value = b.load(entry(G, j, p, r))
            with b.if_then(b.fcmp_unordered("!=", value, _double(0.0))):
                term = b.fmul(b.fmul(value, value), b.load(entry(G, p, p, r)))
                code.set(pivot, b.fsub(code.get(pivot), term))
        pivot_value = code.get(pivot)
        positive = b.and_(b.fcmp_ordered(">", pivot_value, _double(0.0)), code.finite(pivot_value))
        continuing = code.block("ldlt.positive")
        b.cbranch(positive, continuing, singular)
        b.position_at_end(continuing)
        code.set(largest, code.maximum(code.get(largest), pivot_value))
        code.set(smallest, code.minimum(code.get(smallest), pivot_value))
        b.store(pivot_value, entry(G, j, j, r))
        with code.loop(j, "update") as p:
            value = b.load(entry(G, j, p, r))
            with b.if_then(b.fcmp_unordered("!=", value, _double(0.0))):
                weight = b.load(entry(G, p, p, r))
                with code.loop(r, "update_row", start=b.add(j, _int(1))) as i:
                    target = entry(G, i, j, r)
                    b.store(b.fsub(b.load(target), b.fmul(b.fmul(b.load(entry(G, i, p, r)), value), weight)),
                            target)
        inverse = b.fdiv(_double(1.0), pivot_value)
        with code.loop(r, "scale_column", start=b.add(j, _int(1))) as i:
            target = entry(G, i, j, r)
            b.store(b.fmul(b.load(target), inverse), target)
    ratio = b.fdiv(code.get(largest), code.get(smallest))
    finite_ratio = code.block("finite_ratio")
    b.cbranch(b.fcmp_ordered("<", ratio, _double(float("inf"))), finite_ratio, singular)
    b.position_at_end(finite_ratio)
    b.ret(b.select(b.fcmp_ordered(">", code.sqrt(ratio), _double(SINGULAR_PIVOT_RATIO)), _int(STATUS_SINGULAR),
                   _int(STATUS_OK)))
    b.position_at_end(singular)
    b.ret(_int(STATUS_SINGULAR))  # constraint_ratio's inf
    code.seal()
    return function


class _Driver:
    """The body of one method's driver (:func:`physics.kernels.explicit_rk._integrate_explicit_rk`), in the
    kernel's order of operations."""

    def __init__(self, module: ir.Module, method: _Method, evaluate: ir.Function, two_rows: ir.Function,
                 gram: ir.Function, project: ir.Function) -> None:
        self.method = method
        self.evaluate_function = evaluate
        self.two_row_function = two_rows
        self.gram_function = gram
        self.project_function = project
        function = ir.Function(module, DRIVER_TYPE, FUNCTION_NAMES[method.name])
        self.code = _Code(function)
        (self.assemble, self.layout, self.y0, self.t0, self.t_end, self.t_eval, self.n_samples, self.params, self.rtol,
         self.atol, self.alpha, self.beta, projecting, self.max_steps, self.y_out, scratch, self.counts,
         self.t_reached) = function.args
        code, b = self.code, self.code.b
        self.n = code.load(self.layout, _int(LAYOUT_COORDINATES))
        self.n_state = b.mul(_int(2), self.n)
        self.r = code.load(self.layout, _int(LAYOUT_CONSTRAINTS))
        self.rhs_address = code.load(self.layout, _int(LAYOUT_RHS))
        self.slot = code.load(self.layout, _int(LAYOUT_TIME))
        self.constraint_address = code.load(self.layout, _int(LAYOUT_CONSTRAINT_FUNCTION))
        offset = 0
        pointers = []
        for rows in (method.n_rows, tables.DOP853_INTERPOLATOR_POWER) + (1,) * _WORK_VECTORS:
            pointers.append(code.at(scratch, b.mul(_int(offset), self.n_state) if offset else _int(0)))
            offset += rows
        self.K, self.F, self.y, self.y_new, self.y_next, self.y_stage, self.f, self.f_next, self.scale, self.work = (
            pointers)
        self.theta = code.at(scratch, b.mul(_int(offset), self.n_state))
        self.omega = code.at(self.theta, self.n)
        self.J = code.at(self.omega, self.n)
        rows = b.select(b.icmp_signed(">", self.r, _int(2)), self.r, _int(2))
        self.v = code.at(self.J, b.mul(rows, self.n))
        self.G = code.at(self.v, b.mul(_int(2), rows))
        self.k = code.load(self.layout, _int(LAYOUT_UNKNOWNS))
        self.A = code.at(self.G, b.mul(rows, rows))
        self.b_vector = code.at(self.A, b.mul(self.k, self.k))
        self.x = code.at(self.b_vector, self.k)
        self.col_scale = code.at(self.x, self.k)
        self.lam = code.at(self.col_scale, self.k)
        self.projecting = b.icmp_signed("!=", projecting, _int(0))
        self.status = code.var(_int(STATUS_OK))
        self.n_steps = code.var(_int(0))
        self.n_rhs = code.var(_int(0))
        self.t = code.var(self.t0)
        self.i_sample = code.var(_int(0))
        self.exit = code.block("exit")

    # ---------------------------------------------------------------- pieces
    def finish(self, status) -> None:
        """``return status, n_steps, n_rhs, t, i_sample`` (the counters as they stand)."""
        self.code.set(self.status, status)
        self.code.jump(self.exit)

    def fused(self, t, y, dydt):
        """One right-hand side, counted, as the kernel's rhs_into evaluates it: the generated fused ``rhs`` when
        there is one, and the general path (:mod:`physics.codegen.linear_ir`) when there is none or it answers
        NOT_FUSED. Returns the status (OK, SINGULAR or NOT_FINITE)."""
        code, b = self.code, self.code.b
        code.set(self.n_rhs, b.add(code.get(self.n_rhs), _int(1)))
        return b.call(self.evaluate_function, [
            self.rhs_address, self.assemble, self.layout, self.A, self.b_vector, self.x, self.col_scale, self.J,
            self.v, t, y, self.params, self.theta, self.omega, dydt, self.alpha, self.beta])

    def project(self, t, y):
        """The kernel's project_state of ``y`` at ``t`` in place: true when the result is finite."""
        return self.code.b.call(self.project_function, [self.layout, t, y, self.params, self.theta, self.omega,
                                                        self.J, self.v, self.G, self.lam])

    def geometric(self, t, y):
        """The kernel's step_status with constraints (r != 0): its closed form for two rows, else J J^T's pivots."""
        code, b = self.code, self.code.b
        result = code.var(_int(STATUS_OK))
        with b.if_else(b.icmp_signed("==", self.r, _int(2))) as (two_rows, more_rows):
            with two_rows:
                code.set(result, b.call(self.two_row_function, [
                    self.constraint_address, self.slot, self.n, t, y, self.params, self.theta, self.omega, self.J,
                    self.v]))
            with more_rows:
                code.set(result, b.call(self.gram_function, [
                    self.constraint_address, self.slot, self.n, self.r, t, y, self.params, self.theta, self.omega,
                    self.J, self.v, self.G]))
        return code.get(result)

    def stage_sum(self, y, h, weights, count: int, out) -> None:
        """``out[j] = y[j] + h * sum_{r < count} K[r, j] * weights[r]`` (arrays.stage_sum_into)."""
        code, b = self.code, self.code.b
        with code.loop(self.n_state, "stage_sum") as j:
            total = _double(0.0)
            for r in range(count):
                total = b.fadd(total, b.fmul(code.load(code.row(self.K, r, self.n_state), j), _double(weights[r])))
            code.store(b.fadd(code.load(y, j), b.fmul(h, total)), out, j)

    def rms_norm(self, x):
        code, b = self.code, self.code.b
        total = code.var(_double(0.0))
        with code.loop(self.n_state, "norm") as j:
            value = code.load(x, j)
            code.set(total, b.fadd(code.get(total), b.fmul(value, value)))
        return b.fdiv(code.sqrt(code.get(total)), code.sqrt(code.to_double(self.n_state)))

    def copy(self, source, target) -> None:
        code = self.code
        with code.loop(self.n_state, "copy") as j:
            code.store(code.load(source, j), target, j)

    def sample_pending(self, t_limit, body_block, done_block) -> None:
        """``if i_sample < n_samples and t_eval[i_sample] <= t_limit`` → body, else done."""
        code, b = self.code, self.code.b
        index = code.get(self.i_sample)
        check_time = code.block("sample.time")
        b.cbranch(b.icmp_signed("<", index, self.n_samples), check_time, done_block)
        b.position_at_end(check_time)
        b.cbranch(b.fcmp_ordered("<=", code.load(self.t_eval, index), t_limit), body_block, done_block)

    def write_sample(self, source) -> None:
        """y_out[i_sample] = source; i_sample += 1."""
        code, b = self.code, self.code.b
        index = code.get(self.i_sample)
        row = code.at(self.y_out, b.mul(index, self.n_state))
        self.copy(source, row)
        code.set(self.i_sample, b.add(index, _int(1)))

    # ---------------------------------------------------------------- the run
    def emit(self) -> None:
        code, b = self.code, self.code.b
        with code.loop(b.mul(self.k, self.k), "zero_matrix") as i:  # make_system's zero A (the structured path's)
            code.store(_double(0.0), self.A, i)
        with code.loop(self.k, "unit_scale") as i:
            code.store(_double(1.0), self.col_scale, i)
        self.copy(self.y0, self.y)
        self.start()
        self.initial_step()
        self.steps()
        code.jump(self.exit)
        b.position_at_end(self.exit)
        code.store(code.get(self.n_steps), self.counts, _int(0))
        code.store(code.get(self.n_rhs), self.counts, _int(1))
        code.store(code.get(self.i_sample), self.counts, _int(2))
        code.store(code.get(self.t), self.t_reached, _int(0))
        b.ret(code.get(self.status))
        code.seal()
        # Blocks left empty after a jump are unreachable: end each with a branch to the exit.
        for block in code.function.blocks:
            if not block.is_terminated:
                b.position_at_end(block)
                b.branch(self.exit)

    def start(self) -> None:
        """A projecting run's projection of the start (NOT_FINITE before any evaluation), start_rhs and
        initial_samples; a run of zero length ends here."""
        code, b = self.code, self.code.b
        with b.if_then(self.projecting):
            with b.if_then(b.not_(self.project(self.t0, self.y))):
                self.finish(_int(STATUS_NOT_FINITE))
        status = self.fused(self.t0, self.y, self.f)
        all_finite = code.var(ir.Constant(_BOOL, 1))
        with code.loop(self.n_state, "start_finite") as j:
            with b.if_then(b.not_(code.finite(code.load(self.y, j)))):
                code.set(all_finite, ir.Constant(_BOOL, 0))
        started = code.var(status)
        with b.if_then(b.and_(code.get(all_finite), b.icmp_signed("!=", self.r, _int(0)))):
            geometric = self.geometric(self.t0, self.y)
            with b.if_then(b.icmp_signed("!=", geometric, _int(STATUS_OK))):
                code.set(started, geometric)
        status = code.get(started)
        with b.if_then(b.icmp_signed("!=", status, _int(STATUS_OK))):
            self.finish(status)
        body, done = code.block("initial.body"), code.block("initial.done")
        test = code.block("initial.test")
        b.branch(test)
        b.position_at_end(test)
        self.sample_pending(self.t0, body, done)
        b.position_at_end(body)
        self.write_sample(self.y)
        b.branch(test)
        b.position_at_end(done)
        self.interval_length = code.fabs(b.fsub(self.t_end, self.t0))
        with b.if_then(b.fcmp_ordered("==", self.interval_length, _double(0.0))):
            self.finish(_int(STATUS_OK))

    def initial_step(self) -> None:
        """scipy's select_initial_step, as the kernel writes it; leaves ``self.h_abs``."""
        code, b = self.code, self.code.b
        m = self.method
        with code.loop(self.n_state, "initial_scale") as j:
            code.store(b.fadd(self.atol, b.fmul(code.fabs(code.load(self.y, j)), self.rtol)), self.scale, j)
        with code.loop(self.n_state, "d0") as j:
            code.store(b.fdiv(code.load(self.y, j), code.load(self.scale, j)), self.work, j)
        d0 = self.rms_norm(self.work)
        with code.loop(self.n_state, "d1") as j:
            code.store(b.fdiv(code.load(self.f, j), code.load(self.scale, j)), self.work, j)
        d1 = self.rms_norm(self.work)
        small = b.or_(b.fcmp_ordered("<", d0, _double(1e-5)), b.fcmp_ordered("<", d1, _double(1e-5)))
        h0 = b.select(small, _double(1e-6), b.fdiv(b.fmul(_double(0.01), d0), d1))
        h0 = code.minimum(h0, self.interval_length)
        with code.loop(self.n_state, "h0_stage") as j:
            code.store(b.fadd(code.load(self.y, j), b.fmul(h0, code.load(self.f, j))), self.y_stage, j)
        status = self.fused(b.fadd(self.t0, h0), self.y_stage, self.f_next)
        with b.if_then(b.icmp_signed("!=", status, _int(STATUS_OK))):
            self.finish(status)
        with code.loop(self.n_state, "d2") as j:
            difference = b.fsub(code.load(self.f_next, j), code.load(self.f, j))
            code.store(b.fdiv(difference, code.load(self.scale, j)), self.work, j)
        d2 = b.fdiv(self.rms_norm(self.work), h0)
        flat = b.and_(b.fcmp_ordered("<=", d1, _double(1e-15)), b.fcmp_ordered("<=", d2, _double(1e-15)))
        h1 = code.var(_double(0.0))
        with b.if_else(flat) as (then, otherwise):
            with then:
                code.set(h1, code.maximum(_double(1e-6), b.fmul(h0, _double(1e-3))))
            with otherwise:
                quotient = b.fdiv(_double(0.01), code.maximum(d1, d2))
                code.set(h1, code.pow(quotient, _double(m.initial_step_exponent)))
        h_abs = code.minimum(code.minimum(b.fmul(_double(100.0), h0), code.get(h1)), self.interval_length)
        self.h_abs = code.var(h_abs)

    def next_after(self, t):
        """``np.nextafter(t, inf)``: the next double up (t finite or not)."""
        b = self.code.b
        bits = b.bitcast(t, _I64)
        up = b.bitcast(b.select(b.icmp_signed(">=", bits, _int(0)), b.add(bits, _int(1)), b.sub(bits, _int(1))),
                       _DOUBLE)
        up = b.select(b.fcmp_ordered("==", t, _double(0.0)), _double(5e-324), up)
        special = b.or_(b.fcmp_unordered("uno", t, t), b.fcmp_ordered("==", t, _double(float("inf"))))
        return b.select(special, b.fadd(t, t), up)

    def steps(self) -> None:
        code, b = self.code, self.code.b
        m = self.method
        K, n_state = self.K, self.n_state
        test, body, done = code.block("steps.test"), code.block("steps.body"), code.block("steps.done")
        b.branch(test)
        b.position_at_end(test)
        t = code.get(self.t)
        b.cbranch(b.fcmp_ordered("<", t, self.t_end), body, done)
        b.position_at_end(body)
        with b.if_then(b.icmp_signed(">=", code.get(self.n_steps), self.max_steps)):
            code.set(self.status, _int(STATUS_MAX_STEPS))
            code.jump(done)
        min_step = b.fmul(_double(10.0), code.fabs(b.fsub(self.next_after(t), t)))
        with b.if_then(b.fcmp_ordered("<", code.get(self.h_abs), min_step)):
            code.set(self.h_abs, min_step)
        step_rejected = code.var(ir.Constant(_BOOL, 0))
        t_new_slot = code.var(t)
        h_slot = code.var(_double(0.0))
        attempt, attempted = code.block("attempt"), code.block("attempted")
        b.branch(attempt)
        b.position_at_end(attempt)
        with b.if_then(b.fcmp_ordered("<", code.get(self.h_abs), min_step)):
            code.set(self.status, _int(STATUS_STEP_TOO_SMALL))
            code.jump(attempted)
        t_new = b.fadd(t, code.get(self.h_abs))
        t_new = b.select(b.fcmp_ordered(">", b.fsub(t_new, self.t_end), _double(0.0)), self.t_end, t_new)
        code.set(t_new_slot, t_new)
        h = b.fsub(t_new, t)
        code.set(h_slot, h)
        code.set(self.h_abs, code.fabs(h))
        self.copy(self.f, K)
        for s in range(1, m.n_stages):
            self.stage_sum(self.y, h, m.A[s], s, self.y_stage)
            status = self.fused(b.fadd(t, b.fmul(_double(m.C[s]), h)), self.y_stage, code.row(K, s, n_state))
            with b.if_then(b.icmp_signed("!=", status, _int(STATUS_OK))):
                code.set(self.status, status)
                code.jump(attempted)
        self.stage_sum(self.y, h, m.B, m.n_stages, self.y_new)
        status = self.fused(t_new, self.y_new, code.row(K, m.n_stages, n_state))
        with b.if_then(b.icmp_signed("!=", status, _int(STATUS_OK))):
            code.set(self.status, status)
            code.jump(attempted)
        with code.loop(n_state, "scale") as j:
            larger = code.maximum(code.fabs(code.load(self.y, j)), code.fabs(code.load(self.y_new, j)))
            code.store(b.fadd(self.atol, b.fmul(larger, self.rtol)), self.scale, j)
        error_norm = self.dop853_error(h) if m.dop853 else self.rk45_error(h)
        with b.if_then(b.not_(code.finite(error_norm))):
            code.set(self.status, _int(STATUS_NOT_FINITE))
            code.jump(attempted)
        accept, reject = code.block("accept"), code.block("reject")
        b.cbranch(b.fcmp_ordered("<", error_norm, _double(1.0)), accept, reject)
        b.position_at_end(accept)
        grown = code.minimum(_double(MAX_FACTOR), b.fmul(_double(SAFETY), code.pow(error_norm,
                                                                                _double(m.error_exponent))))
        factor = b.select(b.fcmp_ordered("==", error_norm, _double(0.0)), _double(MAX_FACTOR), grown)
        factor = b.select(code.get(step_rejected), code.minimum(_double(1.0), factor), factor)
        code.set(self.h_abs, b.fmul(code.get(self.h_abs), factor))
        b.branch(attempted)
        b.position_at_end(reject)
        shrink = code.maximum(_double(MIN_FACTOR), b.fmul(_double(SAFETY), code.pow(error_norm,
                                                                                  _double(m.error_exponent))))
        code.set(self.h_abs, b.fmul(code.get(self.h_abs), shrink))
        code.set(step_rejected, ir.Constant(_BOOL, 1))
        b.branch(attempt)

        b.position_at_end(attempted)
        with b.if_then(b.icmp_signed("!=", code.get(self.status), _int(STATUS_OK))):
            code.jump(done)
        t_new, h = code.get(t_new_slot), code.get(h_slot)
        with b.if_then(b.icmp_signed("!=", self.r, _int(0))):
            geometric = self.geometric(t_new, self.y_new)
            with b.if_then(b.icmp_signed("!=", geometric, _int(STATUS_OK))):
                code.set(self.status, geometric)
                code.jump(done)
        last_row = code.row(K, m.n_stages, n_state)
        with code.loop(n_state, "next") as j:
            code.store(code.load(self.y_new, j), self.y_next, j)
            code.store(code.load(last_row, j), self.f_next, j)
        with b.if_then(self.projecting):  # the next state projected, with a fresh derivative
            with b.if_then(b.not_(self.project(t_new, self.y_next))):
                code.set(self.status, _int(STATUS_NOT_FINITE))
                code.jump(done)
            status = self.fused(t_new, self.y_next, self.f_next)
            with b.if_then(b.icmp_signed("!=", status, _int(STATUS_OK))):
                code.set(self.status, status)
                code.jump(done)
        self.samples(t, t_new, h, done)
        self.copy(self.y_next, self.y)
        self.copy(self.f_next, self.f)
        code.set(self.t, t_new)
        code.set(self.n_steps, b.add(code.get(self.n_steps), _int(1)))
        b.branch(test)
        b.position_at_end(done)

    def rk45_error(self, h):
        code, b = self.code, self.code.b
        with code.loop(self.n_state, "error") as j:
            total = _double(0.0)
            for r in range(self.method.n_stages + 1):
                term = b.fmul(code.load(code.row(self.K, r, self.n_state), j), _double(tables.RK45_E[r]))
                total = b.fadd(total, term)
            code.store(b.fdiv(b.fmul(total, h), code.load(self.scale, j)), self.work, j)
        return self.rms_norm(self.work)

    def dop853_error(self, h):
        code, b = self.code, self.code.b
        err5_norm_2, err3_norm_2 = code.var(_double(0.0)), code.var(_double(0.0))
        with code.loop(self.n_state, "error") as j:
            err5 = _double(0.0)
            err3 = _double(0.0)
            for r in range(self.method.n_stages + 1):
                k = code.load(code.row(self.K, r, self.n_state), j)
                err5 = b.fadd(err5, b.fmul(k, _double(tables.DOP853_E5[r])))
                err3 = b.fadd(err3, b.fmul(k, _double(tables.DOP853_E3[r])))
            scale = code.load(self.scale, j)
            err5 = b.fdiv(err5, scale)
            err3 = b.fdiv(err3, scale)
            code.set(err5_norm_2, b.fadd(code.get(err5_norm_2), b.fmul(err5, err5)))
            code.set(err3_norm_2, b.fadd(code.get(err3_norm_2), b.fmul(err3, err3)))
        e5, e3 = code.get(err5_norm_2), code.get(err3_norm_2)
        zero = b.and_(b.fcmp_ordered("==", e5, _double(0.0)), b.fcmp_ordered("==", e3, _double(0.0)))
        denominator = b.fadd(e5, b.fmul(_double(0.01), e3))
        norm = b.fdiv(b.fmul(code.fabs(h), e5), code.sqrt(b.fmul(denominator, code.to_double(self.n_state))))
        return b.select(zero, _double(0.0), norm)

    def samples(self, t, t_new, h, done) -> None:
        """The step's samples in (t, t_new] by its dense output (DOP853's three extra stages first)."""
        code, b = self.code, self.code.b
        m = self.method
        body, skip = code.block("samples"), code.block("samples.skip")
        self.sample_pending(t_new, body, skip)
        b.position_at_end(body)
        if m.dop853:
            for s in range(tables.DOP853_N_STAGES + 1, tables.DOP853_N_STAGES_EXTENDED):
                self.stage_sum(self.y, h, tables.DOP853_A[s], s, self.y_stage)
                status = self.fused(b.fadd(t, b.fmul(_double(tables.DOP853_C[s]), h)), self.y_stage,
                                    code.row(self.K, s, self.n_state))
                with b.if_then(b.icmp_signed("!=", status, _int(STATUS_OK))):
                    code.set(self.status, status)
                    code.jump(done)
            self.dense_rows(h)
        test, each = code.block("sample.test"), code.block("sample.each")
        b.branch(test)
        b.position_at_end(test)
        self.sample_pending(t_new, each, skip)
        b.position_at_end(each)
        x = b.fdiv(b.fsub(code.load(self.t_eval, code.get(self.i_sample)), t), h)
        if m.dop853:
            self.dop853_sample(x)
        else:
            self.rk45_sample(x, h)
        with b.if_then(self.projecting):  # each sample projected (its finiteness is not judged)
            self.project(code.load(self.t_eval, code.get(self.i_sample)), self.y_stage)
        self.write_sample(self.y_stage)
        b.branch(test)
        b.position_at_end(skip)

    def dense_rows(self, h) -> None:
        """DOP853's ``F`` (7 rows) from ``K`` (16 rows), as ``_dop853_dense_coefficients``."""
        code, b = self.code, self.code.b
        K, F, n_state = self.K, self.F, self.n_state
        with code.loop(n_state, "dense") as j:
            delta_y = b.fsub(code.load(self.y_new, j), code.load(self.y, j))
            f_old = code.load(K, j)
            f_new = code.load(code.row(K, tables.DOP853_N_STAGES, n_state), j)
            code.store(delta_y, F, j)
            code.store(b.fsub(b.fmul(h, f_old), delta_y), code.row(F, 1, n_state), j)
            code.store(b.fsub(b.fmul(_double(2.0), delta_y), b.fmul(h, b.fadd(f_new, f_old))),
                       code.row(F, 2, n_state), j)
            for row in range(tables.DOP853_INTERPOLATOR_POWER - 3):
                total = _double(0.0)
                for r in range(tables.DOP853_N_STAGES_EXTENDED):
                    k = code.load(code.row(K, r, n_state), j)
                    total = b.fadd(total, b.fmul(_double(tables.DOP853_D[row, r]), k))
                code.store(b.fmul(h, total), code.row(F, 3 + row, n_state), j)

    def dop853_sample(self, x) -> None:
        code, b = self.code, self.code.b
        power = tables.DOP853_INTERPOLATOR_POWER
        with code.loop(self.n_state, "dop853_sample") as j:
            value = _double(0.0)
            for i in range(power):
                value = b.fadd(value, code.load(code.row(self.F, power - 1 - i, self.n_state), j))
                value = b.fmul(value, x if i % 2 == 0 else b.fsub(_double(1.0), x))
            code.store(b.fadd(value, code.load(self.y, j)), self.y_stage, j)

    def rk45_sample(self, x, h) -> None:
        code, b = self.code, self.code.b
        p0 = x
        p1 = b.fmul(p0, x)
        p2 = b.fmul(p1, x)
        p3 = b.fmul(p2, x)
        with code.loop(self.n_state, "rk45_sample") as j:
            q = [_double(0.0)] * 4
            for r in range(tables.RK45_N_STAGES + 1):
                k = code.load(code.row(self.K, r, self.n_state), j)
                q = [b.fadd(q[c], b.fmul(k, _double(tables.RK45_P[r, c]))) for c in range(4)]
            total = b.fadd(b.fadd(b.fadd(b.fmul(q[0], p0), b.fmul(q[1], p1)), b.fmul(q[2], p2)), b.fmul(q[3], p3))
            code.store(b.fadd(b.fmul(h, total), code.load(self.y, j)), self.y_stage, j)


def integrators_ir(methods=None) -> str:
    """The module's IR text: the drivers of ``methods`` (default: both) and their inlined helpers."""
    return str(integrators_module(methods))


def integrators_module(methods=None) -> ir.Module:
    """:func:`integrators_ir`'s module before it is written out (:mod:`physics.codegen.specialised_ir` adds one
    system's specialised entry points to it)."""
    module = ir.Module(name="linkage_lab_integrators")
    fused = _fused_rhs(module)
    two_rows = _two_row_test(module)
    gram = _gram_test(module)
    linear = add_linear_functions(module)
    evaluate = _evaluate(module, fused, linear)
    project = ProjectionFunctions(module, linear).project
    for name in (FUNCTION_NAMES if methods is None else methods):
        _Driver(module, _Method(name), evaluate, two_rows, gram, project).emit()
    return module
