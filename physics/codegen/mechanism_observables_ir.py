"""What a mechanism run reports of every sample besides its solve, written as LLVM IR: one native call over the
samples, generic in the bodies, the points and the reaction rows (nothing here knows a chain).

Entry point (C calling convention)::

    void mechanism_observables(i64* shape, i64* indices, double* constants, i64 rows, i64 tree, double g,
                               double* x, double* v, i64 state_stride, double* full, double* pose_jacobian,
                               double* pose_vector, double* scratch, double* points, double* velocities,
                               double* energies, double* reactions)

``shape = [n, B, k, P, R]``: coordinates, bodies, unknowns of the solve, points, reaction rows.
``indices = [acceleration (n), rotation (B)]``: where each coordinate's acceleration is among the unknowns, and
which coordinate is each body's rotation (absolute rotations). ``constants = [mass_diagonal (3 B),
constant_force (3 B), damping (3 B x 3 B), linear (3 B x R), unknowns_map (k x R), origin (P x 2), to_x (2 B x P),
to_y (2 B x P)]`` row-major. Per sample ``t``: row ``t`` of ``x``, ``v`` starts at ``t * state_stride`` (a run's
states ``[x, v]`` read in place); ``full (rows, k)`` the solve's unknowns; for ``tree`` (a tree formulation)
``pose_jacobian (rows, 3 B, n)`` and ``pose_vector (rows, 6 B)`` (pose, then bias) of the generated kinematics.
Outputs: ``points`` and ``velocities (rows, P, 2)``, ``energies (3, rows)`` (kinetic, potential, total) and
``reactions (rows, R)``. ``scratch``: :func:`~physics.codegen.mechanism_observables.scratch_length` doubles.

What each output is (:mod:`physics.codegen.mechanism_observables` says why paths): point ``p`` at ``origin_p +
[cos phi, sin phi] @ to_x[:, p]`` (and ``y``), its velocity the same product with ``[-omega sin phi, omega cos
phi]``; points ``0 .. B-1`` are the bodies' centres of mass, whose velocities and heights give ``1/2 sum (m v^2
+ I omega^2)`` and ``sum m g y``; the reaction rows ``(M qddot - Q) @ linear + full @ unknowns_map`` with
``qdot = J v``, ``qddot = J a + bias`` and ``Q = constant_force + damping @ qdot`` for a tree formulation (Newton's
second law on every body in closed form, :mod:`physics.mechanism.tree_reactions`: ``unknowns_map`` takes a
loop's cut pins' multipliers), ``full @ unknowns_map`` alone otherwise (the DAE's own multipliers). Each sum is
taken in index order, one IEEE operation at a time.
"""

from __future__ import annotations

from llvmlite import ir

from .ir_code import _DOUBLE, _DOUBLE_POINTER, _I64, _I64_POINTER, _Code, _double, _int

NAME = "mechanism_observables"


def _dot(code: _Code, count, first, second, start, name: str):
    """``start + sum_j first(j) * second(j)`` for ``j < count``, in order."""
    b = code.b
    total = code.var(start)
    with code.loop(count, name) as j:
        code.set(total, b.fadd(code.get(total), b.fmul(first(j), second(j))))
    return code.get(total)


