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
)


def _constant(value) -> str:
    """A double constant as LLVM writes it exactly: the IEEE bits in hex."""
    return "0x%016X" % struct.unpack(">Q", struct.pack(">d", float(value)))[0]


class _Function:
    """One IR function under construction: SSA names for every sub-expression, computed once."""

    def __init__(self, name: str, arguments: tuple[str, ...]) -> None:
        self.lines = [f"define void @{name}({', '.join(f'double* noalias %{a}' for a in arguments)}) {{",
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

    def finish(self) -> str:
        return "\n".join(self.lines + ["  ret void", "}"])


def function_ir(name: str, symbols, entries, matrix_size: int, matrix: str, vector: str) -> str:
    """IR of ``name(theta, omega, params, matrix, vector)`` writing ``entries``: ``((row, col), expr)`` into the
    row-major matrix of size ``matrix_size``, or ``(("v", i), expr)`` into the vector."""
    function = _Function(name, ("theta", "omega", "params", matrix, vector))
    exprs = [e for _, e in entries]
    replacements, reduced = sp.cse(exprs, symbols=sp.numbered_symbols("_t"), order="none")
    used = set().union(*(e.free_symbols for e in exprs)) if exprs else set()
    for i, sym in enumerate(symbols.theta):
        if sym in used:
            function.values[sym] = function.load("theta", i)
    for i, sym in enumerate(symbols.omega):
        if sym in used:
            function.values[sym] = function.load("omega", i)
    for i, sym in enumerate(symbols.params):
        if sym in used:
            function.values[sym] = function.load("params", i)
    for sym, expr in replacements:
        function.values[sym] = function.value(expr)
    for (target, _), expr in zip(entries, reduced):
        if target[0] == "v":
            function.store(vector, target[1], function.value(expr))
        else:
            function.store(matrix, target[0] * matrix_size + target[1], function.value(expr))
    return function.finish()


def module_ir(functions: list[str]) -> str:
    return _DECLARATIONS + "\n" + "\n\n".join(functions) + "\n"
