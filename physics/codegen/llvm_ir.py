"""sympy expressions -> LLVM IR text: a mechanism's straight-line arithmetic, compiled without numba's front end.

numba spends almost all of a generated function's compile time typing and lowering it one operation at a
time in Python (about 3 s for the 10-bar Newton-Euler matrix); the same arithmetic written as LLVM IR compiles in
a fraction of that. The IR is plain IEEE arithmetic (no fast-math: the same roundings as the Python text would
give), loads from and stores to the pointer arguments of :mod:`physics.kernels.abi`, and calls LLVM's
``llvm.sin.f64``/``llvm.cos.f64``/``llvm.sqrt.f64``/``llvm.pow.f64`` intrinsics.
"""

from __future__ import annotations

import struct

import sympy as sp

_INTRINSICS = {sp.sin: "llvm.sin.f64", sp.cos: "llvm.cos.f64"}
_DECLARATIONS = (
    "declare double @llvm.sin.f64(double)\n"
    "declare double @llvm.cos.f64(double)\n"
    "declare double @llvm.sqrt.f64(double)\n"
    "declare double @llvm.pow.f64(double, double)\n"
    "declare double @llvm.fabs.f64(double)\n"
    "declare double @llvm.maxnum.f64(double, double)\n"
    "declare double @llvm.minnum.f64(double, double)\n"
)


def _constant(value) -> str:
    """A double constant as LLVM writes it exactly: the IEEE bits in hex."""
    return "0x%016X" % struct.unpack(">Q", struct.pack(">d", float(value)))[0]


class _Function:
    """One IR function under construction: SSA names for every sub-expression, computed once."""

    def __init__(self, name: str, arguments: tuple[str, ...], returns: str = "void") -> None:
        self.lines = [f"define {returns} @{name}({', '.join(f'double* noalias %{a}' for a in arguments)}) {{",
                      "entry:"]
        self.values: dict = {}
        self.counter = 0

    def _new(self) -> str:
        self.counter += 1
        return f"%v{self.counter}"

    def emit(self, text: str) -> str:
        name = self._new()
        self.lines.append(f"  {name} = {text}")
        return name

    def load(self, pointer: str, index: int) -> str:
        address = self.emit(f"getelementptr inbounds double, double* %{pointer}, i64 {index}")
        return self.emit(f"load double, double* {address}")

    def store(self, pointer: str, index: int, value: str) -> None:
        address = self.emit(f"getelementptr inbounds double, double* %{pointer}, i64 {index}")
        self.lines.append(f"  store double {value}, double* {address}")

    def _fold(self, op: str, operands: list[str]) -> str:
        result = operands[0]
        for operand in operands[1:]:
            result = self.emit(f"{op} double {result}, {operand}")
        return result

    def _power(self, base: str, exponent: int) -> str:
        """base**exponent for a positive integer by repeated squaring."""
        result, square = None, base
        while exponent:
            if exponent & 1:
                result = square if result is None else self.emit(f"fmul double {result}, {square}")
            exponent >>= 1
            if exponent:
                square = self.emit(f"fmul double {square}, {square}")
        assert result is not None  # exponent >= 1: at least one factor was multiplied in
        return result

    def value(self, expr) -> str:
        if expr in self.values:
            return self.values[expr]
        if expr.is_Number:
            return _constant(expr)
        if expr.is_Add:
            result = self._fold("fadd", [self.value(arg) for arg in expr.args])
        elif expr.is_Mul:
            coefficient, factors = expr.as_coeff_mul()
            operands = [self.value(f) for f in factors]
            if coefficient == -1:
                result = self.emit(f"fneg double {self._fold('fmul', operands)}")
            elif coefficient != 1:
                result = self._fold("fmul", [_constant(coefficient)] + operands)
            else:
                result = self._fold("fmul", operands)
        elif expr.is_Pow:
            base, exponent = expr.as_base_exp()
            b = self.value(base)
            if exponent.is_Integer and exponent > 0:
                result = self._power(b, int(exponent))
            elif exponent.is_Integer and exponent < 0:
                result = self.emit(f"fdiv double {_constant(1.0)}, {self._power(b, -int(exponent))}")
            elif exponent == sp.Rational(1, 2):
                result = self.emit(f"call double @llvm.sqrt.f64(double {b})")
            else:
                result = self.emit(f"call double @llvm.pow.f64(double {b}, double {self.value(exponent)})")
        elif expr.func in _INTRINSICS:
            (argument,) = expr.args
            result = self.emit(f"call double @{_INTRINSICS[expr.func]}(double {self.value(argument)})")
        else:
            raise NotImplementedError(f"no LLVM translation for {expr.func} in generated code")
        self.values[expr] = result
        return result

    def finish(self, returned: str | None = None) -> str:
        """The function's text, returning ``returned`` (a double's SSA name) or nothing."""
        ret = "  ret void" if returned is None else f"  ret double {returned}"
        return "\n".join(self.lines + [ret, "}"])

    def bind_inputs(self, symbols, exprs, replacements, theta_at: tuple[str, int], omega_at: tuple[str, int]) -> None:
        """Load the coordinates, speeds and parameters that ``exprs`` use (``theta_at``/``omega_at``: the pointer
        argument and the offset each vector starts at; the parameters are ``params``), then compute the
        common subexpressions ``replacements`` once, in their order."""
        used = set().union(*(e.free_symbols for e in exprs)) if exprs else set()
        for (pointer, offset), group in ((theta_at, symbols.theta), (omega_at, symbols.omega),
                                         (("params", 0), symbols.params)):
            for i, sym in enumerate(group):
                if sym in used:
                    self.values[sym] = self.load(pointer, offset + i)
        for sym, expr in replacements:
            self.values[sym] = self.value(expr)


