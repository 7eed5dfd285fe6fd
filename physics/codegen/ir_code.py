"""The few pieces every generated IR function of the project's own (the integrators' drivers, the linear
solves, the samples' pass) is written with: LLVM types, constants, and :class:`_Code`, a function under
construction whose scalars live in promoted allocas and whose loops are plain blocks.

Arithmetic is emitted one IEEE operation at a time, without fast-math flags: LLVM may neither reassociate nor
contract it, so the machine code computes what the numba kernels compute, bit for bit."""

from __future__ import annotations

from contextlib import contextmanager

from llvmlite import ir

_DOUBLE = ir.DoubleType()
_I64 = ir.IntType(64)
_BOOL = ir.IntType(1)
_DOUBLE_POINTER = _DOUBLE.as_pointer()
_I64_POINTER = _I64.as_pointer()


def _double(value: float) -> ir.Constant:
    return ir.Constant(_DOUBLE, float(value))


def _int(value: int) -> ir.Constant:
    return ir.Constant(_I64, int(value))


class _Code:
    """An IR function under construction: mutable scalars live in entry-block allocas (promoted to registers by
    LLVM's mem2reg), loops and branches are plain blocks."""

    def __init__(self, function: ir.Function) -> None:
        self.function = function
        self.allocas = function.append_basic_block("allocas")
        self.b = ir.IRBuilder(function.append_basic_block("start"))
        self._alloca_builder = ir.IRBuilder(self.allocas)

    def seal(self) -> None:
        """The alloca block falls through to the code (called once everything is emitted)."""
        self._alloca_builder.branch(self.function.blocks[1])

    def var(self, initial) -> ir.AllocaInstr:
        slot = self._alloca_builder.alloca(initial.type)
        self.b.store(initial, slot)
        return slot

    def get(self, slot):
        return self.b.load(slot)

    def set(self, slot, value) -> None:
        self.b.store(value, slot)

    def block(self, name: str) -> ir.Block:
        return self.function.append_basic_block(name)

    def at(self, pointer, index):
        return self.b.gep(pointer, [index], inbounds=True)

    def load(self, pointer, index):
        return self.b.load(self.at(pointer, index))

    def store(self, value, pointer, index) -> None:
        self.b.store(value, self.at(pointer, index))

    def row(self, pointer, row: int, n_state):
        """Row ``row`` of a row-major matrix of ``n_state`` columns."""
        return self.at(pointer, self.b.mul(_int(row), n_state))

    @contextmanager
    def loop(self, stop, name: str = "loop", start=None):
        """``for i in range(start, stop)`` (start 0 by default): yields ``i``."""
        counter = self.var(_int(0) if start is None else start)
        test, body, done = self.block(f"{name}.test"), self.block(f"{name}.body"), self.block(f"{name}.done")
        self.b.branch(test)
        self.b.position_at_end(test)
        index = self.get(counter)
        self.b.cbranch(self.b.icmp_signed("<", index, stop), body, done)
        self.b.position_at_end(body)
        yield index
        self.set(counter, self.b.add(index, _int(1)))
        self.b.branch(test)
        self.b.position_at_end(done)

    def jump(self, target: ir.Block) -> None:
        """Branch to ``target``; code emitted after it lands in a fresh (unreachable) block."""
        self.b.branch(target)
        self.b.position_at_end(self.block("after"))

    def fabs(self, x):
        return self.b.call(self.intrinsic("llvm.fabs", [_DOUBLE]), [x])

    def sqrt(self, x):
        return self.b.call(self.intrinsic("llvm.sqrt", [_DOUBLE]), [x])

    def pow(self, x, y):
        return self.b.call(self.intrinsic("llvm.pow", [_DOUBLE]), [x, y])

    def intrinsic(self, name: str, types):
        return self.function.module.declare_intrinsic(name, types)

    def minimum(self, accumulator, value):
        """numba's ``min(accumulator, value)`` for floats: ``value if value < accumulator else accumulator``."""
        return self.b.select(self.b.fcmp_ordered("<", value, accumulator), value, accumulator)

    def maximum(self, accumulator, value):
        """numba's ``max(accumulator, value)``: ``value if value > accumulator else accumulator``."""
        return self.b.select(self.b.fcmp_ordered(">", value, accumulator), value, accumulator)

    def finite(self, x):
        """``np.isfinite(x)``: |x| < inf (false for NaN)."""
        return self.b.fcmp_ordered("<", self.fabs(x), _double(float("inf")))

    def to_double(self, integer):
        return self.b.sitofp(integer, _DOUBLE)
