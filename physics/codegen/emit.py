"""LinearSystem -> Python source of a numba module (common subexpressions hoisted, no sympy at run time).

The generated module fills ``A`` and ``b`` entry by entry from the state and the parameter vector, applies
Baumgarte terms to the tip rows when asked, and solves with a small LU factorisation with partial pivoting
whose pivot ratio doubles as a cheap singularity detector. The integrator kernels
(``physics/simulate/kernels.py``) are appended to the same file, so numba compiles the whole right-hand side
and the integration loop together and caches them beside the file.
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


def _function(signature, doc, first_line, entries, s, printer) -> list:
    """Lines of one ``@njit`` function that unpacks the state and parameters and writes ``entries``."""
    replacements, reduced = sp.cse([e for _, e in entries], symbols=sp.numbered_symbols("_t"), order="none")
    lines = ["", "@njit(cache=True)", f"def {signature}:", f'    """{doc}"""']
    for i in range(len(s.theta)):
        lines.append(f"    {s.theta[i]} = theta[{i}]")
        lines.append(f"    {s.omega[i]} = omega[{i}]")
    for idx, sym in enumerate(s.params):
        lines.append(f"    {sym} = params[{idx}]")
    lines.append(f"    {first_line}")
    for sym, expr in replacements:
        lines.append(f"    {sym} = {printer.doprint(expr)}")
    for (target, _), expr in zip(entries, reduced):
        lines.append(f"    {target} = {printer.doprint(expr)}")
    return lines


def emit_module(system: LinearSystem, header: str, kernels_source: str) -> str:
    """Source text of the generated module for ``system`` (see docs/architecture.md for its API)."""
    s = system.symbols
    n = system.n
    k = len(system.unknowns)
    printer = _Printer({"standard": "python3"})

    entries = []  # (target, expression)
    for i in range(k):
        for j in range(k):
            if system.A[i, j] != 0:
                entries.append((f"A[{i}, {j}]", system.A[i, j]))
    for i in range(k):
        entries.append((f"b[{i}]", system.b[i]))

    lines = []
    lines.append(header.rstrip() + "\n")
    lines.append("import math\n\nimport numpy as np\nfrom numba import njit\n")
    lines.append(f"N_LINKS = {n}")
    lines.append(f"N_UNKNOWNS = {k}")
    lines.append(f"PINNED = {bool(system.pinned)}")
    lines.append(f"THETA_DDOT_INDEX = np.array({_index_literal(system.theta_ddot_index)}, dtype=np.int64)")
    flat = [v for pair in system.reaction_index for v in pair]
    lines.append(f"REACTION_INDEX = np.array({_index_literal(flat)}, dtype=np.int64).reshape(-1, 2)")
    tip_reaction = system.tip_reaction_index or ()
    lines.append(f"TIP_REACTION_INDEX = np.array({_index_literal(tip_reaction)}, dtype=np.int64)")
    tip_rows = system.tip_rows or ()
    lines.append(f"TIP_ROWS = np.array({_index_literal(tip_rows)}, dtype=np.int64)")
    lines.append(f"HAS_LAGRANGIAN = {system.mass_matrix is not None}")
    lines.append("")
    lines += _function(
        "assemble(theta, omega, params, A, b)",
        "Fill A (k, k) and b (k,) of A x = b at one state; entries not written are zero.",
        "A[:, :] = 0.0", entries, s, printer,
    )
    if system.mass_matrix is not None:
        pieces = [(f"M[{i}, {j}]", system.mass_matrix[i, j]) for i in range(n) for j in range(n)
                  if system.mass_matrix[i, j] != 0]
        pieces += [(f"force[{i}]", system.lagrangian_force[i]) for i in range(n)]
        lines += _function(
            "mass_and_force(theta, omega, params, M, force)",
            "The Lagrangian's mass matrix d2T/domega2 (n, n) and force dL/dtheta + Q (n,), for the "
            "variational integrator.",
            "M[:, :] = 0.0", pieces, s, printer,
        )
    else:
        lines += [
            "",
            "@njit(cache=True)",
            "def mass_and_force(theta, omega, params, M, force):",
            '    """Not available: this formulation has no Lagrangian (the variational integrator needs one)."""',
            "    M[:, :] = np.nan",
            "    force[:] = np.nan",
        ]
    lines.append("")
    lines.append(_SOLVE_SOURCE)
    lines.append(kernels_source)
    return "\n".join(lines) + "\n"


_SOLVE_SOURCE = '''
# Entries below this fraction of the largest are rounding noise (about 500 units in the last place).
RELATIVE_NOISE = 1e-13
# Above this pivot ratio the fast solve is redone with equilibration (well below the singular threshold).
RESCALE_ABOVE = 1e4

@njit(cache=True)
def lu_solve(A, b, x):
    """Solve A x = b in place by Gaussian elimination with partial pivoting (the fast path).

    Returns the ratio of the largest to the smallest pivot magnitude, infinite when a pivot vanishes.
    """
    k = A.shape[0]
    largest = 0.0
    smallest = np.inf
    for col in range(k):
        pivot_row = col
        pivot_abs = abs(A[col, col])
        for row in range(col + 1, k):
            value = abs(A[row, col])
            if value > pivot_abs:
                pivot_abs = value
                pivot_row = row
        if pivot_abs == 0.0 or not np.isfinite(pivot_abs):
            for i in range(k):
                x[i] = np.nan
            return np.inf
        if pivot_row != col:
            for j in range(col, k):
                tmp = A[col, j]
                A[col, j] = A[pivot_row, j]
                A[pivot_row, j] = tmp
            tmp = b[col]
            b[col] = b[pivot_row]
            b[pivot_row] = tmp
        largest = max(largest, pivot_abs)
        smallest = min(smallest, pivot_abs)
        inv = 1.0 / A[col, col]
        for row in range(col + 1, k):
            factor = A[row, col] * inv
            if factor != 0.0:
                for j in range(col + 1, k):
                    A[row, j] -= factor * A[col, j]
                b[row] -= factor * b[col]
    for i in range(k - 1, -1, -1):
        acc = b[i]
        for j in range(i + 1, k):
            acc -= A[i, j] * x[j]
        x[i] = acc / A[i, i]
    return largest / smallest


@njit(cache=True)
def lu_solve_equilibrated(A, b, x):
    """Solve A x = b in place: equilibrate rows and columns, then Gaussian elimination with partial pivoting.

    Returns the ratio of the largest to the smallest pivot magnitude of the equilibrated matrix: a cheap
    estimate of the condition number, infinite when a pivot vanishes (the configuration is singular).
    Equilibrating first keeps mere differences of scale (a very light tip, stiff mass ratios) from
    looking like a singular position.
    """
    k = A.shape[0]
    col_scale = np.empty(k)
    overall = 0.0
    for row in range(k):
        for j in range(k):
            overall = max(overall, abs(A[row, j]))
    if not (overall > 0.0 and np.isfinite(overall)):
        for i in range(k):
            x[i] = np.nan
        return np.inf
    # A row or column that is rounding noise next to the rest of the matrix (cos(pi/2) = 6e-17 in a loop
    # constraint) is a zero row: scaling it up would hide a singular position behind a solvable matrix.
    noise = RELATIVE_NOISE * overall
    for row in range(k):
        biggest = 0.0
        for j in range(k):
            biggest = max(biggest, abs(A[row, j]))
        if biggest <= noise:
            for i in range(k):
                x[i] = np.nan
            return np.inf
        if np.isfinite(biggest):
            inv = 1.0 / biggest
            for j in range(k):
                A[row, j] *= inv
            b[row] *= inv
    for j in range(k):
        biggest = 0.0
        for row in range(k):
            biggest = max(biggest, abs(A[row, j]))
        if biggest <= RELATIVE_NOISE:  # rows are now of size 1
            for i in range(k):
                x[i] = np.nan
            return np.inf
        col_scale[j] = 1.0 / biggest if np.isfinite(biggest) else 1.0
        for row in range(k):
            A[row, j] *= col_scale[j]
    ratio = lu_solve(A, b, x)
    for i in range(k):
        x[i] *= col_scale[i]
    return ratio


@njit(cache=True)
def _system(theta, omega, params, alpha, beta, A, b):
    """A and b at one state, with Baumgarte terms on the tip rows of a pinned chain."""
    assemble(theta, omega, params, A, b)
    if PINNED and (alpha != 0.0 or beta != 0.0):
        n = N_LINKS
        tip_x = 0.0
        tip_y = 0.0
        vel_x = 0.0
        vel_y = 0.0
        for i in range(n):
            s = math.sin(theta[i])
            c = math.cos(theta[i])
            tip_x += params[i] * s
            tip_y -= params[i] * c
            vel_x += params[i] * c * omega[i]
            vel_y += params[i] * s * omega[i]
        b[TIP_ROWS[0]] -= 2.0 * alpha * vel_x + beta * beta * (tip_x - params[4 * n + 1])
        b[TIP_ROWS[1]] -= 2.0 * alpha * vel_y + beta * beta * (tip_y - params[4 * n + 2])


@njit(cache=True)
def solve_full(theta, omega, params, alpha, beta, x):
    """All unknowns x (k,) at one state; Baumgarte with gains alpha, beta on the tip rows of a pinned chain.

    Returns the condition estimate (inf when singular). The fast path is a plain pivoted LU; only when its
    pivot ratio looks singular is the system rebuilt and solved again equilibrated, so that a mere difference
    of scale (a very light tip, a stiff mass ratio) is not mistaken for a singular position. A closed chain's
    geometric singularity (all links lined up) is judged on the loop Jacobian itself.
    """
    A = np.empty((N_UNKNOWNS, N_UNKNOWNS))
    b = np.empty(N_UNKNOWNS)
    _system(theta, omega, params, alpha, beta, A, b)
    ratio = lu_solve(A, b, x)
    if not ratio <= RESCALE_ABOVE:
        _system(theta, omega, params, alpha, beta, A, b)
        ratio = lu_solve_equilibrated(A, b, x)
    if PINNED:
        ratio = max(ratio, loop_ratio(theta, params))
    return ratio


@njit(cache=True)
def loop_ratio(theta, params):
    """sigma_max / sigma_min of the 2 x n loop Jacobian d(tip)/d(theta); inf when it loses rank."""
    jxx = 0.0
    jyy = 0.0
    jxy = 0.0
    for i in range(N_LINKS):
        cx = params[i] * math.cos(theta[i])
        sy = params[i] * math.sin(theta[i])
        jxx += cx * cx
        jyy += sy * sy
        jxy += cx * sy
    half_trace = 0.5 * (jxx + jyy)
    gap = math.sqrt(max(0.0, half_trace * half_trace - (jxx * jyy - jxy * jxy)))
    smallest = half_trace - gap
    if not smallest > 0.0:
        return np.inf
    return math.sqrt((half_trace + gap) / smallest)


@njit(cache=True)
def accel(theta, omega, params, alpha, beta, theta_ddot):
    """Angular accelerations (n,) at one state; returns the condition estimate."""
    x = np.empty(N_UNKNOWNS)
    cond = solve_full(theta, omega, params, alpha, beta, x)
    for i in range(N_LINKS):
        theta_ddot[i] = x[THETA_DDOT_INDEX[i]]
    return cond


@njit(cache=True)
def accel_batch(theta, omega, params, alpha, beta, theta_ddot):
    """accel over a batch: theta, omega, theta_ddot of shape (K, n); params (P,) shared by all."""
    for row in range(theta.shape[0]):
        accel(theta[row], omega[row], params, alpha, beta, theta_ddot[row])


@njit(cache=True)
def solve_full_batch(theta, omega, params, alpha, beta, x, cond):
    """solve_full over a batch: x (K, k), cond (K,)."""
    for row in range(theta.shape[0]):
        cond[row] = solve_full(theta[row], omega[row], params, alpha, beta, x[row])
'''