def common_subexpressions(exprs: list) -> tuple[list, list]:
    """sympy's common subexpressions of ``exprs``: ``(replacements, reduced)``, as the generated functions
    hoist them (``assemble`` and the fused ``rhs`` share one result: the same values, computed once)."""
    return sp.cse(exprs, symbols=sp.numbered_symbols("_t"), order="none")


def function_ir(name: str, symbols, entries, matrix_size: int, matrix: str, vector: str, cse=None) -> str:
    """IR of ``name(theta, omega, params, matrix, vector)`` writing ``entries``: ``((row, col), expr)`` into the
    row-major matrix of size ``matrix_size``, or ``(("v", i), expr)`` into the vector. ``cse``: the
    :func:`common_subexpressions` of the entries' expressions when already computed."""
    return fused_function_ir(name, symbols, [(entries, cse)], matrix_size, matrix, vector)


def fused_function_ir(name: str, symbols, groups, matrix_size: int, matrix: str, vector: str) -> str:
    """IR of ``name(theta, omega, params, matrix, vector)`` doing what :func:`function_ir` does for each group
    ``(entries, cse)`` in turn, each as if alone (its own common subexpressions, nothing carried over from the
    group before), so every entry gets the bits of the function that group makes by itself; LLVM's passes then
    compute once what the groups have alike (the sines and cosines of the angles: pure calls on the same
    loads)."""
    function = _Function(name, ("theta", "omega", "params", matrix, vector))
    for entries, cse in groups:
        function.values = {}
        exprs = [e for _, e in entries]
        replacements, reduced = cse if cse is not None else common_subexpressions(exprs)
        function.bind_inputs(symbols, exprs, replacements, ("theta", 0), ("omega", 0))
        for (target, _), expr in zip(entries, reduced):
            if target[0] == "v":
                function.store(vector, target[1], function.value(expr))
            else:
                function.store(matrix, target[0] * matrix_size + target[1], function.value(expr))
    return function.finish()


def module_ir(functions: list[str]) -> str:
    return _DECLARATIONS + "\n" + "\n\n".join(functions) + "\n"


# ---------------------------------------------------------------------------------------------------------------
# A sparse system solved in a fixed order: Gaussian elimination unrolled over the structural non-zeros only
# ---------------------------------------------------------------------------------------------------------------


def safe_pivots(A, vanishing=frozenset()) -> set[tuple[int, int]]:
    """Entries of the symbolic ``A`` that cannot vanish during a run: made of numbers and parameters only (a
    mass, an inertia, 1), never a sine or a cosine of the state, nor a parameter that may be zero in a valid
    model (``vanishing``: a guide's direction component, a point's coordinate)."""
    k = A.shape[0]
    return {(i, j) for i in range(k) for j in range(k)
            if A[i, j] != 0 and not A[i, j].has(sp.sin, sp.cos) and not (A[i, j].free_symbols & vanishing)}


