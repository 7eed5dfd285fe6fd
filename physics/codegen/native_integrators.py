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
import importlib
import threading
import time
from collections.abc import Callable

import numpy as np

from ..kernels.checks import check_arguments
from ..kernels.layout import LAYOUT_CONSTRAINTS, LAYOUT_UNKNOWNS
from .ir_shapes import ADDRESS_SLOTS as SPECIALISED_ADDRESS_SLOTS
from .ir_shapes import INTEGRATOR_FUNCTION_NAMES as FUNCTION_NAMES
from .ir_shapes import SPECIALISED_NAMES
from .ir_shapes import integrator_scratch_length as scratch_length
from .ir_shapes import symbol_names as specialised_names
from .machine_code import compile_module, is_cached, llvm_binding, sources_digest

_SIGNATURE = ctypes.CFUNCTYPE(
    ctypes.c_int64, ctypes.c_int64, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_void_p,
    ctypes.c_int64, ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_double, ctypes.c_double,
    ctypes.c_int64, ctypes.c_int64, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p,
)
_lock = threading.Lock()
_compiled: dict = {}
SPECIALISED_VARIANT = "driver-O2"  # LLVM's O2 pipeline and code generation at level 2
VARIANT = "driver-O0"  # the passes of _promote_registers and code generation at level 0 (the object file's key)


def integrators_ir(methods=None) -> str:
    """:func:`physics.codegen.integrator_ir.integrators_ir`, imported on a machine-code cache miss only: a warm
    process loads the drivers' machine code and never needs the IR builders or ``llvmlite.ir``."""
    from .integrator_ir import integrators_ir as build  # noqa: PLC0415  (llvmlite.ir: only on a cache miss)

    return build(methods)


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


def ir_builder(module: str, function: str) -> Callable[[], str]:
    """The IR text of ``physics.codegen.<module>.<function>()``, its module imported when the text is asked for,
    that is on a machine-code cache miss only: a warm process loads the machine code and never imports the IR
    builders or ``llvmlite.ir``."""

    def build() -> str:
        return getattr(importlib.import_module(f".{module}", __package__), function)()

    return build


_tables: dict[str, dict] = {}


def ctypes_functions(key: str, ir_text: Callable[[], str], signatures: dict) -> dict:
    """``{name: ctypes function}`` for every ``name: CFUNCTYPE`` of ``signatures``, the functions of the module
    ``ir_text()`` compiled or loaded once per process under ``key`` (:func:`compile_functions`)."""
    if key not in _tables:
        addresses = compile_functions(key, ir_text, tuple(signatures))
        _tables.setdefault(key, {name: signature(addresses[name]) for name, signature in signatures.items()})
    return _tables[key]


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


def generic_driver(method: str):
    """The ctypes function of ``method``'s generic driver ("RK45" or "DOP853"), compiled or loaded once."""
    return _driver(method)


def specialised_key(method: str, layout: np.ndarray, system_digest: str) -> tuple[list[int], str]:
    """For ``method`` ("RK45", "DOP853", "samples", the samples' solve, or "samples pose", with the solve and
    kinematics in one call too): the layout without its addresses (1 where the system has that function), all of the layout that shapes
    the specialised IR, and the machine-code cache's key of that IR."""
    shape = [1 if slot in SPECIALISED_ADDRESS_SLOTS and value != 0 else int(value) for slot, value in enumerate(layout)]
    return shape, f"specialised {method}\n{shape}\n{system_digest}\n{sources_digest()}"


def specialised_cached(method: str, layout: np.ndarray, system_digest: str) -> bool:
    """Whether the machine code of :func:`specialised_driver` (``method`` "samples":
    :func:`physics.codegen.native_samples.specialised_solve`) for these arguments is in the cache already."""
    return is_cached(specialised_key(method, layout, system_digest)[1], SPECIALISED_VARIANT)


def answers(layout: np.ndarray, alpha, beta, project, cond_out) -> bool:
    """Whether the IR drivers answer a run of these settings (else :func:`integrate` hands it back): every run
    but one that asks for a condition estimate per sample (Baumgarte terms and projection are theirs too)."""
    return cond_out.shape[0] == 0


def specialised_engine(ir_text, layout: np.ndarray, assemble: int, system_digest: str, key: str, sample: int = 0):
    """An engine holding a module of :mod:`physics.codegen.specialised_ir` (``ir_text()`` builds it): the
    system's symbols bound to its addresses (``sample``: the generated ``sample``'s, when the module calls it),
    then compiled at O2 or loaded from the machine-code cache under ``key`` (:func:`specialised_key`)."""
    from . import native  # noqa: PLC0415  (its O2 pipeline and target machine, as for the generated systems)

    names = specialised_names(system_digest)
    start = time.perf_counter()
    # both compile locks: this may run in a background thread (CompiledSystem._specialised) beside a generated
    # module's compilation, and LLVM's global context is not to be shared between two at once
    with _lock, native._lock:
        llvm = llvm_binding()
        llvm.add_symbol(names["assemble"], int(assemble))  # bound before linking, the module or its object file
        if sample:
            llvm.add_symbol(names["sample"], int(sample))
        for slot in SPECIALISED_ADDRESS_SLOTS:
            if layout[slot] != 0:
                llvm.add_symbol(names[str(slot)], int(layout[slot]))
        engine = compile_module(ir_text, SPECIALISED_VARIANT, native._optimize, native._target_machine, key=key)
        _compiled["seconds"] = _compiled.get("seconds", 0.0) + time.perf_counter() - start
    return engine


