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

from .formulation import Formulation, LinearSystem
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
            """d/dt of an expression in (theta, omega): the chain rule, with theta' = omega, omega' = theta''."""
            total = sp.Integer(0)
            for k in range(n):
                total += sp.diff(expr, theta[k]) * omega[k] + sp.diff(expr, omega[k]) * theta_ddot[k]
            return total

        # Partial velocities e_ij = d(r_Gi)/d(theta_j) (functions of theta only), so v_i = sum_j e_ij omega_j and
        # T = sum_i 1/2 m_i v_i . v_i + 1/2 I_i omega_i^2. Lagrange's terms follow from T by the chain rule through
        # these small pieces instead of by sympy differentiating T (squares of long sums) once per variable:
        #   dT/domega_k = sum_i m_i v_i . e_ik + I_k omega_k,   dT/dtheta_k = sum_i m_i v_i . dv_i/dtheta_k,
        #   d/dt(dT/domega_k) = sum_i m_i (a_i . e_ik + v_i . de_ik/dt) + I_k theta''_k  with a_i = dv_i/dt.
        partial = [[(sp.diff(com[i][0], theta[j]), sp.diff(com[i][1], theta[j])) for j in range(n)] for i in range(n)]
        v_com = [
            (sum((partial[i][j][0] * omega[j] for j in range(n)), sp.Integer(0)),
             sum((partial[i][j][1] * omega[j] for j in range(n)), sp.Integer(0)))
            for i in range(n)
        ]
        # a_i = dv_i/dt = sum_j e_ij theta''_j + (the rest): theta'' enters only through the first sum, so the
        # equations' matrix is read off directly (no Jacobian of the assembled equations).
        a_rest = [
            (sum((time_derivative(partial[i][j][0]) * omega[j] for j in range(n)), sp.Integer(0)),
             sum((time_derivative(partial[i][j][1]) * omega[j] for j in range(n)), sp.Integer(0)))
            for i in range(n)
        ]
        potential = sum((s.m[i] * s.g * com[i][1] for i in range(n)), sp.Integer(0))
        relative = [omega[0]] + [omega[k] - omega[k - 1] for k in range(1, n)]
        dissipation = sum((s.damping * w**2 / 2 for w in relative), sp.Integer(0))

        size = n + (2 if pinned else 0)
        A = sp.zeros(size, size)
        b = sp.zeros(size, 1)
        names, lagrangian_force = [], []
        for k in range(n):
            # d/dt(dT/domega_k) = sum_j M_kj theta''_j + rest, with M_kj = d2T/domega_k domega_j
            #                   = sum_i m_i e_ij . e_ik + I_k delta_kj (bar i moves with theta_k only when i >= k).
            rest = sp.Integer(0)
            dT_dtheta = sp.Integer(0)
            for i in range(k, n):
                e_x, e_y = partial[i][k]
                rest += s.m[i] * (a_rest[i][0] * e_x + v_com[i][0] * time_derivative(e_x)
                                  + a_rest[i][1] * e_y + v_com[i][1] * time_derivative(e_y))
                dT_dtheta += s.m[i] * (v_com[i][0] * sp.diff(v_com[i][0], theta[k])
                                       + v_com[i][1] * sp.diff(v_com[i][1], theta[k]))
            for j in range(n):
                A[k, j] = sum((s.m[i] * (partial[i][j][0] * partial[i][k][0] + partial[i][j][1] * partial[i][k][1])
                               for i in range(max(j, k), n)), sp.Integer(0))
            A[k, k] += s.I[k]
            force_k = dT_dtheta - sp.diff(potential, theta[k]) - sp.diff(dissipation, omega[k])
            # Lagrange: d/dt(dT/domega_k) - dT/dtheta_k + dV/dtheta_k + dD/domega_k = (tip reaction) . dr_H/dtheta_k
            b[k] = force_k - rest
            if pinned:
                A[k, n] = -sp.diff(joints[n][0], theta[k])
                A[k, n + 1] = -sp.diff(joints[n][1], theta[k])
            names.append(f"Lagrange equation for theta_{k + 1}")
            lagrangian_force.append(force_k)

        unknowns = list(theta_ddot)
        tip_rows = None
        tip_reaction_index = None
        if pinned:
            reaction_h = (sp.Symbol("R_Hx", real=True), sp.Symbol("R_Hy", real=True))
            tip_rows = (n, n + 1)
            for axis, label in ((0, "x"), (1, "y")):
                # Phi = r_H - pin; Phi'' = sum_j dr_H/dtheta_j theta''_j + sum_j d/dt(dr_H/dtheta_j) omega_j = 0
                row = n + axis
                for j in range(n):
                    jacobian = sp.diff(joints[n][axis], theta[j])
                    A[row, j] = jacobian
                    b[row] -= time_derivative(jacobian) * omega[j]
                names.append(f"loop constraint Phi_{label}'' = 0")
            unknowns += list(reaction_h)
            tip_reaction_index = (n, n + 1)
        mass_matrix = A[:n, :n]
        lagrangian_force = sp.Matrix(lagrangian_force)
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
