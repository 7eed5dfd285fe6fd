"""Lagrange's equations from T - V, in the absolute angles.

    d/dt (dT/d omega_k) - dT/d theta_k + dV/d theta_k = Q_k

with T = sum 1/2 m_i |v_Gi|^2 + 1/2 I_i omega_i^2 and V = sum m_i g y_Gi built from the positions alone
(velocities by differentiating positions, not from any other formulation). Because the unknowns enter only
through d/dt(dT/d omega), ``A`` is the Hessian of T in the velocities and the rest goes to ``b``.
Q_k collects joint damping (a Rayleigh dissipation function) and, for a pinned tip, the generalized force
of the tip reaction, R_H . d r_H / d theta_k; the loop then adds Phi_ddot = 0 for Phi = r_H(theta) - pin,
obtained by differentiating the position constraint twice.
"""

from __future__ import annotations

import sympy as sp

from .formulation import Formulation, LinearSystem, linear_system
from .symbols import add, along, chain_symbols, scale


class Lagrange(Formulation):
    name = "lagrange"
    title = "Lagrange's equations from T - V"

    def derive(self, n: int, pinned: bool) -> LinearSystem:
        s = chain_symbols(n)
        theta, omega, theta_ddot = list(s.theta), list(s.omega), list(s.theta_ddot)
        joints = [(sp.Integer(0), sp.Integer(0))]
        for i in range(n):
            joints.append(add(joints[-1], scale(s.L[i], along(s.theta[i]))))
        com = [add(joints[i], scale(s.d[i], along(s.theta[i]))) for i in range(n)]

        def time_derivative(expr):
            return sum((sp.diff(expr, theta[k]) * omega[k] for k in range(n)), sp.Integer(0))

        v_com = [(time_derivative(c[0]), time_derivative(c[1])) for c in com]
        kinetic = sum(
            (s.m[i] * (v_com[i][0] ** 2 + v_com[i][1] ** 2) / 2 + s.I[i] * omega[i] ** 2 / 2 for i in range(n)),
            sp.Integer(0),
        )
        potential = sum((s.m[i] * s.g * com[i][1] for i in range(n)), sp.Integer(0))
        relative = [omega[0]] + [omega[k] - omega[k - 1] for k in range(1, n)]
        dissipation = sum((s.damping * w**2 / 2 for w in relative), sp.Integer(0))

        reaction_h = (sp.Symbol("R_Hx", real=True), sp.Symbol("R_Hy", real=True))
        equations, names = [], []
        for k in range(n):
            p_k = sp.diff(kinetic, omega[k])
            dp_dt = sum(
                (sp.diff(p_k, theta[j]) * omega[j] + sp.diff(p_k, omega[j]) * theta_ddot[j] for j in range(n)),
                sp.Integer(0),
            )
            generalized_force = -sp.diff(dissipation, omega[k])
            if pinned:
                generalized_force += reaction_h[0] * sp.diff(joints[n][0], theta[k])
                generalized_force += reaction_h[1] * sp.diff(joints[n][1], theta[k])
            equations.append(dp_dt - sp.diff(kinetic, theta[k]) + sp.diff(potential, theta[k]) - generalized_force)
            names.append(f"Lagrange equation for theta_{k + 1}")

        unknowns = list(theta_ddot)
        tip_rows = None
        tip_reaction_index = None
        if pinned:
            tip_rows = (n, n + 1)
            for axis, label in ((0, "x"), (1, "y")):
                phi = joints[n][axis] - (s.pin_x if axis == 0 else s.pin_y)
                phi_dot = time_derivative(phi)
                phi_ddot = sum(
                    (sp.diff(phi_dot, theta[j]) * omega[j] + sp.diff(phi_dot, omega[j]) * theta_ddot[j] for j in range(n)),
                    sp.Integer(0),
                )
                equations.append(phi_ddot)
                names.append(f"loop constraint Phi_{label}'' = 0")
            unknowns += list(reaction_h)
            tip_reaction_index = (n, n + 1)
        A, b = linear_system(equations, unknowns)
        mass_matrix = sp.Matrix(n, n, lambda i, j: sp.diff(kinetic, omega[i], omega[j]))
        lagrangian_force = sp.Matrix(
            [sp.diff(kinetic, theta[k]) - sp.diff(potential, theta[k]) - sp.diff(dissipation, omega[k]) for k in range(n)]
        )
        return LinearSystem(
            formulation=self.name,
            n=n,
            pinned=pinned,
            symbols=s,
            A=A,
            b=b,
            unknowns=unknowns,
            equation_names=names,
            theta_ddot_index=list(range(n)),
            tip_reaction_index=tip_reaction_index,
            tip_rows=tip_rows,
            mass_matrix=mass_matrix,
            lagrangian_force=lagrangian_force,
        )
