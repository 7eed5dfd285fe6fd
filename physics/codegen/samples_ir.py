"""The samples' pass of a run (:func:`physics.simulate.build.build_trajectory`) written as LLVM IR: no numba.

After an integration, a trajectory solves its system once per sample (the reactions and the condition estimate,
:func:`physics.kernels.system.solve_states`), follows positions, energies and the tip's velocity from the
states (:func:`physics.kernels.observables.chain_observables`) and the joint reactions from the accelerations
(:func:`~physics.kernels.observables.chain_joint_reactions`); a pinned chain's condition number needs its plain
matrices (:func:`physics.kernels.system.assemble_states`). In numba these four kernels cost an empty cache
seconds of compilation; emitted here operation for operation (the general solve from
:mod:`physics.codegen.linear_ir`, ``sin``/``cos`` as numba's ``llvm.sin``/``llvm.cos``, no fast-math), they
compile with the IR drivers' pipeline in a fraction of a second and give the kernels' very bits.

Entry points (C calling convention)::

    void solve_states(i64 assemble, i64* layout, i64 rows, double* theta, double* omega, double* params,
                      double alpha, double beta, double* x_out, double* cond_out, double* scratch)
    void assemble_states(i64 assemble, i64* layout, i64 rows, double* theta, double* omega, double* params,
                         double* A_out, double* b_out)
    void chain_observables(i64 rows, i64 n, double* theta, double* omega, double* L, double* d, double* m,
                           double* inertia, double g, i64 trace_bar, double trace_along, double trace_across,
                           double* joints, double* trace_xy, double* kinetic, double* potential,
                           double* tip_velocity)
    void chain_joint_reactions(i64 rows, i64 n, double* theta, double* omega, double* theta_ddot, double* L,
                               double* d, double* m, double g, i64 pinned, double* tip_reaction,
                               double* joint_reactions)

Arrays are row-major and C-contiguous; ``scratch`` holds
:func:`physics.codegen.ir_shapes.samples_scratch_length` doubles.
"""

from __future__ import annotations

from llvmlite import ir

from ..kernels.layout import LAYOUT_CONSTRAINTS, LAYOUT_COORDINATES, LAYOUT_UNKNOWNS
from .ir_code import _DOUBLE, _DOUBLE_POINTER, _I64, _I64_POINTER, _Code, _double, _int
from .linear_ir import LinearFunctions, _entry, _fill

_POINTER_CALL = ir.FunctionType(ir.VoidType(), [_DOUBLE_POINTER] * 5)


def _external(module: ir.Module, name: str, arguments) -> _Code:
    return _Code(ir.Function(module, ir.FunctionType(ir.VoidType(), arguments), name))


class _SolveScratch:
    """make_system's fresh arrays in ``scratch`` (``A`` zeroed and ``col_scale`` set to one, once for all rows, as
    the kernel makes them) and the sizes read from the layout."""

    def __init__(self, code: _Code, layout, scratch) -> None:
        b = code.b
        self.n = code.load(layout, _int(LAYOUT_COORDINATES))
        self.k = code.load(layout, _int(LAYOUT_UNKNOWNS))
        self.r = code.load(layout, _int(LAYOUT_CONSTRAINTS))
        r_rows = b.select(b.icmp_signed(">", self.r, _int(1)), self.r, _int(1))
        self.A = scratch
        self.b_vector = code.at(self.A, b.mul(self.k, self.k))
        self.x = code.at(self.b_vector, self.k)
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


def _sine_cosine(code: _Code):
    """``trig(angle, i) -> (sin, cos)`` by ``llvm.sin``/``llvm.cos`` (numba's ``np.sin``/``np.cos``)."""
    sin = code.intrinsic("llvm.sin", [_DOUBLE])
    cos = code.intrinsic("llvm.cos", [_DOUBLE])
    return lambda angle, i: (code.b.call(sin, [angle]), code.b.call(cos, [angle]))


