"""The RK45 and DOP853 drivers of :mod:`physics.codegen.integrator_ir`, compiled once per installation (the machine code kept in the cache) and called.

:func:`integrate` answers a run exactly as :func:`physics.kernels.explicit_rk.integrate_rk45` /
``integrate_dop853`` would, or returns ``None`` when the numba kernel must run it instead: a per-sample
condition asked for (``cond_out`` not empty), or arrays of another type or order than the kernel's. Every other
run is answered, stabilised or not (projection onto the constraints, Baumgarte terms), with or without a
generated fused ``rhs`` (the general solve is IR too, :mod:`physics.codegen.linear_ir`). Arrays are checked as
the kernel checks them (the same ``ValueError`` for a programming error).
"""

from __future__ import annotations

import ctypes
import threading
import time

import numpy as np

from ..kernels.checks import check_arguments
from ..kernels.layout import LAYOUT_CONSTRAINTS, LAYOUT_UNKNOWNS
from .integrator_ir import FUNCTION_NAMES, integrators_ir, scratch_length
from .machine_code import compile_module, llvm_binding, sources_digest

_SIGNATURE = ctypes.CFUNCTYPE(
    ctypes.c_int64, ctypes.c_int64, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_void_p,
    ctypes.c_int64, ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_double, ctypes.c_double,
    ctypes.c_int64, ctypes.c_int64, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p,
)
_lock = threading.Lock()
_compiled: dict = {}
VARIANT = "driver-O0"  # the passes of _promote_registers and code generation at level 0 (the object file's key)


def compile_seconds() -> float:
    """Seconds this process spent building and compiling (or loading) the drivers (0 before the first run)."""
    return float(_compiled.get("seconds", 0.0))


def _target_machine(llvm):
    """The host CPU at LLVM's code generation level 0 (fast instruction selection): the drivers' time goes into
    the generated ``rhs`` they call (compiled at O2 in its own module), so their own compilation is kept short
    (about 0.1 s, against 0.7 s through the O2 pipeline, for a run about 1.3 times as long)."""
    return llvm.Target.from_default_triple().create_target_machine(
        cpu=llvm.get_host_cpu_name(), features=llvm.get_host_cpu_features().flatten(), opt=0, codemodel="jitdefault")


def _promote_registers(llvm, module) -> None:
    """The helpers inlined and the scalars' allocas promoted to registers, nothing else: no pass here
    reassociates or contracts floating-point arithmetic (none is allowed to without fast-math flags)."""
    builder = llvm.create_pass_builder(_target_machine(llvm), llvm.create_pipeline_tuning_options(speed_level=0))
    passes = llvm.create_new_module_pass_manager()
    passes.add_always_inliner_pass()
    passes.add_sroa_pass()
    passes.add_instruction_combine_pass()
    passes.add_simplify_cfg_pass()
    passes.run(module, builder)


def compile_functions(key: str, ir_text, names) -> dict[str, int]:
    """The machine-code addresses of functions ``names`` of the module ``ir_text()`` (IR text of the project's
    own generator), compiled (or loaded from the machine-code cache, :mod:`physics.codegen.machine_code`) on
    the first call for ``key`` in this process and kept for its life; the seconds go to :func:`compile_seconds`.
    ``key`` names the IR among the modules this generator makes: with the digest of its sources it names the
    machine code, so a process that loads it never builds the IR."""
    with _lock:
        modules = _compiled.setdefault("modules", {})
        if key not in modules:
            start = time.perf_counter()
            llvm = llvm_binding()
            engine = compile_module(ir_text, VARIANT, lambda module: _promote_registers(llvm, module),
                                    lambda: _target_machine(llvm), key=f"{key}\n{sources_digest()}")
            _compiled.setdefault("engines", []).append(engine)  # owns the machine code
            modules[key] = {name: engine.get_function_address(name) for name in names}
            _compiled["seconds"] = _compiled.get("seconds", 0.0) + time.perf_counter() - start
        return modules[key]


def _driver(method: str):
    """The ctypes function of ``method``'s driver, compiled on its first use in this process: each method in a
    module of its own, so a run compiles only the driver it calls (half the time of both)."""
    name = FUNCTION_NAMES[method]
    with _lock:
        functions = _compiled.setdefault("functions", {})
        if method in functions:
            return functions[method]
    address = compile_functions(method, lambda: integrators_ir((method,)), (name,))[name]
    with _lock:
        return functions.setdefault(method, _SIGNATURE(address))


def _c_array(array, dtype, ndim: int) -> bool:
    return (isinstance(array, np.ndarray) and array.dtype == dtype and array.flags.c_contiguous
            and array.ndim == ndim)


def integrate(method: str, assemble: int, layout, y0, t0, t_end, t_eval, params, rtol, atol, alpha, beta, project,
              max_steps, y_out, cond_out):
    """The kernel's ``(status, n_steps, n_rhs, t_reached, n_filled)`` for ``method`` ("RK45" or "DOP853"), with
    the kernel's arguments, or ``None`` when the numba kernel must run it (the module docstring says when)."""
    if cond_out.shape[0] != 0:
        return None
    arrays = ((y0, 1), (t_eval, 1), (params, 1), (y_out, 2))
    if not all(_c_array(array, np.float64, ndim) for array, ndim in arrays) or not _c_array(layout, np.int64, 1):
        return None  # the kernel's own typing says what is wrong
    # the kernel's own check (physics.kernels.checks, which numba compiles for the kernel), as plain Python
    check_arguments(layout, y0, t0, t_end, t_eval, params, y_out, cond_out)
    driver = _driver(method)
    own_params = params.copy()  # the driver writes t into it
    scratch = np.empty(scratch_length(method, y0.shape[0], int(layout[LAYOUT_CONSTRAINTS]),
                                     int(layout[LAYOUT_UNKNOWNS])))
    counts = np.zeros(3, dtype=np.int64)
    t_reached = np.zeros(1)
    projecting = bool(project) and layout[LAYOUT_CONSTRAINTS] != 0  # the kernel's _projecting
    y_out.fill(np.nan)
    status = driver(int(assemble), layout.ctypes.data, y0.ctypes.data, float(t0), float(t_end),
                    t_eval.ctypes.data, t_eval.shape[0], own_params.ctypes.data, float(rtol), float(atol),
                    float(alpha), float(beta), int(projecting), int(max_steps), y_out.ctypes.data, scratch.ctypes.data, counts.ctypes.data, t_reached.ctypes.data)
    return int(status), int(counts[0]), int(counts[1]), float(t_reached[0]), int(counts[2])
