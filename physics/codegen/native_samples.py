"""The samples' solve of :mod:`physics.codegen.samples_ir`, compiled once per process and called through ctypes.

Each function takes the arguments of the numba kernel it replaces (:mod:`physics.kernels.system`) and fills the
same outputs with the same bits. Arrays must be C-contiguous float64 of the kernel's shapes: the callers
(:class:`physics.codegen.cache.CompiledSystem`, :mod:`physics.codegen.mechanism_samples`) build them so; a wrong
one is a programming error and raises ``ValueError`` before any pointer is handed over.
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from ..kernels.layout import LAYOUT_CONSTRAINTS, LAYOUT_COORDINATES, LAYOUT_UNKNOWNS
from .ir_shapes import SAMPLES_SOLVE_NAME, SAMPLES_SOLVE_POSE_NAME
from .ir_shapes import samples_scratch_length as scratch_length
from .native_integrators import checked_address as _pointer
from .native_integrators import ctypes_functions, ir_builder, specialised_engine, specialised_key

_P = ctypes.c_void_p
_I = ctypes.c_int64
_D = ctypes.c_double
_SIGNATURES = {
    "solve_states": ctypes.CFUNCTYPE(None, _I, _P, _I, _P, _P, _P, _D, _D, _P, _P, _P),
    "assemble_states": ctypes.CFUNCTYPE(None, _I, _P, _I, _P, _P, _P, _P, _P),
    "solve_pose_states": ctypes.CFUNCTYPE(None, _I, _P, _I, _P, _P, _P, _D, _D, _P, _P, _P, _P, _P, _I, _I),
}
_BUILD = ir_builder("samples_ir", "samples_ir")


def _function(name: str):
    return ctypes_functions("samples", _BUILD, _SIGNATURES)[name]


def specialised_solve(layout: np.ndarray, assemble: int, system_digest: str, sample: int = 0):
    """``(functions, engine)``: ``solve_states`` specialised for one system (its ``layout``, the one for one
    evaluation at a time), a :class:`SpecialisedSamples` of ctypes functions of the generic ones' signatures
    valid while ``engine`` lives; the same bits as the generic ones. ``sample``: the address of the system's
    generated ``sample`` (0: none), whose ``solve_pose_states`` is specialised too. Compiled at O2 or loaded
    from the machine-code cache."""
    shape, key = specialised_key(samples_kind(sample), layout, system_digest)

    def ir_text() -> str:
        from .specialised_ir import specialised_samples_ir  # noqa: PLC0415  (llvmlite.ir: only on a cache miss)

        return specialised_samples_ir(shape, system_digest, pose=bool(sample))

    engine = specialised_engine(ir_text, layout, assemble, system_digest, key, sample=sample)
    functions = SpecialisedSamples(
        _SIGNATURES["solve_states"](engine.get_function_address(SAMPLES_SOLVE_NAME)),
        _SIGNATURES["solve_pose_states"](engine.get_function_address(SAMPLES_SOLVE_POSE_NAME)) if sample else None)
    return functions, engine


def pose_counterpart(solve, specialised: SpecialisedSamples | None):
    """The ``solve_pose_states`` that goes with the samples' solve ``solve``: the specialised one when ``solve``
    is ``specialised``'s (a system's :meth:`~physics.codegen.cache.CompiledSystem.samples_solve`), the generic
    one when ``solve`` is the generic ``solve_states``; None otherwise (no ``sample`` specialised with it)."""
    if specialised is not None and solve is specialised.solve:
        return specialised.solve_pose
    if solve is _function("solve_states"):
        return _function("solve_pose_states")
    return None


def samples_kind(sample) -> str:
    """The name of a system's specialised samples' module in the machine-code cache's key: with the solve and
    kinematics in one call when the system has a generated ``sample`` (``sample``: true, or its address)."""
    return "samples pose" if sample else "samples"


def generic_solve_pose():
    """The generic ctypes function ``solve_pose_states`` (compiled or loaded once)."""
    return _function("solve_pose_states")


def solve_states(assemble: int, layout, theta, omega, params, alpha, beta, x_out, cond_out) -> None:
    """:func:`physics.kernels.system.solve_states`: all unknowns ``x_out`` (K, k) and ``cond_out`` (K,)."""
    n, k, r = int(layout[LAYOUT_COORDINATES]), int(layout[LAYOUT_UNKNOWNS]), int(layout[LAYOUT_CONSTRAINTS])
    rows = theta.shape[0]
    scratch = np.empty(scratch_length(n, k, r))
    _function("solve_states")(
        int(assemble), _pointer(layout, (None,), np.int64), rows, _pointer(theta, (rows, n)),
        _pointer(omega, (rows, n)), _pointer(params, (None,)), float(alpha), float(beta), _pointer(x_out, (rows, k)),
        _pointer(cond_out, (rows,)), scratch.ctypes.data)


def assemble_states(assemble: int, layout, theta, omega, params, A_out, b_out) -> None:
    """:func:`physics.kernels.system.assemble_states`: ``A_out`` (K, k, k) and ``b_out`` (K, k)."""
    n, k = int(layout[LAYOUT_COORDINATES]), int(layout[LAYOUT_UNKNOWNS])
    rows = theta.shape[0]
    _function("assemble_states")(
        int(assemble), _pointer(layout, (None,), np.int64), rows, _pointer(theta, (rows, n)),
        _pointer(omega, (rows, n)), _pointer(params, (None,)), _pointer(A_out, (rows, k, k)),
        _pointer(b_out, (rows, k)))


class SpecialisedSamples(NamedTuple):
    """A system's specialised samples' functions (:func:`specialised_solve`): ``solve_states`` and (a system
    with a generated ``sample``) ``solve_pose_states``, of their generic functions' signatures."""

    solve: Callable
    solve_pose: Callable | None = None
