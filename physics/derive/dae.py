"""Maximal coordinates: every centre-of-mass acceleration, angular acceleration and joint reaction at once.

Per bar i (its proximal joint J_{i-1}, distal joint J_i, reaction R_k = force ON bar k+1 BY bar k or ground):

    linear momentum   m_i a_Gi = R_{i-1} - R_i + m_i g_vec             (R_n = 0, or -R_H for a pinned tip)
    angular momentum  I_i theta_ddot_i = r_{J(i-1)/Gi} x R_{i-1} + r_{Ji/Gi} x (-R_i)   (about G_i)
    constraints       a_{J(i-1)} seen from bar i-1 = a_{J(i-1)} seen from bar i

where "seen from bar i" is a_Gi + theta_ddot_i z x r_{J/Gi} - omega_i^2 r_{J/Gi} (rigid-body kinematics, one
bar at a time) and the ground does not accelerate: 5n equations in 5n unknowns (15 x 15 for the seed's
triple pendulum). A pinned tip adds R_H and the two rows a_H = 0 (17 x 17).
"""

from __future__ import annotations

import sympy as sp

from .formulation import Formulation, LinearSystem, linear_system
from .symbols import add, along, chain_symbols, cross, scale, sub


def _rigid_acceleration(a_com, alpha, omega, r):
    """Acceleration of the point at ``r`` from the centre of mass of a bar: a_G + alpha z x r - omega^2 r."""
    return (a_com[0] - alpha * r[1] - omega**2 * r[0], a_com[1] + alpha * r[0] - omega**2 * r[1])


class DAE(Formulation):
    name = "dae"
    title = "Maximal coordinates (DAE): momentum balances, joint constraints and reactions"

    def derive(self, n: int, pinned: bool) -> LinearSystem:
        s = chain_symbols(n)
        ax = [sp.Symbol(f"a_x{i}", real=True) for i in range(1, n + 1)]
        ay = [sp.Symbol(f"a_y{i}", real=True) for i in range(1, n + 1)]
        reaction = [(sp.Symbol(f"R_{k}x", real=True), sp.Symbol(f"R_{k}y", real=True)) for k in range(n)]
        reaction_h = (sp.Symbol("R_Hx", real=True), sp.Symbol("R_Hy", real=True))
        zero = (sp.Integer(0), sp.Integer(0))

        # Position of each bar's proximal and distal joints relative to its own centre of mass.
        proximal = [scale(-s.d[i], along(s.theta[i])) for i in range(n)]
        distal = [scale(s.L[i] - s.d[i], along(s.theta[i])) for i in range(n)]
        a_com = [(ax[i], ay[i]) for i in range(n)]

        lmb, amb, constraints, names_lmb, names_amb, names_con = [], [], [], [], [], []
        for i in range(n):
            force_from_next = scale(-1, reaction[i + 1]) if i + 1 < n else (reaction_h if pinned else zero)
            net = add(reaction[i], force_from_next, (sp.Integer(0), -s.m[i] * s.g))
            lmb += [s.m[i] * ax[i] - net[0], s.m[i] * ay[i] - net[1]]
            names_lmb += [f"LMB bar {i + 1} (x)", f"LMB bar {i + 1} (y)"]

            torque = cross(proximal[i], reaction[i]) + cross(distal[i], force_from_next)
            relative_before = s.omega[i] - (s.omega[i - 1] if i > 0 else 0)
            torque += -s.damping * relative_before
            if i + 1 < n:
                torque += s.damping * (s.omega[i + 1] - s.omega[i])
            amb.append(s.I[i] * s.theta_ddot[i] - torque)
            names_amb.append(f"AMB bar {i + 1} about its centre of mass")

            here = _rigid_acceleration(a_com[i], s.theta_ddot[i], s.omega[i], proximal[i])
            if i == 0:
                there = zero
            else:
                there = _rigid_acceleration(a_com[i - 1], s.theta_ddot[i - 1], s.omega[i - 1], distal[i - 1])
            gap = sub(here, there)
            constraints += [gap[0], gap[1]]
            names_con += [f"joint {i} acceleration match (x)", f"joint {i} acceleration match (y)"]

        equations = lmb + amb + constraints
        names = names_lmb + names_amb + names_con
        unknowns = []
        for i in range(n):
            unknowns += [ax[i], ay[i], s.theta_ddot[i]]
        for k in range(n):
            unknowns += list(reaction[k])
        tip_rows = None
        tip_reaction_index = None
        if pinned:
            a_tip = _rigid_acceleration(a_com[n - 1], s.theta_ddot[n - 1], s.omega[n - 1], distal[n - 1])
            tip_rows = (len(equations), len(equations) + 1)
            equations += [a_tip[0], a_tip[1]]
            names += ["tip H does not accelerate (x)", "tip H does not accelerate (y)"]
            unknowns += list(reaction_h)
            tip_reaction_index = (5 * n, 5 * n + 1)
        A, b = linear_system(equations, unknowns)
        return LinearSystem(
            formulation=self.name,
            n=n,
            pinned=pinned,
            symbols=s,
            A=A,
            b=b,
            unknowns=unknowns,
            equation_names=names,
            theta_ddot_index=[3 * i + 2 for i in range(n)],
            reaction_index=[(3 * n + 2 * k, 3 * n + 2 * k + 1) for k in range(n)],
            tip_reaction_index=tip_reaction_index,
            tip_rows=tip_rows,
        )
