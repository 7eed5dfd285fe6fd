"""Compile a generated module's LLVM IR to machine code in this process, and hand its addresses to the kernels.

The functions come out as plain C function pointers; the once-compiled kernels take their addresses as
integers (:func:`physics.kernels.abi.call_native`). Compiling a 10-bar mechanism's IR takes a small fraction of
a second, which is still most of a warm run: the machine code is kept in the private cache
(:mod:`physics.codegen.machine_code`, authenticated like every cache file) and a later process loads it.
"""

from __future__ import annotations

import threading

from .machine_code import compile_module, defined_functions, llvm_binding

FUNCTION_NAMES = ("assemble", "mass_and_force", "solve", "rhs", "constraints", "kinematics", "sample")
_lock = threading.Lock()  # one compilation at a time: LLVM's global state is not ours to share carelessly
VARIANT = "system-O2"  # the passes of _optimize and code generation at level 2 (the object file's key)


def _target_machine():
    """A target machine for the host CPU (its vector units included). An execution engine takes ownership of
    the one it is given, so every engine (and every pass pipeline) gets its own."""
    llvm = llvm_binding()
    return llvm.Target.from_default_triple().create_target_machine(
        cpu=llvm.get_host_cpu_name(), features=llvm.get_host_cpu_features().flatten(), opt=2,
        codemodel="jitdefault",
    )


def _optimize(module) -> None:
    """LLVM's standard O2 pipeline: instruction combining, scheduling, vectorising of the straight-line code."""
    llvm = llvm_binding()
    machine = _target_machine()
    options = llvm.create_pipeline_tuning_options(speed_level=2)
    builder = llvm.create_pass_builder(machine, options)
    passes = builder.getModulePassManager()
    passes.run(module, builder)


class NativeModule:
    """The machine code of one generated module: ``addresses[name]`` for each function in its IR, valid while
    this object lives (it holds the execution engine that owns the code)."""

    def __init__(self, ir_text: str) -> None:
        with _lock:
            self._engine = compile_module(ir_text, VARIANT, _optimize, _target_machine)
            defined = defined_functions(ir_text)
            self.addresses = {name: int(self._engine.get_function_address(name)) for name in FUNCTION_NAMES
                              if name in defined}
