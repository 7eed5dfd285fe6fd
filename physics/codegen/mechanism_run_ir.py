"""A mechanism's compiled run and its samples' calls as one native call, written as LLVM IR: what
:func:`physics.codegen.mechanism_run.observe` did between its native calls in Python (the rows finite
throughout, the states split into ``x`` and ``v``, the kinematics' zero times) and the calls themselves, through
the functions' addresses (a ctypes call costs 3 to 6 us, its arguments converted one by one; a run of seed case C
made five of them). The same functions are called with the same arguments in the same order, so the same bits.

Entry points (C calling convention)::

    i64 mechanism_run(i64* plan, double* values, double t0, double t_end, double rtol, double atol, double alpha,
                      double beta, i64 project, i64 max_steps, double g)
    void mechanism_solve_samples(i64* plan, double* values, i64 rows, double alpha, double beta, double g,
                                 double* spare)

``plan`` (:data:`~physics.codegen.mechanism_run.PLAN_SLOTS` int64, made once per run shape and functions by
:mod:`physics.codegen.mechanism_run`): the functions (driver, solve, ``solve_pose_states``, the system's
``sample``, ``native_states``, ``assemble_states``, ``mechanism_observables``), the system's ``assemble`` and
kinematics functions (a non-zero ``sample``: the solve and the kinematics of each sample in one call of it,
``solve_pose_states``, instead of ``solve_states`` then ``native_states``; the same bits), the layouts' and the
observables plan's addresses, the sizes, then the offsets (in doubles) of the buffer's parts, and
``solve_samples`` (0: no sample solved, the plan's observables read the states and the kinematics alone, the
solve left to :func:`~physics.codegen.mechanism_run.solve_samples` for whoever reads its results). ``values``: the
run's buffer, its inputs copied in and ``y_out`` filled with NaN. Returns the driver's status and writes the
number of rows finite throughout (``physics.simulate.run``'s rule: NaN or an infinity anywhere in a row) as a
double at the ``rows`` offset; then copies up to two runs of the observables' points out on their own (a run of
count 0 copies nothing), so that a caller's per-point arrays are C-contiguous without a copy in numpy.

``mechanism_solve_samples`` is the samples' pass alone, over the first ``rows`` rows of a buffer a run of
``mechanism_run`` filled without solving its samples: its ``plan`` is the one the run would have had to solve
them (the same slots), the solve's and the observables' results written at the buffer's offsets but the points,
velocities and energies, which go to ``spare`` (``4 rows P + 3 rows`` doubles) so the run's own stay as they are.
"""

from __future__ import annotations

from llvmlite import ir

from .ir_code import _DOUBLE, _DOUBLE_POINTER, _I64, _I64_POINTER, _Code, _double, _int
from .mechanism_run import PLAN_SLOTS

NAME = "mechanism_run"
SOLVE_NAME = "mechanism_solve_samples"
_VOID_P = ir.IntType(8).as_pointer()
_DRIVER = ir.FunctionType(_I64, [_I64, _VOID_P, _VOID_P, _DOUBLE, _DOUBLE, _VOID_P, _I64, _VOID_P, _DOUBLE, _DOUBLE,
                                 _DOUBLE, _DOUBLE, _I64, _I64, _VOID_P, _VOID_P, _VOID_P, _VOID_P])
_SOLVE = ir.FunctionType(ir.VoidType(), [_I64, _VOID_P, _I64, _VOID_P, _VOID_P, _VOID_P, _DOUBLE, _DOUBLE, _VOID_P,
                                         _VOID_P, _VOID_P])
_SOLVE_POSE = ir.FunctionType(ir.VoidType(), [_I64, _VOID_P, _I64, _VOID_P, _VOID_P, _VOID_P, _DOUBLE, _DOUBLE,
                                              _VOID_P, _VOID_P, _VOID_P, _VOID_P, _VOID_P, _I64, _I64])
_STATES = ir.FunctionType(ir.VoidType(), [_I64, _VOID_P, _I64, _VOID_P, _VOID_P, _VOID_P, _VOID_P, _I64, _I64,
                                          _VOID_P, _VOID_P])
