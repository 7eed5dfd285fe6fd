"""Generated arithmetic as LLVM IR, compiled in-process: every construct the translator handles gives the value
numpy gives for the same expression."""

from __future__ import annotations

import ctypes

import numpy as np
import pytest
import sympy as sp

from physics.codegen import llvm_ir
from physics.codegen.native import NativeModule
from physics.derive.symbols import chain_symbols


def _evaluate(exprs, theta, omega, params):
    """Compile ``exprs`` as the vector ``b`` of an ``assemble`` and call it through ctypes."""
    s = chain_symbols(2)
    entries = [(("v", i), e) for i, e in enumerate(exprs)]
    native = NativeModule(llvm_ir.module_ir([llvm_ir.function_ir("assemble", s, entries, 1, "A", "b")]))
    pointer = ctypes.POINTER(ctypes.c_double)
    function = ctypes.CFUNCTYPE(None, *[pointer] * 5)(native.addresses["assemble"])
    arrays = [np.ascontiguousarray(a, dtype=float) for a in (theta, omega, params, np.zeros(1), np.zeros(len(exprs)))]
    function(*[a.ctypes.data_as(pointer) for a in arrays])
    return arrays[-1]


def test_every_construct_matches_numpy():
    s = chain_symbols(2)
    t1, t2 = s.theta
    w1, w2 = s.omega
    L1, L2 = s.L
    g = s.g
    exprs = [
        sp.sin(t1) * sp.cos(t2) - 3 * w1,  # functions, a coefficient, a difference
        t1**2 + w2**3 + L1**5,  # integer powers by repeated squaring
        1 / L2 + L1**-3,  # reciprocals
        sp.sqrt(L1 + L2) + (L1 + g) ** sp.Rational(3, 2),  # square root and a general power
        sp.Rational(1, 3) * g * (w1 - w2) + sp.Float(2.5),  # rationals and floats as exact constants
        -(t1 + t2),  # a negated product
    ]
    theta, omega = np.array([0.3, -1.2]), np.array([0.7, -0.4])
    params = np.array([1.3, 0.8, 0.5, 0.4, 1.0, 2.0, 0.1, 0.2, 9.81, 0.0, 0.0, 0.0])
    values = dict(zip([*s.theta, *s.omega, *s.params], [*theta, *omega, *params]))
    expected = [float(e.evalf(subs=values)) for e in exprs]
    np.testing.assert_allclose(_evaluate(exprs, theta, omega, params), expected, rtol=1e-14, atol=1e-14)


def test_division_by_zero_gives_inf_not_an_error():
    s = chain_symbols(2)
    result = _evaluate([1 / s.theta[0]], np.zeros(2), np.zeros(2), np.zeros(12))
    assert np.isinf(result[0])


def test_an_untranslatable_function_is_refused_when_generating():
    s = chain_symbols(2)
    with pytest.raises(NotImplementedError, match="exp"):
        llvm_ir.function_ir("assemble", s, [(("v", 0), sp.exp(s.theta[0]))], 1, "A", "b")


def _markowitz_by_scanning(A, vanishing=frozenset()):
    """Markowitz's order written the plain way (every entry scanned for every candidate): the oracle of the
    indexed version in :func:`llvm_ir.elimination_order`."""
    k = A.shape[0]
    structure = {(i, j) for i in range(k) for j in range(k) if A[i, j] != 0}
    if k < 6 or len(structure) > 0.4 * k * k:
        return None
    safe = llvm_ir.safe_pivots(A, vanishing)
    rows, cols, order = set(range(k)), set(range(k)), []
    while rows:
        candidates = [((i, j) not in safe,
                       (sum(1 for (r, c) in structure if r == i and c in cols) - 1)
                       * (sum(1 for (r, c) in structure if c == j and r in rows) - 1), i, j)
                      for (i, j) in structure if i in rows and j in cols]
        if not candidates:
            return None
        _, _, row, col = min(candidates)
        order.append((row, col))
        pivot_cols = [c for (r, c) in structure if r == row and c in cols and c != col]
        for r in [r for (r, c) in structure if c == col and r in rows and r != row]:
            structure.update((r, j) for j in pivot_cols)
        rows.discard(row)
        cols.discard(col)
    return order


@pytest.mark.parametrize("seed", range(40))
def test_the_pivot_order_is_markowitzs_on_random_sparse_structures(seed):
    rng = np.random.default_rng(seed)
    k = int(rng.integers(6, 30))
    x, m, p = sp.Symbol("x"), sp.Symbol("m", positive=True), sp.Symbol("p")
    kinds = [sp.Integer(0)] * 6 + [m, sp.sin(x), p]  # mostly zero; a safe mass, a state-dependent sine, a vanishing p
    A = sp.Matrix(k, k, lambda i, j: m if i == j and rng.random() < 0.5 else kinds[int(rng.integers(len(kinds)))])
    assert llvm_ir.elimination_order(A, frozenset({p})) == _markowitz_by_scanning(A, frozenset({p}))