def _observables_row(code: _Code, trig, t, n, theta, omega, L, d, m, inertia, g, trace_bar, trace_along,
                     trace_across, joints, trace_xy, kinetic, potential, tip_velocity) -> None:
    """Sample ``t`` of observables.chain_observables, statement for statement; ``trig(angle, i)`` gives bar
    ``i``'s sine and cosine."""
    b = code.b
    joint_row = b.mul(b.add(n, _int(1)), _int(2))
    x, y, vx, vy = (code.var(_double(0.0)) for _ in range(4))
    energy_kinetic, energy_potential = code.var(_double(0.0)), code.var(_double(0.0))
    joints_t = code.at(joints, b.mul(t, joint_row))
    code.store(_double(0.0), joints_t, _int(0))
    code.store(_double(0.0), joints_t, _int(1))
    with code.loop(n, "bar") as i:
        angle = b.load(_entry(code, theta, t, i, n))
        s, c = trig(angle, i)
        w = b.load(_entry(code, omega, t, i, n))
        d_i, m_i, L_i = code.load(d, i), code.load(m, i), code.load(L, i)
        com_y = b.fsub(code.get(y), b.fmul(d_i, c))
        com_vx = b.fadd(code.get(vx), b.fmul(b.fmul(d_i, c), w))
        com_vy = b.fadd(code.get(vy), b.fmul(b.fmul(d_i, s), w))
        speed2 = b.fadd(b.fmul(com_vx, com_vx), b.fmul(com_vy, com_vy))
        spin = b.fmul(b.fmul(code.load(inertia, i), w), w)
        code.set(energy_kinetic, b.fadd(code.get(energy_kinetic),
                                        b.fmul(_double(0.5), b.fadd(b.fmul(m_i, speed2), spin))))
        code.set(energy_potential, b.fadd(code.get(energy_potential), b.fmul(b.fmul(m_i, g), com_y)))
        with b.if_then(b.icmp_signed("==", i, trace_bar)):
            x_now, y_now = code.get(x), code.get(y)
            code.store(b.fadd(b.fadd(x_now, b.fmul(trace_along, s)), b.fmul(trace_across, c)), trace_xy,
                       b.mul(t, _int(2)))
            code.store(b.fadd(b.fsub(y_now, b.fmul(trace_along, c)), b.fmul(trace_across, s)), trace_xy,
                       b.add(b.mul(t, _int(2)), _int(1)))
        code.set(x, b.fadd(code.get(x), b.fmul(L_i, s)))
        code.set(y, b.fsub(code.get(y), b.fmul(L_i, c)))
        code.set(vx, b.fadd(code.get(vx), b.fmul(b.fmul(L_i, c), w)))
        code.set(vy, b.fadd(code.get(vy), b.fmul(b.fmul(L_i, s), w)))
        joint = b.mul(b.add(i, _int(1)), _int(2))
        code.store(code.get(x), joints_t, joint)
        code.store(code.get(y), joints_t, b.add(joint, _int(1)))
    code.store(code.get(energy_kinetic), kinetic, t)
    code.store(code.get(energy_potential), potential, t)
    code.store(code.get(vx), tip_velocity, b.mul(t, _int(2)))
    code.store(code.get(vy), tip_velocity, b.add(b.mul(t, _int(2)), _int(1)))


def _chain_observables(module: ir.Module) -> None:
    """observables.chain_observables, statement for statement."""
    code = _external(module, "chain_observables", [_I64, _I64] + [_DOUBLE_POINTER] * 6
                     + [_DOUBLE, _I64, _DOUBLE, _DOUBLE] + [_DOUBLE_POINTER] * 5)
    rows, n, *arguments = code.function.args
    trig = _sine_cosine(code)
    with code.loop(rows, "sample") as t:
        _observables_row(code, trig, t, n, *arguments)
    code.b.ret_void()
    code.seal()