_ASSEMBLE = ir.FunctionType(ir.VoidType(), [_I64, _VOID_P, _I64, _VOID_P, _VOID_P, _VOID_P, _VOID_P, _VOID_P])
_OBSERVABLES = ir.FunctionType(ir.VoidType(), [_VOID_P, _VOID_P, _VOID_P, _I64, _I64, _DOUBLE, _VOID_P, _VOID_P,
                                               _I64, _VOID_P, _VOID_P, _VOID_P, _VOID_P, _VOID_P, _VOID_P, _VOID_P,
                                               _VOID_P])


class _PlanReader:
    """Reads a plan's slots in the IR being written: its integers, its functions, the buffer's parts."""

    def __init__(self, code: _Code, plan, values) -> None:
        self.code, self.plan, self.values = code, plan, values

    def slot(self, name: str):
        return self.code.load(self.plan, _int(PLAN_SLOTS.index(name)))

    def function(self, name: str, kind: ir.FunctionType):
        return self.code.b.inttoptr(self.slot(name), kind.as_pointer())

    def part(self, name: str):
        """The address of the buffer's part ``name`` (an offset in doubles), as ``i8*``."""
        return self.code.b.bitcast(self.code.at(self.values, self.slot(name)), _VOID_P)

    def address(self, name: str):
        return self.code.b.inttoptr(self.slot(name), _VOID_P)


def _samples_pass(code: _Code, plan, values, filled, alpha, beta, g, points, velocities, energies) -> None:
    """The calls over the ``filled`` rows of ``x``, ``v`` (and the kinematics' zero times) that the plan names:
    the solve and the kinematics (by the generated sample in one call per sample, or the solve when
    ``solve_samples`` is not 0 and the kinematics when ``size`` is not 0), the matrices, then the observables,
    whose points, velocities and energies go to the given addresses."""
    b = code.b

    read = _PlanReader(code, plan, values)
    slot, function, part, address = read.slot, read.function, read.part, read.address

    n, size = slot("n"), slot("size")
    layout = address("layout")
    has_rows = b.icmp_signed(">", filled, _int(0))
    pose_width = b.sdiv(b.mul(size, _int(8)), _int(3))  # pose, bias (3 B each), each body's cosine and sine
    with b.if_else(b.icmp_signed("!=", slot("sample"), _int(0))) as (in_one_call, separately):
        with in_one_call:  # the solve and the kinematics by the generated sample, one call per sample
            b.call(function("solve_pose", _SOLVE_POSE), [
                slot("sample"), layout, filled, part("x"), part("v"), part("solve_params"), alpha, beta, part("full"),
                part("condition"), part("solve_scratch"), part("pose_jacobian"), part("pose_vector"),
                b.mul(size, n), pose_width])
        with separately:
            with b.if_then(b.icmp_signed("!=", slot("solve_samples"), _int(0))):  # 0: left to solve_samples
                b.call(function("solve", _SOLVE), [slot("assemble"), layout, filled, part("x"), part("v"),
                                                   part("solve_params"), alpha, beta, part("full"),
                                                   part("condition"), part("solve_scratch")])
            with b.if_then(b.and_(b.icmp_signed("!=", size, _int(0)), has_rows)):
                b.call(function("states", _STATES), [
                    slot("kinematics"), layout, filled, part("zeros"), part("x"), part("v"),
                    part("kinematics_params"), b.mul(size, n), pose_width, part("pose_jacobian"), part("pose_vector")])
    with b.if_then(b.and_(b.icmp_signed("!=", slot("matrices"), _int(0)), has_rows)):
        b.call(function("assemble_states", _ASSEMBLE), [
            slot("assemble"), layout, filled, part("x"), part("v"), part("solve_params"), part("matrices_at"),
            part("rhs")])
    b.call(function("observables", _OBSERVABLES), [
        address("shape"), address("indices"), address("constants"), filled, slot("tree"), g, part("x"), part("v"),
        n, part("full"), part("pose_jacobian"), part("pose_vector"), part("scratch"), points, velocities, energies,
        part("reactions")])


