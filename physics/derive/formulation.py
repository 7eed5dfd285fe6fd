"""The one interface every formulation implements: equations of motion as a linear system ``A x = b``.

A formulation only writes its equations, each as an expression that vanishes on the true motion and is
linear in the unknowns ``x``; :func:`linear_system` turns the list into ``A`` and ``b`` (the analogue of
MATLAB's ``equationsToMatrix``), without simplifying and without ever inverting anything symbolically.
Code generation, the numeric solve, simulation, the CLI and the app are shared by all formulations.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from .symbols import ChainSymbols


@dataclass
class LinearSystem:
    """Symbolic ``A x = b`` and the layout of the unknowns ``x`` (docs/architecture.md)."""

    formulation: str
    n: int
    pinned: bool
    symbols: ChainSymbols
    A: sp.Matrix
    b: sp.Matrix
    unknowns: list  # sympy symbols, in the order of x
    equation_names: list  # one short label per row, for the equations panel
    theta_ddot_index: list
    reaction_index: list = field(default_factory=list)  # (ix, iy) of joint reaction k = 0..n-1
    tip_reaction_index: tuple | None = None
    tip_rows: tuple | None = None  # rows whose (A x - b) is the tip's acceleration
    # The Lagrangian's pieces, for the variational integrator (Lagrange only): the mass matrix d2T/d omega2
    # (n, n) and the force dL/d theta + Q (n,) with Q the damping's generalized force (no loop reaction).
    mass_matrix: sp.Matrix | None = None
    lagrangian_force: sp.Matrix | None = None


def linear_system(equations, unknowns):
    """``A = d(equations)/d(unknowns)`` and ``b = -equations(unknowns = 0)`` for equations linear in unknowns."""
    eqs = sp.Matrix(equations)
    A = eqs.jacobian(list(unknowns))
    zero = {u: 0 for u in unknowns}
    b = -eqs.xreplace(zero)
    return A, b


class Formulation:
    """Base class. Subclasses set ``name`` and implement :meth:`equations`."""

    name = ""
    title = ""

    def derive(self, n: int, pinned: bool) -> LinearSystem:  # pragma: no cover - interface
        raise NotImplementedError