def _joint_reactions_row(code: _Code, trig, t, n, theta, omega, theta_ddot, L, d, m, g, pinned, tip_reaction,
                         joint_reactions) -> None:
    """Sample ``t`` of observables.chain_joint_reactions, statement for statement (``pinned``: the pin's force
    on the last bar is taken off, ``tip_reaction`` (rows, 2))."""
    b = code.b
    row_length = b.mul(n, _int(2))

    def reaction(i, axis: int):
        return code.at(joint_reactions, b.add(b.add(b.mul(t, row_length), b.mul(i, _int(2))), _int(axis)))

    sum_x, sum_y = code.var(_double(0.0)), code.var(_double(0.0))
    with code.loop(n, "bar") as i:
        angle = b.load(_entry(code, theta, t, i, n))
        s, c = trig(angle, i)
        w = b.load(_entry(code, omega, t, i, n))
        w2 = b.fmul(w, w)
        acceleration = b.load(_entry(code, theta_ddot, t, i, n))
        ax = b.fsub(b.fmul(acceleration, c), b.fmul(w2, s))
        ay = b.fadd(b.fmul(acceleration, s), b.fmul(w2, c))
        L_i, d_i, m_i = code.load(L, i), code.load(d, i), code.load(m, i)
        lever_x, lever_y = b.fmul(L_i, ax), b.fmul(L_i, ay)
        code.set(sum_x, b.fadd(code.get(sum_x), lever_x))
        code.set(sum_y, b.fadd(code.get(sum_y), lever_y))
        b.store(b.fmul(m_i, b.fadd(b.fsub(code.get(sum_x), lever_x), b.fmul(d_i, ax))), reaction(i, 0))
        y_value = b.fadd(b.fmul(m_i, b.fadd(b.fsub(code.get(sum_y), lever_y), b.fmul(d_i, ay))), b.fmul(m_i, g))
        b.store(y_value, reaction(i, 1))
    last = b.sub(n, _int(1))
    with b.if_then(b.icmp_signed("!=", pinned, _int(0))):
        for axis in (0, 1):
            target = reaction(last, axis)
            tip = code.load(tip_reaction, b.add(b.mul(t, _int(2)), _int(axis)))
            b.store(b.fsub(b.load(target), tip), target)
    with code.loop(b.sub(n, _int(1)), "inwards") as step:
        i = b.sub(b.sub(n, _int(2)), step)
        for axis in (0, 1):
            target = reaction(i, axis)
            b.store(b.fadd(b.load(reaction(b.add(i, _int(1)), axis)), b.load(target)), target)


def _chain_joint_reactions(module: ir.Module) -> None:
    """observables.chain_joint_reactions, statement for statement."""
    code = _external(module, "chain_joint_reactions", [_I64, _I64] + [_DOUBLE_POINTER] * 6
                     + [_DOUBLE, _I64] + [_DOUBLE_POINTER] * 2)
    rows, n, *arguments = code.function.args
    trig = _sine_cosine(code)
    with code.loop(rows, "sample") as t:
        _joint_reactions_row(code, trig, t, n, *arguments)
    code.b.ret_void()
    code.seal()


def samples_pass_offsets(code: _Code, rows, n, k, pinned):
    """Where each array of :class:`physics.codegen.native_samples.SampleArrays` starts in ``samples_pass``'s
    ``out`` (in doubles), in the order of ``native_samples.SAMPLE_ARRAYS``, and the length of them all."""
    b = code.b
    widths = [n, n, b.mul(b.add(n, _int(1)), _int(2)), _int(2), _int(1), _int(1), _int(2), k, _int(1), n,
              b.mul(pinned, _int(2)), b.mul(n, _int(2)), _int(1)]
    offsets, offset = [], _int(0)
    for width in widths:
        offsets.append(offset)
        offset = b.add(offset, b.mul(rows, width))
    return offsets, offset