def _solve_samples(module: ir.Module) -> None:
    """:data:`SOLVE_NAME`: the samples' pass of a run that left it (the plan of the run's full observables)."""
    code = _Code(ir.Function(module, ir.FunctionType(ir.VoidType(), [
        _I64_POINTER, _DOUBLE_POINTER, _I64, _DOUBLE, _DOUBLE, _DOUBLE, _DOUBLE_POINTER]), SOLVE_NAME))
    plan, values, rows, alpha, beta, g, spare = code.function.args
    b = code.b
    count = b.mul(rows, _PlanReader(code, plan, values).slot("count"))
    points = b.bitcast(spare, _VOID_P)
    velocities = b.bitcast(code.at(spare, b.mul(count, _int(2))), _VOID_P)
    energies = b.bitcast(code.at(spare, b.mul(count, _int(4))), _VOID_P)
    _samples_pass(code, plan, values, rows, alpha, beta, g, points, velocities, energies)
    b.ret_void()
    code.seal()


def _run(module: ir.Module) -> None:
    code = _Code(ir.Function(module, ir.FunctionType(_I64, [
        _I64_POINTER, _DOUBLE_POINTER, _DOUBLE, _DOUBLE, _DOUBLE, _DOUBLE, _DOUBLE, _DOUBLE, _I64, _I64, _DOUBLE]),
        NAME))
    plan, values, t0, t_end, rtol, atol, alpha, beta, project, max_steps, g = code.function.args
    b = code.b

    read = _PlanReader(code, plan, values)
    slot, function, part, address = read.slot, read.function, read.part, read.address

    samples, n = slot("samples"), slot("n")
    counts = b.bitcast(values, _VOID_P)
    t_reached = b.bitcast(code.at(values, _int(3)), _VOID_P)
    status = b.call(function("driver", _DRIVER), [
        slot("assemble"), address("integration_layout"), part("y0"), t0, t_end, part("t_eval"), samples,
        part("params"), rtol, atol, alpha, beta, project, max_steps, part("y_out"), part("driver_scratch"), counts,
        t_reached])
    # the rows finite throughout: every entry of the row finite (a sum finite means every entry is)
    width = b.mul(n, _int(2))
    y_out = code.at(values, slot("y_out"))
    rows = code.var(_int(0))
    with code.loop(samples, "rows") as row:
        finite = code.var(ir.Constant(ir.IntType(1), 1))
        start = b.mul(row, width)
        with code.loop(width, "entries") as entry:
            value = code.load(y_out, b.add(start, entry))
            code.set(finite, b.and_(code.get(finite), code.finite(value)))
        code.set(rows, b.add(code.get(rows), b.zext(code.get(finite), _I64)))
    filled = code.get(rows)
    code.store(code.to_double(filled), values, slot("rows"))
    x, v, zeros = code.at(values, slot("x")), code.at(values, slot("v")), code.at(values, slot("zeros"))
    with code.loop(filled, "split") as row:
        start = b.mul(row, width)
        with code.loop(n, "coordinates") as i:
            at = b.add(b.mul(row, n), i)
            code.store(code.load(y_out, b.add(start, i)), x, at)
            code.store(code.load(y_out, b.add(b.add(start, n), i)), v, at)
        code.store(_double(0.0), zeros, row)
    _samples_pass(code, plan, values, filled, alpha, beta, g, part("points"), part("velocities"), part("energies"))
    # each run of points asked for, copied out on its own: (rows, count, 2) of the points (rows, P, 2)
    points, row_width = code.at(values, slot("points")), b.mul(slot("count"), _int(2))
    for number in range(2):
        first, count = slot(f"run_first_{number}"), slot(f"run_count_{number}")
        target, width = code.at(values, slot(f"run_at_{number}")), b.mul(count, _int(2))
        with code.loop(filled, f"run{number}") as row:
            source = b.add(b.mul(row, row_width), b.mul(first, _int(2)))
            with code.loop(width, f"run{number}.entries") as entry:
                code.store(code.load(points, b.add(source, entry)), target, b.add(b.mul(row, width), entry))
    b.ret(status)
    code.seal()


def run_ir() -> str:
    """The module's IR text: :data:`NAME`."""
    module = ir.Module(name="linkage_lab_mechanism_run")
    _run(module)
    _solve_samples(module)
    return str(module)
