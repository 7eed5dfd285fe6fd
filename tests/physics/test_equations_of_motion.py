"""physics.equations_of_motion (issue 24): the equations the app shows and a notebook reads are the ones a run
integrates. A chain's, in the chain's readable symbols (theta, L, d, m, I), solved at a state with the chain's
numbers give the accelerations the engine computes (physics.accelerations runs the chain as a mechanism); a
mechanism's are its structure's derivation, renamed only."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

import physics
from physics.mechanism import derived_system
from physics.mechanism.presets import MECHANISM_PRESETS

METHODS = ("lagrange", "newton_euler", "dae")
DAMPING = 0.3


def _chain_values(chain, theta, omega) -> dict:
    """The readable symbols' numbers: the chain's bars, g, the damping, the pin and the state."""
    values = {"g": chain.g, "c": DAMPING}
    if chain.pin is not None:
        values["x_H"], values["y_H"] = chain.pin
    for k, bar in enumerate(chain.bars, start=1):
        values.update({f"L_{k}": bar.L, f"d_{k}": bar.d, f"m_{k}": bar.m, f"I_{k}": bar.I,
                       f"θ_{k}": theta[k - 1], f"ω_{k}": omega[k - 1]})
    return values


def _solved(equations, values: dict) -> dict:
    """Solve the shown rows (sum of the left side's terms = right side) at ``values``: unknown name -> number."""
    unknowns = equations.unknowns
    A = np.zeros((len(unknowns), len(unknowns)))
    b = np.zeros(len(unknowns))
    for i, (_, lhs_terms, rhs) in enumerate(equations.rows):
        lhs = sp.Add(*lhs_terms)
        for j, unknown in enumerate(unknowns):
            coefficient = lhs.coeff(unknown)
            A[i, j] = float(coefficient.subs({s: values[s.name] for s in coefficient.free_symbols}))
        assert sp.expand(lhs - sum(lhs.coeff(u) * u for u in unknowns)) == 0  # linear in the unknowns
        b[i] = float(rhs.subs({s: values[s.name] for s in rhs.free_symbols}))
    return {str(u): x for u, x in zip(unknowns, np.linalg.solve(A, b))}


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("preset", ["triple-a", "four-bar"])
def test_a_chains_equations_solve_to_the_engines_accelerations(preset, method):
    chain = physics.get_preset(preset).chain
    start = physics.get_preset(preset)
    rng = np.random.default_rng(24)
    if chain.pinned:  # a state on the loop: the preset's start, its rates along the loop (zero)
        theta, omega = np.asarray(start.theta0, float), np.zeros(chain.n)
    else:
        theta, omega = rng.uniform(-2.0, 2.0, chain.n), rng.uniform(-3.0, 3.0, chain.n)
    equations = physics.equations_of_motion(chain, method)
    assert {s.name for row in equations.rows for s in sp.Add(*row[1], row[2]).free_symbols} <= (
        set(_chain_values(chain, theta, omega)) | {str(u) for u in equations.unknowns})  # the chain's names only
    solved = _solved(equations, _chain_values(chain, theta, omega))
    engine = physics.accelerations(chain, theta, omega, method, damping=DAMPING)
    shown = [solved[f"θ̈_{k}"] for k in range(1, chain.n + 1)]
    np.testing.assert_allclose(shown, engine["theta_ddot"], rtol=1e-10, atol=1e-10)


def test_a_mechanisms_equations_are_its_derivation_renamed():
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    for method in METHODS:
        equations = physics.equations_of_motion(mechanism, method)
        system = derived_system(mechanism, method)
        assert equations.system.A == system.A and equations.system.b == system.b
        assert equations.shape == system.A.shape
        if method == "dae":  # its rows' names have no tree coordinate to rename
            assert [name for name, _, _ in equations.rows] == system.equation_names
        names = {str(u) for u in equations.unknowns}
        assert not any(name.startswith(("q", "s0", "lam")) for name in names), names  # readable: bodies, joints
    assert "x\u0308_crank" in {str(u) for u in physics.equations_of_motion(mechanism, "dae").unknowns}


def test_the_reduced_model_and_other_things_are_refused():
    chain = physics.get_preset("four-bar").chain
    with pytest.raises(ValueError, match="reduced"):
        physics.equations_of_motion(chain, "reduced")
    with pytest.raises(TypeError, match="Chain"):
        physics.equations_of_motion("four-bar", "dae")