def _samples_pass(module: ir.Module, linear: LinearFunctions) -> None:
    """The whole samples' pass of a run in one call, row by row: the states split into ``theta`` and ``omega``,
    solve_states' row, chain_observables' row, ``energy = kinetic + potential``, the accelerations (and a
    pinned chain's pin force) taken from the unknowns, chain_joint_reactions' row. Each output is computed by
    the same operations as by the separate functions (the same bits); each bar's sine and cosine are computed
    once per sample and read by both the observables and the reactions."""
    code = _external(module, "samples_pass", [_I64, _I64_POINTER, _I64, _DOUBLE_POINTER, _DOUBLE_POINTER, _DOUBLE,
                                              _DOUBLE, _DOUBLE_POINTER, _DOUBLE, _I64, _DOUBLE, _DOUBLE,
                                              _I64_POINTER, _I64_POINTER, _I64, _DOUBLE_POINTER, _DOUBLE_POINTER])
    (assemble, layout, rows, y, params, alpha, beta, bars, g, trace_bar, trace_along, trace_across,
     theta_ddot_index, tip_reaction_index, pinned, out, scratch) = code.function.args
    b = code.b
    parts = _SolveScratch(code, layout, scratch)
    n, k = parts.n, parts.k
    sines = parts.end
    cosines = code.at(sines, n)
    offsets, _ = samples_pass_offsets(code, rows, n, k, pinned)
    (theta, omega, joints, trace_xy, kinetic, potential, tip_velocity, x, cond, theta_ddot, tip_reaction,
     joint_reactions, energy) = (code.at(out, offset) for offset in offsets)
    L, d, m, inertia = (code.at(bars, b.mul(n, _int(i))) for i in range(4))
    sin = code.intrinsic("llvm.sin", [_DOUBLE])
    cos = code.intrinsic("llvm.cos", [_DOUBLE])

    def shared(angle, i):
        return code.load(sines, i), code.load(cosines, i)

    with code.loop(rows, "sample") as t:
        row_start = b.mul(t, n)
        with code.loop(n, "split") as i:
            angle = code.load(y, b.add(b.mul(t, b.mul(n, _int(2))), i))
            code.store(angle, theta, b.add(row_start, i))
            code.store(code.load(y, b.add(b.mul(t, b.mul(n, _int(2))), b.add(n, i))), omega, b.add(row_start, i))
            code.store(b.call(sin, [angle]), sines, i)
            code.store(b.call(cos, [angle]), cosines, i)
        _solve_row(code, linear, parts, assemble, layout, t, code.at(theta, row_start), code.at(omega, row_start),
                   params, alpha, beta, x, cond)
        _observables_row(code, shared, t, n, theta, omega, L, d, m, inertia, g, trace_bar, trace_along,
                         trace_across, joints, trace_xy, kinetic, potential, tip_velocity)
        code.store(b.fadd(code.load(kinetic, t), code.load(potential, t)), energy, t)
        with code.loop(n, "accelerations") as i:
            code.store(code.load(x, b.add(b.mul(t, k), code.load(theta_ddot_index, i))), theta_ddot,
                       b.add(row_start, i))
        with b.if_then(b.icmp_signed("!=", pinned, _int(0))):
            for axis in (0, 1):
                code.store(code.load(x, b.add(b.mul(t, k), code.load(tip_reaction_index, _int(axis)))),
                           tip_reaction, b.add(b.mul(t, _int(2)), _int(axis)))
        _joint_reactions_row(code, shared, t, n, theta, omega, theta_ddot, L, d, m, g, pinned, tip_reaction,
                             joint_reactions)
    b.ret_void()
    code.seal()


def add_samples_pass(module: ir.Module, linear: LinearFunctions) -> None:
    """``samples_pass`` added to ``module`` (:mod:`physics.codegen.specialised_ir` specialises it)."""
    _samples_pass(module, linear)


def samples_ir() -> str:
    """The module's IR text: the five entry points and the general solve they call."""
    module = ir.Module(name="linkage_lab_samples")
    linear = LinearFunctions(module)
    _solve_states(module, linear)
    _assemble_states(module)
    _chain_observables(module)
    _chain_joint_reactions(module)
    _samples_pass(module, linear)
    return str(module)
