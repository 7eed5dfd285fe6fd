"""What a mechanism run reports of every sample besides its solve, written as LLVM IR: one native call over the
samples, generic in the bodies, the points and the reaction rows (nothing here knows a chain).

Entry point (C calling convention)::

    void mechanism_observables(i64* shape, i64* indices, double* constants, i64 rows, i64 tree, double g,
                               double* x, double* v, i64 state_stride, double* full, double* pose_jacobian,
                               double* pose_vector, double* scratch, double* points, double* velocities,
                               double* energies, double* reactions)

``shape = [n, B, k, P, R, E1, E2, E3, E4]``: coordinates, bodies, unknowns of the solve, points, reaction
rows, and the non-zero terms of four constant matrices, each kept as ``E`` triples ``(output, input, weight)``
in the order of the dense product's sums: the points' places (``to_x``, ``to_y``: output ``2 p + axis``, input
the ``[cos phi, sin phi]`` entry), the dampers' force (``damping``, ``3 B x 3 B``), Newton's law (``linear``,
``3 B x R``) and the held unknowns (``unknowns_map``, ``k x R``). ``indices = [acceleration (n), rotation (B),
then each matrix's outputs (E) and inputs (E)]``: where each coordinate's acceleration is among the unknowns,
which coordinate is each body's rotation (absolute rotations), the triples' indices. ``constants =
[mass_diagonal (3 B), constant_force (3 B), origin (P x 2), then each matrix's weights (E)]``. Per sample ``t``: row ``t`` of ``x``, ``v`` starts at ``t * state_stride`` (a run's
states ``[x, v]`` read in place); ``full (rows, k)`` the solve's unknowns; ``pose_jacobian (rows, 3 B, n)`` and
``pose_vector (rows, 8 B)`` (pose, bias, each body's cosine, each body's sine) of the generated kinematics, read
when ``tree`` is 1 (a tree formulation: reactions by Newton's law), 2 (the same, and each body's cosine and sine
read from them rather than evaluated again: they are those of its rotation coordinate) or 3 (not a tree
formulation's reactions, the cosines and sines read); 0: neither.
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
from .ir_shapes import OBSERVABLES_SPECIALISED_NAME

NAME = "mechanism_observables"
SPECIALISED_NAME = OBSERVABLES_SPECIALISED_NAME


def _dot(code: _Code, count, first, second, start, name: str):
    """``start + sum_j first(j) * second(j)`` for ``j < count``, in order."""
    b = code.b
    total = code.var(start)
    with code.loop(count, name) as j:
        code.set(total, b.fadd(code.get(total), b.fmul(first(j), second(j))))
    return code.get(total)


def _sparse(code: _Code, terms, outputs, inputs, weights, source, target, name: str) -> None:
    """``target[outputs[e]] += source[inputs[e]] * weights[e]`` for ``e < terms``, in order: a constant matrix's
    product summed over its non-zeros only (in the order of the dense sum, whose zero terms add nothing)."""
    b = code.b
    with code.loop(terms, name) as e:
        slot = code.at(target, code.load(outputs, e))
        b.store(b.fadd(b.load(slot), b.fmul(code.load(source, code.load(inputs, e)), code.load(weights, e))), slot)


def _observables(module: ir.Module) -> None:
    code = _Code(ir.Function(module, ir.FunctionType(ir.VoidType(), [
        _I64_POINTER, _I64_POINTER, _DOUBLE_POINTER, _I64, _I64, _DOUBLE, _DOUBLE_POINTER, _DOUBLE_POINTER, _I64,
        _DOUBLE_POINTER, _DOUBLE_POINTER, _DOUBLE_POINTER, _DOUBLE_POINTER, _DOUBLE_POINTER, _DOUBLE_POINTER,
        _DOUBLE_POINTER, _DOUBLE_POINTER]), NAME))
    (shape, indices, constants, rows, tree, g, x, v, state_stride, full, pose_jacobian, pose_vector, scratch,
     points, velocities, energies, reactions) = code.function.args
    b = code.b
    n, bodies, k, count, R = (code.load(shape, _int(i)) for i in range(5))
    terms = [code.load(shape, _int(5 + i)) for i in range(4)]  # places, dampers, Newton's law, held unknowns
    size = b.mul(bodies, _int(3))
    turning = b.mul(bodies, _int(2))
    acceleration_index = indices
    rotation_index = code.at(indices, n)
    term_index, term_weight = [], []
    at_index, at_weight = code.at(rotation_index, bodies), code.at(constants, b.add(b.mul(size, _int(2)),
                                                                                    b.mul(count, _int(2))))
    for number in range(4):
        term_index.append((at_index, code.at(at_index, terms[number])))
        term_weight.append(at_weight)
        at_index = code.at(at_index, b.mul(terms[number], _int(2)))
        at_weight = code.at(at_weight, terms[number])
    mass = constants
    constant_force = code.at(mass, size)
    origin = code.at(constant_force, size)
    turns = scratch
    rates = code.at(turns, turning)
    qdot = code.at(rates, turning)
    qddot = code.at(qdot, size)
    imbalance = code.at(qddot, size)
    sin = code.intrinsic("llvm.sin", [_DOUBLE])
    cos = code.intrinsic("llvm.cos", [_DOUBLE])
    zero = _double(0.0)
    place_count = b.mul(count, _int(2))
    pose_width = b.mul(bodies, _int(8))  # a row of the kinematics' vector: pose, bias (3 B each), cos, sin (B each)
    read_turns = b.or_(b.icmp_signed("==", tree, _int(2)), b.icmp_signed("==", tree, _int(3)))
    newton = b.or_(b.icmp_signed("==", tree, _int(1)), b.icmp_signed("==", tree, _int(2)))
    with code.loop(rows, "sample") as t:
        x_row = code.at(x, b.mul(t, state_stride))
        v_row = code.at(v, b.mul(t, state_stride))
        full_row = code.at(full, b.mul(t, k))
        with b.if_else(read_turns) as (kinematics_turns, own_turns):
            with kinematics_turns:  # the kinematics evaluated them at this sample: the same numbers
                turned = code.at(pose_vector, b.add(b.mul(t, pose_width), b.mul(size, _int(2))))
                with code.loop(turning, "read_turn") as j:
                    code.store(code.load(turned, j), turns, j)
            with own_turns:
                with code.loop(bodies, "turn") as body:
                    angle = code.load(x_row, code.load(rotation_index, body))
                    code.store(b.call(cos, [angle]), turns, body)
                    code.store(b.call(sin, [angle]), turns, b.add(bodies, body))
        with code.loop(bodies, "rate") as body:
            spin = code.load(v_row, code.load(rotation_index, body))
            c, s = code.load(turns, body), code.load(turns, b.add(bodies, body))
            code.store(b.fmul(b.fneg(spin), s), rates, body)
            code.store(b.fmul(spin, c), rates, b.add(bodies, body))
        points_row = code.at(points, b.mul(t, place_count))
        velocities_row = code.at(velocities, b.mul(t, place_count))
        with code.loop(place_count, "start") as j:
            code.store(code.load(origin, j), points_row, j)
            code.store(zero, velocities_row, j)
        with code.loop(terms[0], "place") as e:  # the places and their velocities share the terms
            output, term = code.load(term_index[0][0], e), code.load(term_index[0][1], e)
            weight = code.load(term_weight[0], e)
            for source, target in ((turns, points_row), (rates, velocities_row)):
                slot = code.at(target, output)
                b.store(b.fadd(b.load(slot), b.fmul(code.load(source, term), weight)), slot)
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
        with code.loop(R, "clear") as r:
            code.store(zero, reactions_row, r)
        with b.if_then(newton):
            jacobian = code.at(pose_jacobian, b.mul(t, b.mul(size, n)))
            bias = code.at(pose_vector, b.add(b.mul(t, pose_width), size))
            with code.loop(size, "qdot") as i:
                def entry(j, i=i):
                    return code.load(jacobian, b.add(b.mul(i, n), j))
                code.store(_dot(code, n, entry, lambda j: code.load(v_row, j), zero, "velocity"), qdot, i)
                code.store(b.fadd(_dot(code, n, entry,
                                       lambda j: code.load(full_row, code.load(acceleration_index, j)), zero,
                                       "acceleration"),
                                  code.load(bias, i)), qddot, i)
                code.store(code.load(constant_force, i), imbalance, i)  # Q, summed below
            _sparse(code, terms[1], *term_index[1], term_weight[1], qdot, imbalance, "applied")
            with code.loop(size, "imbalance") as i:
                code.store(b.fsub(b.fmul(code.load(mass, i), code.load(qddot, i)), code.load(imbalance, i)),
                           imbalance, i)
            _sparse(code, terms[2], *term_index[2], term_weight[2], imbalance, reactions_row, "newton")
        _sparse(code, terms[3], *term_index[3], term_weight[3], full_row, reactions_row, "held")
    b.ret_void()
    code.seal()


def observables_ir() -> str:
    """The module's IR text: :data:`NAME`."""
    module = ir.Module(name="linkage_lab_mechanism_observables")
    _observables(module)
    return str(module)