def elimination_order(A, vanishing=frozenset()) -> list[tuple[int, int]] | None:
    """A pivot sequence ``[(row, col), ...]`` for the symbolic matrix ``A``, or None when A is too dense to gain.

    Markowitz's rule on the structure (the fewest fill-ins first), preferring pivots that cannot vanish
    (:func:`safe_pivots`). Fill-in entries count as possibly vanishing. The kernels check every solve by its
    pivot ratio and fall back to a pivoted dense solve when a pivot turns out small. The structure is kept by row
    and by column, so a step counts each candidate's row and column in one lookup (a Jansen leg's 40 unknowns:
    milliseconds, not a quadratic scan of every entry per candidate)."""
    k = A.shape[0]
    by_row: list[set[int]] = [{j for j in range(k) if A[i, j] != 0} for i in range(k)]
    count = sum(len(cols) for cols in by_row)
    if k < 6 or count > 0.4 * k * k:
        return None
    by_col: list[set[int]] = [set() for _ in range(k)]
    for i, cols in enumerate(by_row):
        for j in cols:
            by_col[j].add(i)
    safe = safe_pivots(A, vanishing)
    # by_row/by_col hold only the rows and columns still to eliminate
    remaining = set(range(k))
    order = []
    while remaining:
        best = None
        for i in remaining:
            row_count = len(by_row[i])
            for j in by_row[i]:
                key = ((i, j) not in safe, (row_count - 1) * (len(by_col[j]) - 1), i, j)
                if best is None or key < best:
                    best = key
        if best is None:
            return None  # structurally singular
        _, _, pivot_row, pivot_col = best
        order.append((pivot_row, pivot_col))
        pivot_cols = by_row[pivot_row] - {pivot_col}
        for r in by_col[pivot_col]:
            if r != pivot_row:
                for j in pivot_cols - by_row[r]:  # fill-in
                    by_row[r].add(j)
                    by_col[j].add(r)
        remaining.discard(pivot_row)
        for j in by_row[pivot_row]:
            by_col[j].discard(pivot_row)
        for r in by_col[pivot_col]:
            by_row[r].discard(pivot_col)
        by_row[pivot_row] = set()
        by_col[pivot_col] = set()
    return order


def structured_solve_ir(A, order: list[tuple[int, int]]) -> str:
    """IR of ``double solve(double* A, double* b, double* x)``: Gaussian elimination of ``A x = b`` in the
    fixed ``order``, unrolled over the structural non-zeros of the symbolic ``A`` (row-major, k x k); A and b
    are read only.

    Returns the largest ratio of a pivot row's largest original entry to its pivot (inf when a pivot is zero,
    NaN when one is NaN): how much smaller than its own row's numbers a pivot became, which is what makes an
    unpivoted elimination lose digits. It is independent of the model's units (a ratio of the largest to the
    smallest pivot compared a 0.0006 kg m^2 inertia with a Schur complement of 30 1/kg and made every solve of a
    six-bar look ill-conditioned, 5e4, so each fell back to the dense solve)."""
    k = A.shape[0]
    function = _Function("solve", ("A", "b", "x"), returns="double")
    entry = {}
    for i in range(k):
        for j in range(k):
            if A[i, j] != 0:
                entry[(i, j)] = function.load("A", i * k + j)
    rhs = {i: function.load("b", i) for i in range(k)}
    solution, ratio = _eliminate(function, entry, rhs, k, order)
    for j in range(k):
        function.store("x", j, solution[j])
    return function.finish(ratio)


