"""The seed report's approach, ported straight to Python: the baseline the compiled path is measured against.

What the seed's MATLAB does (course-report.md, sections 2 and 5), and what this module does in its place:

* derive the triple pendulum's equations with symbolic algebra (``syms`` -> sympy), collect them as a
  linear system ``A x = b`` in the unknown accelerations (``equationsToMatrix`` -> ``linear_eq_to_matrix``),
  then ``simplify(A)`` and ``simplify(b)``;
* turn ``A`` and ``b`` into numeric functions (``matlabFunction`` -> ``lambdify`` with numpy);
* in the right-hand side, evaluate ``A`` and ``b`` and solve (``A \\ b`` -> ``numpy.linalg.solve``);
* integrate with ``ode45`` at ``RelTol = AbsTol = 1e-6`` on ``linspace(0, 20, 200)`` (-> ``solve_ivp``,
  ``method="RK45"``, ``t_eval``: the same Dormand-Prince pair under scipy's controller, not MATLAB's; this baseline
  measures what the seed's approach costs in Python, while :mod:`physics.kernels.ode45` follows MATLAB's
  controller step for step for the seed report's numbers).

Two of the seed's derivations are ported: Lagrange (3 x 3) and the maximal-coordinate DAE (15 x 15: linear
momentum balance per bar, angular momentum balance about each centre of mass, acceleration constraints at the
joints O, E, F). The physics is the seed's, not its typos: the seed's DAE has ``m2`` where ``m3`` belongs in
one angular momentum term and ``I1`` for ``I3`` in the report's text; here every bar uses its own ``m_i``
and ``I_i``.

Conventions follow docs/architecture.md so results compare with ``physics``: x right, y up, gravity along -y,
``theta_i`` from the downward vertical, counter-clockwise positive (bar i points along
``(sin theta_i, -cos theta_i)``), parameters ``[L1..L3, d1..d3, m1..m3, I1..I3, g]``. One difference is kept
from the seed on purpose: its reaction ``R_P`` is the force ON the ground / earlier bar BY the later bar (the
forces on bar 1 are ``-R_O + R_E + m_1 g``), the opposite sign of ``physics``' joint reactions.

This module is independent of ``physics/``: it imports neither its derivations nor its generated code.
A derivation is done once per process and kept in memory (``derived``); timings exclude it.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp

N_LINKS = 3
FORMULATIONS = ("lagrange", "dae")

# The seed's parameters (fPendPlot.m): L = 1, d = 0.5, m = 1, I = 0.2 / 0.3 / 0.4, g = 1.
SEED_PARAMS = np.array([1.0, 1.0, 1.0, 0.5, 0.5, 0.5, 1.0, 1.0, 1.0, 0.2, 0.3, 0.4, 1.0])
# The seed's three starts, at rest (the MATLAB's z0 lines; case C is [pi; pi/3; pi/3] there).
SEED_CASES = {
    "A": (math.pi / 2, math.pi, math.pi),
    "B": (math.pi / 4, math.pi / 2, 3 * math.pi / 4),
    "C": (math.pi, math.pi / 3, math.pi / 3),
}
# The seed's run: ode45 on linspace(0, 20, 200) at RelTol = AbsTol = 1e-6.
SEED_T_END = 20.0
SEED_SAMPLES = 200
SEED_RTOL = 1e-6
SEED_ATOL = 1e-6


@dataclass(frozen=True)
class BaselineSystem:
    """Numeric ``A(args)`` and ``b(args)`` from lambdify; ``args = (*params, *theta, *omega)``."""

    formulation: str
    A: Callable[..., np.ndarray]
    b: Callable[..., np.ndarray]
    n_unknowns: int
    theta_ddot_index: tuple
    derive_seconds: float


def _symbols():
    L = sp.symbols("L1:4", positive=True)
    d = sp.symbols("d1:4", real=True)
    m = sp.symbols("m1:4", real=True)
    I = sp.symbols("I1:4", real=True)
    g = sp.Symbol("g", real=True)
    theta = sp.symbols("theta1:4", real=True)
    omega = sp.symbols("theta1dot theta2dot theta3dot", real=True)
    theta_ddot = sp.symbols("theta1doubledot theta2doubledot theta3doubledot", real=True)
    return L, d, m, I, g, theta, omega, theta_ddot


def _er(theta):
    """Unit vector along a bar (the seed's ``er``), from the downward vertical, x right and y up."""
    return sp.Matrix([sp.sin(theta), -sp.cos(theta)])


def _etheta(theta):
    """The seed's ``etheta = e3 x er``: perpendicular to the bar, counter-clockwise."""
    return sp.Matrix([sp.cos(theta), sp.sin(theta)])


def _cross(a, b):
    """z-component of a x b for planar vectors."""
    return a[0] * b[1] - a[1] * b[0]


def _finish(formulation, equations, unknowns, theta_ddot_index, start, args) -> BaselineSystem:
    """``equationsToMatrix`` + ``simplify`` + ``matlabFunction``, as the seed does."""
    A, b = sp.linear_eq_to_matrix(equations, unknowns)
    A = sp.simplify(A)
    b = sp.simplify(b)
    A_func = sp.lambdify(args, A, modules="numpy")
    b_func = sp.lambdify(args, b, modules="numpy")
    return BaselineSystem(
        formulation, A_func, b_func, len(unknowns), tuple(theta_ddot_index), time.perf_counter() - start
    )


def derive_lagrange() -> BaselineSystem:
    """tPendDeriveEOMLagrange.m: T - V from centre-of-mass velocities, Lagrange's equations, A x = b (3 x 3)."""
    start = time.perf_counter()
    L, d, m, I, g, theta, omega, theta_ddot = _symbols()
    # Centre-of-mass positions and velocities, built joint by joint as the seed does.
    r_com, v_com = [], []
    r_joint = sp.zeros(2, 1)
    v_joint = sp.zeros(2, 1)
    for i in range(N_LINKS):
        r_com.append(r_joint + d[i] * _er(theta[i]))
        v_com.append(v_joint + d[i] * omega[i] * _etheta(theta[i]))
        r_joint = r_joint + L[i] * _er(theta[i])
        v_joint = v_joint + L[i] * omega[i] * _etheta(theta[i])
    kinetic = sum(m[i] * v_com[i].dot(v_com[i]) / 2 + I[i] * omega[i] ** 2 / 2 for i in range(N_LINKS))
    potential = sum(m[i] * g * r_com[i][1] for i in range(N_LINKS))  # zero at the height of O
    lagrangian = kinetic - potential
    equations = []
    for i in range(N_LINKS):
        momentum = sp.diff(lagrangian, omega[i])
        # d/dt by the chain rule: theta' = omega, omega' = theta_ddot.
        momentum_rate = sum(
            sp.diff(momentum, theta[j]) * omega[j] + sp.diff(momentum, omega[j]) * theta_ddot[j] for j in range(N_LINKS)
        )
        equations.append(momentum_rate - sp.diff(lagrangian, theta[i]))
    args = (*L, *d, *m, *I, g, *theta, *omega)
    return _finish("lagrange", equations, list(theta_ddot), range(N_LINKS), start, args)


def derive_dae() -> BaselineSystem:
    """tPendDeriveEOMDAE.m: 15 unknowns (centre-of-mass and angular accelerations, reactions at O, E, F).

    Equations: LMB per bar (6), AMB about each centre of mass G_i (3), and the acceleration of each joint
    seen from the bars on both sides of it (the ground for O) made equal (6)."""
    start = time.perf_counter()
    L, d, m, I, g, theta, omega, theta_ddot = _symbols()
    x_ddot = sp.symbols("x1doubledot x2doubledot x3doubledot", real=True)
    y_ddot = sp.symbols("y1doubledot y2doubledot y3doubledot", real=True)
    R = [sp.Matrix(sp.symbols(f"R{p}x R{p}y", real=True)) for p in "OEF"]
    unknowns = []
    for i in range(N_LINKS):
        unknowns += [x_ddot[i], y_ddot[i], theta_ddot[i]]
    for reaction in R:
        unknowns += list(reaction)

    def a_rel(i, r):
        """Acceleration of a point of bar i relative to G_i, at ``r`` from G_i: alpha e3 x r - omega^2 r."""
        return theta_ddot[i] * sp.Matrix([-r[1], r[0]]) - omega[i] ** 2 * r

    a_com = [sp.Matrix([x_ddot[i], y_ddot[i]]) for i in range(N_LINKS)]
    r_proximal = [-d[i] * _er(theta[i]) for i in range(N_LINKS)]  # r_{O/G1}, r_{E/G2}, r_{F/G3}
    r_distal = [(L[i] - d[i]) * _er(theta[i]) for i in range(N_LINKS)]  # r_{E/G1}, r_{F/G2}, r_{H/G3}
    zero = sp.zeros(2, 1)
    lmb, amb, constraints = [], [], []
    for i in range(N_LINKS):
        reaction_distal = R[i + 1] if i + 1 < N_LINKS else zero  # the tip H is free
        gravity = sp.Matrix([0, -m[i] * g])
        forces = -R[i] + reaction_distal + gravity  # the seed's forcesOnLink
        lmb += [forces[0] - m[i] * x_ddot[i], forces[1] - m[i] * y_ddot[i]]
        moment = _cross(r_proximal[i], -R[i]) + _cross(r_distal[i], reaction_distal)  # M about G_i
        amb.append(I[i] * theta_ddot[i] - moment)
        joint_from_this_bar = a_com[i] + a_rel(i, r_proximal[i])
        joint_from_previous = a_com[i - 1] + a_rel(i - 1, r_distal[i - 1]) if i > 0 else zero
        gap = joint_from_this_bar - joint_from_previous
        constraints += [gap[0], gap[1]]
    args = (*L, *d, *m, *I, g, *theta, *omega)
    return _finish("dae", lmb + amb + constraints, unknowns, (2, 5, 8), start, args)


_DERIVERS = {"lagrange": derive_lagrange, "dae": derive_dae}


@functools.cache
def derived(formulation: str) -> BaselineSystem:
    """The derivation of ``formulation``, done once per process."""
    if formulation not in _DERIVERS:
        raise ValueError(f"formulation = {formulation!r}: allowed {', '.join(FORMULATIONS)}")
    return _DERIVERS[formulation]()


def make_rhs(system: BaselineSystem, params):
    """The seed's ``rhsLagrange`` / ``rhsDAE``: evaluate A and b, solve, return ``[omega, theta_ddot]``."""
    params = tuple(float(p) for p in params)
    A_func, b_func = system.A, system.b
    index = list(system.theta_ddot_index)

    def rhs(t, z):
        args = (*params, *z)
        q = np.linalg.solve(A_func(*args), b_func(*args))
        return np.concatenate([z[N_LINKS:], q[index, 0]])

    return rhs


def solve_full(formulation: str, theta, omega, params=SEED_PARAMS) -> np.ndarray:
    """Every unknown ``x`` at one state (for the DAE: accelerations and the seed-sign reactions)."""
    system = derived(formulation)
    args = (*(float(p) for p in params), *(float(v) for v in theta), *(float(v) for v in omega))
    return np.linalg.solve(system.A(*args), system.b(*args))[:, 0]


def simulate(formulation: str, theta0, omega0=(0.0, 0.0, 0.0), params=SEED_PARAMS, t_end=SEED_T_END,
             samples=SEED_SAMPLES, rtol=SEED_RTOL, atol=SEED_ATOL):
    """The seed's ``ode45`` run: ``solve_ivp(RK45)`` sampled on ``linspace(0, t_end, samples)``."""
    rhs = make_rhs(derived(formulation), params)
    z0 = np.concatenate([np.asarray(theta0, float), np.asarray(omega0, float)])
    t_eval = np.linspace(0.0, t_end, samples)
    return solve_ivp(rhs, (0.0, t_end), z0, method="RK45", t_eval=t_eval, rtol=rtol, atol=atol)


def tip_xy(theta, params=SEED_PARAMS) -> np.ndarray:
    """Tip H of the chain for angles ``theta`` of shape (T, 3): (T, 2)."""
    L = np.asarray(params[:N_LINKS])
    theta = np.asarray(theta, float)
    return np.stack([np.sum(L * np.sin(theta), axis=-1), -np.sum(L * np.cos(theta), axis=-1)], axis=-1)
