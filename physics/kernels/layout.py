"""The layout array of the binary contract (:mod:`physics.kernels.abi`): its slots and :func:`make_layout`.

Plain Python and numpy, no numba: the code generator, the LLVM IR drivers and a run that never reaches a numba
kernel read the layout too, and importing numba costs a warm run a third of its time.
"""

from __future__ import annotations

import numpy as np

# Slots of the layout array. The kernels know nothing of chains or bodies: only sizes, where the coordinates'
# accelerations and the constraints' rows sit, and the addresses of the generated functions.
LAYOUT_COORDINATES = 0  # n: coordinates (the state is [theta, omega], 2 n)
LAYOUT_UNKNOWNS = 1  # k: unknowns of A x = b (accelerations, and multipliers or reactions)
LAYOUT_CONSTRAINTS = 2  # r: constraints phi(theta, t) = 0 the integrator holds (0: an open tree, no closure)
LAYOUT_TIME = 3  # index of t in params, written by the integrators before each evaluation; -1: nothing uses t
LAYOUT_SYMMETRIC = 4  # 1 when A is symmetric positive definite (Lagrange's mass matrix): solved by L D L^T
LAYOUT_SOLVE = 5  # address of the generated structured solve of a sparse A (the DAE), 0 when there is none
LAYOUT_CONSTRAINT_FUNCTION = 6  # address of the generated constraints(theta, omega, params, J, v), 0 if r = 0
LAYOUT_WEIGHTS = 7  # offset in params of 2 n projection weights (positions, then velocities); -1: unit weights
LAYOUT_PARAMETERS = 8  # number of parameters the generated code reads (params must be at least this long)
LAYOUT_RHS = 9  # address of the generated rhs(y, params, dydt) (assemble and solve fused), 0 when there is none
LAYOUT_ACCELERATION = 10  # n entries: where each coordinate's acceleration sits in x; then r constraint rows


def make_layout(
    n: int,
    n_unknowns: int,
    acceleration_index,
    *,
    n_parameters: int,
    symmetric: bool = False,
    solve_address: int = 0,
    rhs_address: int = 0,
    constraint_rows=(),
    constraint_address: int = 0,
    time_index: int | None = None,
    weights_offset: int | None = None,
) -> np.ndarray:
    """The int64 layout array the kernels read (slots above). ``constraint_rows``: the rows of ``A x = b``
    whose ``(A x - b)[row]`` is the second time derivative of constraint ``i`` (Baumgarte's rows)."""
    rows = [int(row) for row in constraint_rows]
    if rows and not constraint_address:
        raise ValueError("constraint rows need the address of the generated constraints function")
    head = [n, n_unknowns, len(rows), -1 if time_index is None else int(time_index), int(bool(symmetric)),
            int(solve_address), int(constraint_address) if rows else 0,
            -1 if weights_offset is None else int(weights_offset), int(n_parameters), int(rhs_address)]
    return np.array(head + [int(i) for i in acceleration_index] + rows, dtype=np.int64)