def _table(module: ir.Module, name: str, values) -> ir.Constant:
    """A private constant ``i64`` array of ``values``, as an ``i64*`` to its first entry."""
    table_type = ir.ArrayType(_I64, len(values))
    table = ir.GlobalVariable(module, table_type, name)
    table.linkage = "private"
    table.global_constant = True
    table.initializer = ir.Constant(table_type, [ir.Constant(_I64, int(value)) for value in values])
    return table.gep([_int(0), _int(0)])


def specialised_observables_ir(shape, indices, tree: int) -> str:
    """The IR text of :data:`SPECIALISED_NAME`: :data:`NAME` for one structure of plan (its integer ``shape``
    and ``indices`` and whether it is a ``tree``'s, constant tables in the module), of :data:`NAME`'s signature
    whose ``shape``, ``indices`` and ``tree`` arguments it ignores; the constants (masses, forces, weights)
    stay arguments, so every set of parameters of a structure shares its machine code. The generic function
    is called (inlined) with the tables: O2 then knows every size and index, unrolls the loops over bodies,
    points and terms and reads no index at run time (about a quarter of the call for seed case C). The same
    operations in the same order, no fast-math flags: the generic function's bits."""
    module = ir.Module(name="linkage_lab_mechanism_observables_specialised")
    _observables(module)
    generic = module.get_global(NAME)
    generic.linkage = "internal"
    generic.attributes.add("alwaysinline")
    wrapper = ir.Function(module, generic.function_type, SPECIALISED_NAME)
    builder = ir.IRBuilder(wrapper.append_basic_block("entry"))
    arguments = list(wrapper.args)
    arguments[0] = _table(module, "specialised_shape", shape)
    arguments[1] = _table(module, "specialised_indices", indices)
    arguments[4] = _int(int(tree))
    builder.call(generic, arguments)
    builder.ret_void()
    return str(module)
