"""LinearSystem -> the generated module: layout constants and LLVM IR (no sympy, no numba front end at run time).

The generated module holds only the mechanism's own arithmetic: ``assemble`` fills ``A`` and ``b`` entry by
entry from the state and the parameter vector (and, for Lagrange, ``mass_and_force`` the Lagrangian's
pieces), straight-line code over raw pointers written as LLVM IR (:mod:`physics.codegen.llvm_ir`). Everything generic (Baumgarte terms, the solve and its
singularity detector, every integrator) lives in :mod:`physics.kernels`, compiled once for all mechanisms.
"""

from __future__ import annotations

import sympy as sp

from ..derive.formulation import LinearSystem
from . import llvm_ir


def _index_literal(values) -> str:
    return "[" + ", ".join(str(int(v)) for v in values) + "]"


def emit_module(system: LinearSystem, header: str) -> str:
    """Source text of the generated module for ``system`` (see physics/kernels/abi.py for its contract).

    The module holds the layout constants and ``LLVM_IR``, the text of ``assemble`` (and, for Lagrange,
    ``mass_and_force``) as LLVM IR, which :mod:`physics.codegen.native` compiles in the loading process."""
    s = system.symbols
    n = system.n
    k = len(system.unknowns)

    entries: list[tuple[tuple[int | str, int], object]] = []  # (target, expression)
    for i in range(k):
        for j in range(k):
            if system.A[i, j] != 0:
                entries.append(((i, j), system.A[i, j]))
    for i in range(k):
        entries.append((("v", i), system.b[i]))
    shared = llvm_ir.common_subexpressions([expr for _, expr in entries])  # assemble's, and the fused rhs's
    functions = [llvm_ir.function_ir("assemble", s, entries, k, "A", "b", cse=shared)]
    if system.mass_matrix is not None and system.lagrangian_force is not None:
        pieces: list[tuple[tuple[int | str, int], object]] = [((i, j), system.mass_matrix[i, j]) for i in range(n) for j in range(n)
                  if system.mass_matrix[i, j] != 0]
        pieces += [(("v", i), system.lagrangian_force[i]) for i in range(n)]
        functions.append(llvm_ir.function_ir("mass_and_force", s, pieces, n, "M", "force"))
    rows, phi, jacobian, rate = system.held_constraints()
    if rows:
        pieces = [((i, j), jacobian[i, j]) for i in range(len(rows)) for j in range(n) if jacobian[i, j] != 0]
        pieces += [(("v", i), phi[i]) for i in range(len(rows))]
        pieces += [(("v", len(rows) + i), rate[i]) for i in range(len(rows))]
        functions.append(llvm_ir.function_ir("constraints", s, pieces, n, "J", "v"))
    angle_index: list[int] = []
    sample_functions: list[str] = []  # a module of its own: compiled with the system's specialised samples' pass
    if system.kinematics is not None:  # tree coordinates: every body's pose, d pose / d theta and the bias
        pose, pose_jacobian, bias = system.kinematics
        size = len(pose)
        angles = [pose[3 * body + 2] for body in range(size // 3)]
        pieces = [((i, j), pose_jacobian[i, j]) for i in range(size) for j in range(n) if pose_jacobian[i, j] != 0]
        pieces += [(("v", i), pose[i]) for i in range(size)] + [(("v", size + i), bias[i]) for i in range(size)]
        # each body's [cos, sin] of its angle: the generated code has them already (its rotations), and a run's
        # observables read them here instead of evaluating them again at every sample
        pieces += [(("v", 2 * size + body), sp.cos(angle)) for body, angle in enumerate(angles)]
        pieces += [(("v", 2 * size + len(angles) + body), sp.sin(angle)) for body, angle in enumerate(angles)]
        kinematics_cse = llvm_ir.common_subexpressions([expr for _, expr in pieces])
        functions.append(llvm_ir.function_ir("kinematics", s, pieces, n, "J", "v", cse=kinematics_cse))
        # a sample's solve and kinematics in one call (the run's samples): assemble's A and b, then after b
        # kinematics' J (row-major) and vector, each evaluated as its own function evaluates it
        after_b: list[tuple[tuple[int | str, int], object]] = [
            (("v", k + size * n + target[1]) if target[0] == "v" else ("v", k + int(target[0]) * n + target[1]), expr)
            for target, expr in pieces]
        sample_functions.append(llvm_ir.fused_function_ir("sample", s, [(entries, shared), (after_b, kinematics_cse)],
                                                          k, "A", "b"))
        theta_index = {symbol: index for index, symbol in enumerate(s.theta)}
        angle_index = [theta_index.get(angle, -1) for angle in angles]
    order = llvm_ir.elimination_order(system.A, system.vanishing_parameters)
    rhs_functions = []  # a module of its own: compiled only by a process that integrates (the kernels' fast path)
    if order is not None:
        functions.append(llvm_ir.structured_solve_ir(system.A, order))
        rhs_functions.append(llvm_ir.structured_rhs_ir(s, system.A, system.b, order, system.theta_ddot_index,
                                                       cse=shared))

    lines = []
    lines.append(header.rstrip() + "\n")
    lines.append(f"N_LINKS = {n}")
    lines.append(f"N_UNKNOWNS = {k}")
    lines.append(f"PINNED = {bool(system.pinned)}")
    lines.append(f"THETA_DDOT_INDEX = {_index_literal(system.theta_ddot_index)}")
    flat = [v for pair in system.reaction_index for v in pair]
    lines.append(f"REACTION_INDEX = {_index_literal(flat)}  # pairs (x, y)")
    lines.append(f"TIP_REACTION_INDEX = {_index_literal(system.tip_reaction_index or ())}")
    lines.append(f"TIP_ROWS = {_index_literal(system.tip_rows or ())}")
    lines.append(f"CONSTRAINT_ROWS = {_index_literal(rows)}  # (A x - b)[row] is phi_i''")
    lines.append(f"TIME_INDEX = {-1 if system.time_index is None else int(system.time_index)}")
    lines.append(f"N_PARAMETERS = {len(s.params)}")
    lines.append(f"MULTIPLIER_INDEX = {_index_literal(system.multiplier_index)}")
    lines.append(f"POSE_SIZE = {0 if system.kinematics is None else len(system.kinematics[0])}  # kinematics()'s 3 B")
    lines.append(f"POSE_ANGLE_INDEX = {_index_literal(angle_index)}  # the coordinate each body's angle is, or -1")
    lines.append(f"HAS_LAGRANGIAN = {system.mass_matrix is not None}")
    # Lagrange's open-chain matrix is the mass matrix itself: symmetric positive definite, solved by Cholesky.
    symmetric = system.mass_matrix is not None and not system.pinned and system.A.is_symmetric(simplify=False)
    lines.append(f"SYMMETRIC = {bool(symmetric)}")
    lines.append(f"STRUCTURED = {order is not None}  # a generated solve for the sparse A (elimination order below)")
    if order is not None:
        lines.append(f"ELIMINATION_ORDER = {[list(pair) for pair in order]}")
    lines.append("")
    lines.append("# assemble(theta, omega, params, A, b): A (k x k, row-major, zeroed by the caller) and b (k,) of")
    lines.append("# A x = b at one state; mass_and_force(theta, omega, params, M, force): the Lagrangian's mass matrix")
    lines.append("# (n x n) and force dL/dtheta + Q (n,); solve(A, b, x) for a sparse A (returns the pivot ratio);")
    lines.append("# rhs(y, params, dydt) for a sparse A: dydt = [omega, theta_ddot] at y = [theta, omega] by assemble and")
    lines.append("# solve in one function (returns solve's pivot ratio);")
    lines.append("# constraints(theta, omega, params, J, v): J (r x n) and v = [phi, phi_dot] of the held constraints;")
    lines.append("# kinematics(theta, omega, params, J, v): tree coordinates' d pose/d theta (3B x n), v = [pose, bias,")
    lines.append("# cos of each body's angle, sin of each body's angle] (3B, 3B, B, B);")
    lines.append("# sample(theta, omega, params, A, out): assemble's A and b = out[:k], then kinematics' J = out[k:k + 3Bn]")
    lines.append("# and v = out[k + 3Bn:] in one call (a run's samples), each entry with its own function's bits.")
    lines.append("# Straight-line IEEE arithmetic, common subexpressions hoisted.")
    lines.append('LLVM_IR = """')
    lines.append(llvm_ir.module_ir(functions).rstrip("\n"))
    lines.append('"""')
    lines.append("# rhs alone: compiled on the first integration (a driven mechanism's position analysis never calls it).")
    lines.append('LLVM_IR_RHS = """')
    lines.append(llvm_ir.module_ir(rhs_functions).rstrip("\n") if rhs_functions else "")
    lines.append('"""')
    lines.append("# sample alone: compiled with the system's specialised samples' pass (a one-off run never calls it).")
    lines.append('LLVM_IR_SAMPLE = """')
    lines.append(llvm_ir.module_ir(sample_functions).rstrip("\n") if sample_functions else "")
    lines.append('"""')
    return "\n".join(lines) + "\n"