def structured_rhs_ir(symbols, A, b, order: list[tuple[int, int]], acceleration_index, cse=None) -> str:
    """IR of ``double rhs(double* y, double* params, double* dydt)``: the ODE's right-hand side
    ``dydt = [omega, theta_ddot]`` at the state ``y = [theta, omega]`` in one function, ``A`` and ``b`` built as
    ``assemble`` builds them and eliminated as ``solve`` eliminates them, but in registers: no matrix is zeroed,
    stored or loaded, and entries that are numbers fold into the elimination. The same IEEE operations on the
    same values as ``assemble`` then ``solve`` (the same common subexpressions, the same order), so the same
    bits. Returns ``solve``'s pivot ratio; ``t`` is read from ``params`` as ``assemble`` reads it. ``cse``:
    ``assemble``'s :func:`common_subexpressions` of the same expressions in the same order, when computed."""
    k = A.shape[0]
    n = len(symbols.theta)
    function = _Function("rhs", ("y", "params", "dydt"), returns="double")
    targets = [(i, j) for i in range(k) for j in range(k) if A[i, j] != 0] + [("v", i) for i in range(k)]
    exprs = [A[i, j] for i, j in targets[: len(targets) - k]] + [b[i] for i in range(k)]
    replacements, reduced = cse if cse is not None else common_subexpressions(exprs)
    function.bind_inputs(symbols, exprs, replacements, ("y", 0), ("y", n))
    entry: dict = {}
    rhs: dict = {}
    for target, expr in zip(targets, reduced):
        if target[0] == "v":
            rhs[target[1]] = function.value(expr)
        else:
            entry[target] = function.value(expr)
    solution, ratio = _eliminate(function, entry, rhs, k, order)
    for i in range(n):
        function.store("dydt", i, function.load("y", n + i))
        function.store("dydt", n + i, solution[int(acceleration_index[i])])
    return function.finish(ratio)


def _eliminate(function: _Function, entry: dict, rhs: dict, k: int, order: list[tuple[int, int]]):
    """Emit the elimination of ``A x = b`` in ``order`` over the SSA values ``entry[(row, col)]`` (the
    structural non-zeros) and ``rhs[row]``: returns ``({col: x_col}, pivot ratio)`` (see
    :func:`structured_solve_ir`). ``entry`` and ``rhs`` are consumed."""
    rows, cols = set(range(k)), set(range(k))
    pivots = []  # (row, col, inverse, [(col, value) of the pivot row's remaining entries])
    row_scale = {}  # the largest magnitude among each row's original entries
    for i in range(k):
        scale = _constant(0.0)
        for j in range(k):
            if (i, j) in entry:
                magnitude = function.emit(f"call double @llvm.fabs.f64(double {entry[(i, j)]})")
                scale = function.emit(f"call double @llvm.maxnum.f64(double {scale}, double {magnitude})")
        row_scale[i] = scale
    ratio = probe = _constant(1.0)
    for pivot_row, pivot_col in order:
        pivot = entry[(pivot_row, pivot_col)]
        inverse = function.emit(f"fdiv double {_constant(1.0)}, {pivot}")
        # the row's scale over the pivot as a product with the inverse the elimination needs anyway (a second
        # division per pivot was 3-4 % of seed case C's DAE run); a zero pivot gives inf, a NaN one NaN, as before
        magnitude = function.emit(f"call double @llvm.fabs.f64(double {inverse})")
        shrink = function.emit(f"fmul double {row_scale[pivot_row]}, {magnitude}")
        ratio = function.emit(f"call double @llvm.maxnum.f64(double {ratio}, double {shrink})")
        probe = function.emit(f"fadd double {probe}, {shrink}")  # NaN if any pivot was (maxnum skips NaN)
        remaining = [(c, entry[(pivot_row, c)]) for c in sorted(cols) if c != pivot_col and (pivot_row, c) in entry]
        rows.discard(pivot_row)
        cols.discard(pivot_col)
        for r in sorted(rows):
            if (r, pivot_col) not in entry:
                continue
            factor = function.emit(f"fmul double {entry.pop((r, pivot_col))}, {inverse}")
            for c, value in remaining:
                product = function.emit(f"fmul double {factor}, {value}")
                if (r, c) in entry:
                    entry[(r, c)] = function.emit(f"fsub double {entry[(r, c)]}, {product}")
                else:
                    entry[(r, c)] = function.emit(f"fneg double {product}")
            product = function.emit(f"fmul double {factor}, {rhs[pivot_row]}")
            rhs[r] = function.emit(f"fsub double {rhs[r]}, {product}")
        pivots.append((pivot_row, pivot_col, inverse, remaining))
    solution: dict[int, str] = {}
    for pivot_row, pivot_col, inverse, remaining in reversed(pivots):
        total = rhs[pivot_row]
        for c, value in remaining:
            product = function.emit(f"fmul double {value}, {solution[c]}")
            total = function.emit(f"fsub double {total}, {product}")
        solution[pivot_col] = function.emit(f"fmul double {total}, {inverse}")
    unordered = function.emit(f"fcmp uno double {probe}, {_constant(0.0)}")
    ratio = function.emit(f"select i1 {unordered}, double {probe}, double {ratio}")
    return solution, ratio
