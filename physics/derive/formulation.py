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
    # The constraints the integrator holds (a pinned chain's tip, a mechanism's closures and speed motors), for
    # the kernels' generic Baumgarte terms, projection and singularity test (docs/architecture.md):
    # (A x - b)[constraint_rows[i]] is the second time derivative of constraint[i].
    constraint_rows: tuple = ()
    constraint: sp.Matrix | None = None  # phi (r,), in the coordinates, the parameters and possibly t
    constraint_jacobian: sp.Matrix | None = None  # d phi / d theta (r, n)
    constraint_rate: sp.Matrix | None = None  # phi_dot = J omega + d phi / d t (r,)
    multiplier_index: tuple = ()  # where each constraint row's multiplier sits in x
    time_index: int | None = None  # index of t in symbols.params (the kernels write it), None if nothing uses t
    # tree coordinates only: every body's (x, y, phi) in them, d pose / d theta, and the bias d(J)/dt omega
    kinematics: tuple | None = None
    # Parameters that may be zero in a valid model (a guide's direction component, a point's coordinate): an
    # entry holding one is no safe pivot for the generated elimination (physics/codegen/llvm_ir.py). A chain's
    # entries hold its lengths, masses and inertias only where they cannot vanish, so it names none.
    vanishing_parameters: frozenset = frozenset()

    def held_constraints(self) -> tuple[tuple, sp.Matrix, sp.Matrix, sp.Matrix]:
        """``(rows, phi, J, phi_dot)`` of the constraints the integrator holds: a mechanism's own, or a pinned
        chain's tip on its pin (``phi = tip - pin``, on the rows ``tip_rows``); empty for an open chain."""
        if self.constraint is not None:
            return (tuple(self.constraint_rows), self.constraint, self.constraint_jacobian, self.constraint_rate)
        n = self.n
        if not self.pinned:
            return (), sp.zeros(0, 1), sp.zeros(0, n), sp.zeros(0, 1)
        s = self.symbols
        tip = sp.Matrix([sum(s.L[i] * sp.sin(s.theta[i]) for i in range(n)) - s.pin_x,
                         -sum(s.L[i] * sp.cos(s.theta[i]) for i in range(n)) - s.pin_y])
        jacobian = sp.Matrix(2, n, lambda row, i: s.L[i] * (sp.cos(s.theta[i]) if row == 0 else sp.sin(s.theta[i])))
        rate = jacobian * sp.Matrix(s.omega)
        assert self.tip_rows is not None
        return tuple(self.tip_rows), tip, jacobian, rate


def _split_linear(expr, unknowns: frozenset):
    """``(coefficients, rest)`` with ``expr = sum(coefficients[u] * u) + rest`` for an ``expr`` linear in
    ``unknowns``: one walk down the branches that hold an unknown, instead of one derivative per unknown
    (sympy's Jacobian walks the whole equation n times, and differentiates every factor by the product rule)."""
    if not (expr.free_symbols & unknowns):
        return {}, expr
    if expr in unknowns:
        return {expr: sp.Integer(1)}, sp.Integer(0)
    if expr.is_Add:
        coefficients: dict = {}
        rest = []
        for term in expr.args:
            term_coefficients, term_rest = _split_linear(term, unknowns)
            for u, c in term_coefficients.items():
                coefficients[u] = coefficients.get(u, sp.Integer(0)) + c
            rest.append(term_rest)
        return coefficients, sp.Add(*rest)
    if expr.is_Mul:
        holding = [factor for factor in expr.args if factor.free_symbols & unknowns]
        if len(holding) == 1:
            others = sp.Mul(*[factor for factor in expr.args if factor is not holding[0]])
            coefficients, rest = _split_linear(holding[0], unknowns)
            return {u: others * c for u, c in coefficients.items()}, others * rest
    # anything else (an unknown inside a nonlinear function would break linearity): differentiate
    coefficients = {u: sp.diff(expr, u) for u in unknowns if u in expr.free_symbols}
    if any(c.free_symbols & unknowns for c in coefficients.values()):
        raise ValueError(f"equation not linear in the unknowns: {expr}")
    return coefficients, expr.xreplace({u: 0 for u in unknowns})


def linear_system(equations, unknowns):
    """``A = d(equations)/d(unknowns)`` and ``b = -equations(unknowns = 0)`` for equations linear in unknowns."""
    unknowns = list(unknowns)
    wanted = frozenset(unknowns)
    A = sp.zeros(len(equations), len(unknowns))
    b = sp.zeros(len(equations), 1)
    for row, equation in enumerate(equations):
        coefficients, rest = _split_linear(sp.sympify(equation), wanted)
        for col, u in enumerate(unknowns):
            A[row, col] = coefficients.get(u, sp.Integer(0))
        b[row] = -rest
    return A, b


class Formulation:
    """Base class. Subclasses set ``name`` and implement :meth:`equations`."""

    name = ""
    title = ""

    def derive(self, n: int, pinned: bool) -> LinearSystem:  # pragma: no cover - interface
        raise NotImplementedError
