"""Compile a generated module's LLVM IR to machine code in this process, and hand its addresses to the kernels.

The functions come out as plain C function pointers; the once-compiled kernels take their addresses as
integers (:func:`physics.kernels.abi.call_native`). Compiling a 10-bar mechanism's IR takes a small fraction of
a second, so machine code for generated functions is not cached on disk: there is nothing of it to trust or to
damage.
"""

from __future__ import annotations

import threading

import llvmlite.binding as llvm

FUNCTION_NAMES = ("assemble", "mass_and_force", "solve", "rhs", "constraints", "kinematics")
_lock = threading.Lock()  # one compilation at a time: LLVM's global state is not ours to share carelessly
_initialized: list = []


def _target_machine():
    """A target machine for the host CPU (its vector units included). An execution engine takes ownership of
    the one it is given, so every engine (and every pass pipeline) gets its own."""
    if not _initialized:
        llvm.initialize_native_target()
        llvm.initialize_native_asmprinter()
        _initialized.append(True)
    return llvm.Target.from_default_triple().create_target_machine(
        cpu=llvm.get_host_cpu_name(), features=llvm.get_host_cpu_features().flatten(), opt=2,
        codemodel="jitdefault",
    )


def _optimize(module) -> None:
    """LLVM's standard O2 pipeline: instruction combining, scheduling, vectorising of the straight-line code."""
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
            module = llvm.parse_assembly(ir_text)
            module.verify()
            _optimize(module)
            self._engine = llvm.create_mcjit_compiler(module, _target_machine())
            self._engine.finalize_object()
            defined = {function.name for function in module.functions if not function.is_declaration}
            self.addresses = {name: int(self._engine.get_function_address(name)) for name in FUNCTION_NAMES
                              if name in defined}
