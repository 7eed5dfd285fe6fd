"""The integrators' check of their arguments, as plain Python: compiled by numba for the kernels
(:data:`physics.kernels.common.check_arguments`) and run as it is by the LLVM IR drivers
(:mod:`physics.codegen.native_integrators`), which must not import numba for it."""

from __future__ import annotations

from .layout import LAYOUT_COORDINATES, LAYOUT_PARAMETERS


def check_arguments(layout, y0, t0, t_end, t_eval, params, y_out, cond_out):
    """Programming errors only (the caller validates user input): wrong shapes or a backward interval."""
    if not (t_end >= t0):
        raise ValueError("t_end must be >= t0 (the kernels integrate forward only)")
    n = layout[LAYOUT_COORDINATES]
    if y0.shape[0] != 2 * n:
        raise ValueError("y0 must have shape (2 n,) for the mechanism's n coordinates")
    if params.shape[0] < layout[LAYOUT_PARAMETERS]:
        raise ValueError("params is shorter than the parameter vector the generated code reads")
    if y_out.shape[0] != t_eval.shape[0] or y_out.shape[1] != y0.shape[0]:
        raise ValueError("y_out must have shape (len(t_eval), 2 n)")
    if cond_out.shape[0] != t_eval.shape[0] and cond_out.shape[0] != 0:
        raise ValueError("cond_out must have shape (len(t_eval),), or (0,) to skip the per-sample condition")
