"""LinearSystem -> Python source of a numba module (common subexpressions hoisted, no sympy at run time).

The generated module holds only the mechanism's own arithmetic: ``assemble`` fills ``A`` and ``b`` entry by
entry from the state and the parameter vector (and, for Lagrange, ``mass_and_force`` the Lagrangian's
pieces), straight-line code over raw pointers. Everything generic (Baumgarte terms, the solve and its
singularity detector, every integrator) lives in :mod:`physics.kernels`, compiled once for all mechanisms.
"""

from __future__ import annotations

import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

from ..derive.formulation import LinearSystem


class _Printer(PythonCodePrinter):
    """Prints ``math.sin`` etc. with the module's ``import math``; powers of 2 as products (cheaper in numba)."""

    def _print_Pow(self, expr, rational=False):
        base, exp = expr.as_base_exp()
        if exp == 2:
            return f"({self._print(base)})*({self._print(base)})"
        if exp == -1:
            return f"1.0/({self._print(base)})"
        return super()._print_Pow(expr, rational=rational)


def _index_literal(values) -> str:
    return "[" + ", ".join(str(int(v)) for v in values) + "]"


def _function(name, doc, entries, s, printer, matrix_size) -> list:
    """Lines of one straight-line function over raw pointers: unpack the state and the parameters, then write
    ``entries`` (``(row, col)`` of the row-major matrix of size ``matrix_size``, or ``("b", i)`` of the vector)."""
    replacements, reduced = sp.cse([e for _, e in entries], symbols=sp.numbered_symbols("_t"), order="none")
    matrix, vector = ("A", "b") if name == "assemble" else ("M", "force")
    lines = ["", "", f"def {name}(theta, omega, params, {matrix}, {vector}):", f'    """{doc}"""']
    for i in range(len(s.theta)):
        lines.append(f"    {s.theta[i]} = theta[{i}]")
        lines.append(f"    {s.omega[i]} = omega[{i}]")
    for idx, sym in enumerate(s.params):
        lines.append(f"    {sym} = params[{idx}]")
    for sym, expr in replacements:
        lines.append(f"    {sym} = {printer.doprint(expr)}")
    for (target, _), expr in zip(entries, reduced):
        if target[0] == "v":
            lines.append(f"    {vector}[{target[1]}] = {printer.doprint(expr)}")
        else:
            lines.append(f"    {matrix}[{target[0] * matrix_size + target[1]}] = {printer.doprint(expr)}")
    return lines


def emit_module(system: LinearSystem, header: str) -> str:
    """Source text of the generated module for ``system`` (see physics/kernels/abi.py for its contract).

    The module is plain Python over raw pointers (``A[i * k + j]``): it imports nothing but ``math``, and the
    loader compiles its functions with ``numba.cfunc`` on first use."""
    s = system.symbols
    n = system.n
    k = len(system.unknowns)
    printer = _Printer({"standard": "python3"})

    entries = []  # (target, expression)
    for i in range(k):
        for j in range(k):
            if system.A[i, j] != 0:
                entries.append(((i, j), system.A[i, j]))
    for i in range(k):
        entries.append((("v", i), system.b[i]))

    lines = []
    lines.append(header.rstrip() + "\n")
    lines.append("import math\n")
    lines.append(f"N_LINKS = {n}")
    lines.append(f"N_UNKNOWNS = {k}")
    lines.append(f"PINNED = {bool(system.pinned)}")
    lines.append(f"THETA_DDOT_INDEX = {_index_literal(system.theta_ddot_index)}")
    flat = [v for pair in system.reaction_index for v in pair]
    lines.append(f"REACTION_INDEX = {_index_literal(flat)}  # pairs (x, y)")
    lines.append(f"TIP_REACTION_INDEX = {_index_literal(system.tip_reaction_index or ())}")
    lines.append(f"TIP_ROWS = {_index_literal(system.tip_rows or ())}")
    lines.append(f"HAS_LAGRANGIAN = {system.mass_matrix is not None}")
    # Lagrange's open-chain matrix is the mass matrix itself: symmetric positive definite, solved by Cholesky.
    symmetric = system.mass_matrix is not None and not system.pinned and system.A.is_symmetric()
    lines.append(f"SYMMETRIC = {bool(symmetric)}")
    lines += _function(
        "assemble",
        "Fill A (k x k, row-major, zeroed by the caller) and b (k,) of A x = b at one state.",
        entries, s, printer, k,
    )
    if system.mass_matrix is not None:
        pieces = [((i, j), system.mass_matrix[i, j]) for i in range(n) for j in range(n)
                  if system.mass_matrix[i, j] != 0]
        pieces += [(("v", i), system.lagrangian_force[i]) for i in range(n)]
        lines += _function(
            "mass_and_force",
            "The Lagrangian's mass matrix d2T/domega2 (n x n, row-major, zeroed by the caller) and force "
            "dL/dtheta + Q (n,), for the variational integrator.",
            pieces, s, printer, n,
        )
    return "\n".join(lines) + "\n"
