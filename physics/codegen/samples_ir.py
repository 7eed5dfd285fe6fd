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


def _solve_states(module: ir.Module, linear: LinearFunctions) -> None:
    """system.solve_states: make_system's fresh arrays, then per row solve_system (unknowns_into, and the
    constraints' geometric test when there are constraints, the larger ratio kept as numba's ``max``)."""
    code = _external(module, "solve_states", [_I64, _I64_POINTER, _I64] + [_DOUBLE_POINTER] * 3
                     + [_DOUBLE, _DOUBLE] + [_DOUBLE_POINTER] * 3)
    assemble, layout, rows, theta, omega, params, alpha, beta, x_out, cond_out, scratch = code.function.args
    b = code.b
    n = code.load(layout, _int(LAYOUT_COORDINATES))
    k = code.load(layout, _int(LAYOUT_UNKNOWNS))
    r = code.load(layout, _int(LAYOUT_CONSTRAINTS))
    r_rows = b.select(b.icmp_signed(">", r, _int(1)), r, _int(1))
    A = scratch
    b_vector = code.at(A, b.mul(k, k))
    x = code.at(b_vector, k)
    col_scale = code.at(x, k)
    J = code.at(col_scale, k)
    v = code.at(J, b.mul(r_rows, n))
    G = code.at(v, b.mul(_int(2), r_rows))
    _fill(code, A, b.mul(k, k), 0.0, "zero_matrix")
    _fill(code, col_scale, k, 1.0, "unit_scale")
    with code.loop(rows, "row") as row:
        theta_row = code.at(theta, b.mul(row, n))
        omega_row = code.at(omega, b.mul(row, n))
        ratio = b.call(linear.unknowns, [assemble, layout, A, b_vector, x, col_scale, J, v, theta_row, omega_row,
                                         params, alpha, beta])
        result = code.var(ratio)
        with b.if_then(b.icmp_signed("!=", r, _int(0))):
            geometric = b.call(linear.constraint_ratio, [layout, J, v, G, theta_row, omega_row, params])
            code.set(result, code.maximum(ratio, geometric))
        code.store(code.get(result), cond_out, row)
        with code.loop(k, "copy") as j:
            code.store(code.load(x, j), x_out, b.add(b.mul(row, k), j))
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


def _chain_observables(module: ir.Module) -> None:
    """observables.chain_observables, statement for statement."""
    code = _external(module, "chain_observables", [_I64, _I64] + [_DOUBLE_POINTER] * 6
                     + [_DOUBLE, _I64, _DOUBLE, _DOUBLE] + [_DOUBLE_POINTER] * 5)
    (rows, n, theta, omega, L, d, m, inertia, g, trace_bar, trace_along, trace_across, joints, trace_xy, kinetic,
     potential, tip_velocity) = code.function.args
    b = code.b
    sin = code.intrinsic("llvm.sin", [_DOUBLE])
    cos = code.intrinsic("llvm.cos", [_DOUBLE])
    joint_row = b.mul(b.add(n, _int(1)), _int(2))
    with code.loop(rows, "sample") as t:
        x, y, vx, vy = (code.var(_double(0.0)) for _ in range(4))
        energy_kinetic, energy_potential = code.var(_double(0.0)), code.var(_double(0.0))
        joints_t = code.at(joints, b.mul(t, joint_row))
        code.store(_double(0.0), joints_t, _int(0))
        code.store(_double(0.0), joints_t, _int(1))
        with code.loop(n, "bar") as i:
            angle = b.load(_entry(code, theta, t, i, n))
            s, c = b.call(sin, [angle]), b.call(cos, [angle])
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
    b.ret_void()
    code.seal()


def _chain_joint_reactions(module: ir.Module) -> None:
    """observables.chain_joint_reactions, statement for statement (``pinned``: the pin's force on the last bar
    is taken off, ``tip_reaction`` (rows, 2))."""
    code = _external(module, "chain_joint_reactions", [_I64, _I64] + [_DOUBLE_POINTER] * 6
                     + [_DOUBLE, _I64] + [_DOUBLE_POINTER] * 2)
    rows, n, theta, omega, theta_ddot, L, d, m, g, pinned, tip_reaction, joint_reactions = code.function.args
    b = code.b
    sin = code.intrinsic("llvm.sin", [_DOUBLE])
    cos = code.intrinsic("llvm.cos", [_DOUBLE])
    row_length = b.mul(n, _int(2))

    def reaction(t, i, axis: int):
        return code.at(joint_reactions, b.add(b.add(b.mul(t, row_length), b.mul(i, _int(2))), _int(axis)))

    with code.loop(rows, "sample") as t:
        sum_x, sum_y = code.var(_double(0.0)), code.var(_double(0.0))
        with code.loop(n, "bar") as i:
            angle = b.load(_entry(code, theta, t, i, n))
            s, c = b.call(sin, [angle]), b.call(cos, [angle])
            w = b.load(_entry(code, omega, t, i, n))
            w2 = b.fmul(w, w)
            acceleration = b.load(_entry(code, theta_ddot, t, i, n))
            ax = b.fsub(b.fmul(acceleration, c), b.fmul(w2, s))
            ay = b.fadd(b.fmul(acceleration, s), b.fmul(w2, c))
            L_i, d_i, m_i = code.load(L, i), code.load(d, i), code.load(m, i)
            lever_x, lever_y = b.fmul(L_i, ax), b.fmul(L_i, ay)
            code.set(sum_x, b.fadd(code.get(sum_x), lever_x))
            code.set(sum_y, b.fadd(code.get(sum_y), lever_y))
            b.store(b.fmul(m_i, b.fadd(b.fsub(code.get(sum_x), lever_x), b.fmul(d_i, ax))), reaction(t, i, 0))
            y_value = b.fadd(b.fmul(m_i, b.fadd(b.fsub(code.get(sum_y), lever_y), b.fmul(d_i, ay))), b.fmul(m_i, g))
            b.store(y_value, reaction(t, i, 1))
        last = b.sub(n, _int(1))
        with b.if_then(b.icmp_signed("!=", pinned, _int(0))):
            for axis in (0, 1):
                target = reaction(t, last, axis)
                tip = code.load(tip_reaction, b.add(b.mul(t, _int(2)), _int(axis)))
                b.store(b.fsub(b.load(target), tip), target)
        with code.loop(b.sub(n, _int(1)), "inwards") as step:
            i = b.sub(b.sub(n, _int(2)), step)
            for axis in (0, 1):
                target = reaction(t, i, axis)
                b.store(b.fadd(b.load(reaction(t, b.add(i, _int(1)), axis)), b.load(target)), target)
    b.ret_void()
    code.seal()


def samples_ir() -> str:
    """The module's IR text: the four entry points and the general solve they call."""
    module = ir.Module(name="linkage_lab_samples")
    linear = LinearFunctions(module)
    _solve_states(module, linear)
    _assemble_states(module)
    _chain_observables(module)
    _chain_joint_reactions(module)
    return str(module)