def specialised_driver(method: str, layout: np.ndarray, assemble: int, system_digest: str):
    """``(driver, engine)``: ``method``'s driver specialised for one system (:mod:`physics.codegen.specialised_ir`),
    a ctypes function of the generic driver's signature valid while ``engine`` lives (the caller keeps it with
    the system whose machine code it calls). ``layout``: the system's integration layout, ``assemble`` its
    ``assemble``'s address, ``system_digest`` a digest of its IR texts (the symbols' names). Compiled at O2 (or
    loaded from the machine-code cache) on the first call for a system in a process."""
    shape, key = specialised_key(method, layout, system_digest)

    def ir_text() -> str:
        from .specialised_ir import specialised_ir  # noqa: PLC0415  (llvmlite.ir: only on a cache miss)

        return specialised_ir(method, shape, system_digest)

    engine = specialised_engine(ir_text, layout, assemble,
                                system_digest, key)
    address = engine.get_function_address(SPECIALISED_NAMES[method])
    return _SIGNATURE(address), engine


_layout_addresses: dict[int, tuple[np.ndarray, int]] = {}
MAX_LAYOUTS = 64  # layouts remembered at once (a few systems'; all forgotten past that)


def layout_address(layout: np.ndarray) -> int:
    """The data address of ``layout``, a C-contiguous int64 array (else ValueError), found once per layout
    object: a system's layout lives as long as the system and is handed over run after run, and an address
    look-up costs 2-3 us (the entry holds the array, so its id is not reused while remembered)."""
    entry = _layout_addresses.get(id(layout))
    if entry is not None and entry[0] is layout:
        return entry[1]
    if not _c_array(layout, np.int64, 1):
        raise ValueError("expected a C-contiguous 1-D int64 layout")
    address = layout.ctypes.data
    with _lock:
        if len(_layout_addresses) >= MAX_LAYOUTS:
            _layout_addresses.clear()
        _layout_addresses[id(layout)] = (layout, address)
    return address


def checked_address(array, shape: tuple, dtype=np.float64) -> int:
    """The address of ``array``'s data after checking it is what the generated code reads: C-contiguous, of
    ``dtype`` and of ``shape`` (None: any length on that axis); else ``ValueError`` before any pointer is handed
    over (the IR modules' checked entry points, :mod:`physics.codegen.native_samples` and
    :mod:`physics.codegen.native_states`)."""
    if not (isinstance(array, np.ndarray) and array.dtype == dtype and array.flags.c_contiguous
            and array.ndim == len(shape) and all(want is None or have == want
                                                 for have, want in zip(array.shape, shape, strict=True))):
        raise ValueError(f"expected a C-contiguous {np.dtype(dtype).name} array of shape {shape}")
    return int(array.ctypes.data)


def _c_array(array, dtype, ndim: int) -> bool:
    return (isinstance(array, np.ndarray) and array.dtype == dtype and array.flags.c_contiguous
            and array.ndim == ndim)


def integrate(method: str, assemble: int, layout, y0, t0, t_end, t_eval, params, rtol, atol, alpha, beta, project,
              max_steps, y_out, cond_out, driver=None):
    """The kernel's ``(status, n_steps, n_rhs, t_reached, n_filled)`` for ``method`` ("RK45" or "DOP853"), with
    the kernel's arguments, or ``None`` when the numba kernel must run it (the module docstring says when).
    ``driver``: the driver :func:`specialised_driver` made for this ``layout`` (default the generic one)."""
    if not answers(layout, alpha, beta, project, cond_out):
        return None
    arrays = ((y0, 1), (t_eval, 1), (params, 1), (y_out, 2))
    if not all(_c_array(array, np.float64, ndim) for array, ndim in arrays) or not _c_array(layout, np.int64, 1):
        return None  # the kernel's own typing says what is wrong
    # the kernel's own check (physics.kernels.checks, which numba compiles for the kernel), as plain Python
    check_arguments(layout, y0, t0, t_end, t_eval, params, y_out, cond_out)
    if driver is None:
        driver = _driver(method)
    # One buffer for everything the driver reads or writes besides the layout and y_out: [counts (3 int64),
    # t_reached, y0, t_eval, params (the driver writes t into this copy), scratch]; each pointer is the buffer's
    # address plus an offset (an address look-up costs a microsecond or two, a small copy much less).
    n_state, n_samples, n_params = y0.shape[0], t_eval.shape[0], params.shape[0]
    scratch = scratch_length(method, n_state, int(layout[LAYOUT_CONSTRAINTS]), int(layout[LAYOUT_UNKNOWNS]))
    at_y0 = 4
    at_t_eval = at_y0 + n_state
    at_params = at_t_eval + n_samples
    at_scratch = at_params + n_params
    values = np.empty(at_scratch + scratch)
    counts = values[:3].view(np.int64)
    counts.fill(0)
    values[3] = 0.0
    values[at_y0:at_t_eval] = y0
    values[at_t_eval:at_params] = t_eval
    values[at_params:at_scratch] = params
    base = values.ctypes.data
    projecting = bool(project) and layout[LAYOUT_CONSTRAINTS] != 0  # the kernel's _projecting
    y_out.fill(np.nan)
    status = driver(int(assemble), layout_address(layout), base + 8 * at_y0, float(t0), float(t_end),
                    base + 8 * at_t_eval, n_samples, base + 8 * at_params, float(rtol), float(atol), float(alpha),
                    float(beta), int(projecting), int(max_steps), y_out.ctypes.data, base + 8 * at_scratch, base,
                    base + 24)
    return int(status), int(counts[0]), int(counts[1]), float(values[3]), int(counts[2])