def _observables(module: ir.Module) -> None:
    code = _Code(ir.Function(module, ir.FunctionType(ir.VoidType(), [
        _I64_POINTER, _I64_POINTER, _DOUBLE_POINTER, _I64, _I64, _DOUBLE, _DOUBLE_POINTER, _DOUBLE_POINTER, _I64,
        _DOUBLE_POINTER, _DOUBLE_POINTER, _DOUBLE_POINTER, _DOUBLE_POINTER, _DOUBLE_POINTER, _DOUBLE_POINTER,
        _DOUBLE_POINTER, _DOUBLE_POINTER]), NAME))
    (shape, indices, constants, rows, tree, g, x, v, state_stride, full, pose_jacobian, pose_vector, scratch,
     points, velocities, energies, reactions) = code.function.args
    b = code.b
    n, bodies, k, count, R = (code.load(shape, _int(i)) for i in range(5))
    size = b.mul(bodies, _int(3))
    turning = b.mul(bodies, _int(2))
    acceleration_index = indices
    rotation_index = code.at(indices, n)
    mass = constants
    constant_force = code.at(mass, size)
    damping = code.at(constant_force, size)
    linear = code.at(damping, b.mul(size, size))
    unknowns_map = code.at(linear, b.mul(size, R))
    origin = code.at(unknowns_map, b.mul(k, R))
    to_x = code.at(origin, b.mul(count, _int(2)))
    to_y = code.at(to_x, b.mul(turning, count))
    turns = scratch
    rates = code.at(turns, turning)
    qdot = code.at(rates, turning)
    qddot = code.at(qdot, size)
    imbalance = code.at(qddot, size)
    sin = code.intrinsic("llvm.sin", [_DOUBLE])
    cos = code.intrinsic("llvm.cos", [_DOUBLE])
    zero = _double(0.0)
    with code.loop(rows, "sample") as t:
        x_row = code.at(x, b.mul(t, state_stride))
        v_row = code.at(v, b.mul(t, state_stride))
        full_row = code.at(full, b.mul(t, k))
        with code.loop(bodies, "turn") as body:
            coordinate = code.load(rotation_index, body)
            angle, spin = code.load(x_row, coordinate), code.load(v_row, coordinate)
            c, s = b.call(cos, [angle]), b.call(sin, [angle])
            code.store(c, turns, body)
            code.store(s, turns, b.add(bodies, body))
            code.store(b.fmul(b.fneg(spin), s), rates, body)
            code.store(b.fmul(spin, c), rates, b.add(bodies, body))
        points_row = code.at(points, b.mul(t, b.mul(count, _int(2))))
        velocities_row = code.at(velocities, b.mul(t, b.mul(count, _int(2))))
        with code.loop(count, "point") as p:
            for axis, table in ((0, to_x), (1, to_y)):
                def column(j, table=table):
                    return code.load(table, b.add(b.mul(j, count), p))
                place = _dot(code, turning, lambda j: code.load(turns, j), column,
                             code.load(origin, b.add(b.mul(p, _int(2)), _int(axis))), "place")
                code.store(place, points_row, b.add(b.mul(p, _int(2)), _int(axis)))
                speed = _dot(code, turning, lambda j: code.load(rates, j), column, zero, "speed")
                code.store(speed, velocities_row, b.add(b.mul(p, _int(2)), _int(axis)))
        kinetic, potential = code.var(zero), code.var(zero)
        with code.loop(bodies, "energy") as body:
            m = code.load(mass, b.mul(body, _int(3)))
            inertia = code.load(mass, b.add(b.mul(body, _int(3)), _int(2)))
            vx = code.load(velocities_row, b.mul(body, _int(2)))
            vy = code.load(velocities_row, b.add(b.mul(body, _int(2)), _int(1)))
            spin = code.load(v_row, code.load(rotation_index, body))
            term = b.fadd(b.fmul(m, b.fadd(b.fmul(vx, vx), b.fmul(vy, vy))), b.fmul(inertia, b.fmul(spin, spin)))
            code.set(kinetic, b.fadd(code.get(kinetic), term))
            y = code.load(points_row, b.add(b.mul(body, _int(2)), _int(1)))
            code.set(potential, b.fadd(code.get(potential), b.fmul(b.fmul(m, g), y)))
        half_kinetic = b.fmul(_double(0.5), code.get(kinetic))
        code.store(half_kinetic, energies, t)
        code.store(code.get(potential), energies, b.add(rows, t))
        code.store(b.fadd(half_kinetic, code.get(potential)), energies, b.add(b.add(rows, rows), t))
        reactions_row = code.at(reactions, b.mul(t, R))
        with b.if_else(b.icmp_signed("!=", tree, _int(0))) as (is_tree, is_not):
            with is_tree:
                jacobian = code.at(pose_jacobian, b.mul(t, b.mul(size, n)))
                bias = code.at(pose_vector, b.add(b.mul(t, b.mul(size, _int(2))), size))
                with code.loop(size, "qdot") as i:
                    def entry(j, i=i):
                        return code.load(jacobian, b.add(b.mul(i, n), j))
                    code.store(_dot(code, n, entry, lambda j: code.load(v_row, j), zero, "velocity"), qdot, i)
                    code.store(b.fadd(_dot(code, n, entry,
                                           lambda j: code.load(full_row, code.load(acceleration_index, j)), zero,
                                           "acceleration"),
                                      code.load(bias, i)), qddot, i)
                with code.loop(size, "imbalance") as i:
                    applied = _dot(code, size, lambda j: code.load(qdot, j),
                                   lambda j, i=i: code.load(damping, b.add(b.mul(j, size), i)),
                                   code.load(constant_force, i), "applied")
                    code.store(b.fsub(b.fmul(code.load(mass, i), code.load(qddot, i)), applied), imbalance, i)
                with code.loop(R, "tree_row") as r:
                    code.store(_dot(code, size, lambda j: code.load(imbalance, j),
                                    lambda j, r=r: code.load(linear, b.add(b.mul(j, R), r)), zero, "newton"),
                               reactions_row, r)
            with is_not:
                with code.loop(R, "clear") as r:
                    code.store(zero, reactions_row, r)
        with code.loop(R, "row") as r:
            held = _dot(code, k, lambda j: code.load(full_row, j),
                        lambda j, r=r: code.load(unknowns_map, b.add(b.mul(j, R), r)), code.load(reactions_row, r),
                        "held")
            code.store(held, reactions_row, r)
    b.ret_void()
    code.seal()


def observables_ir() -> str:
    """The module's IR text: :data:`NAME`."""
    module = ir.Module(name="linkage_lab_mechanism_observables")
    _observables(module)
    return str(module)
