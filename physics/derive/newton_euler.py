"""Newton-Euler in minimal coordinates: angular momentum balance about each joint.

For joint j (j = 0 is O) take the part of the chain beyond it, bars j+1..n, as one free body. The reaction
at joint j passes through the joint, so it drops out of the moment balance about that joint:

    sum_{i>j} [ r_{Gi/Jj} x m_i a_Gi + I_i theta_ddot_i ] = sum_{i>j} r_{Gi/Jj} x m_i g_vec  (+ tip reaction, damping)

with the absolute centre-of-mass accelerations ``a_Gi`` written out from the kinematics of the chain
(the seed's AMB about O, E and F). For a pinned tip the ground's force R_H at H acts on bar n, which lies
beyond every joint, so it enters every balance; two more rows state that H does not accelerate.
"""

from __future__ import annotations

import sympy as sp

from .formulation import Formulation, LinearSystem, linear_system
from .symbols import add, along, chain_symbols, cross, normal, scale, sub


def _joint_positions(s):
    joints = [(sp.Integer(0), sp.Integer(0))]
    for i in range(s.n):
        joints.append(add(joints[-1], scale(s.L[i], along(s.theta[i]))))
    return joints


def _point_acceleration(s, upto, extra):
    """Acceleration of a point ``extra`` along bar ``upto`` (0-based) beyond its proximal joint:
    sum over the bars before it of L_k (theta_ddot_k n_k - omega_k^2 e_k), plus the same with ``extra``."""
    terms = []
    for k in range(upto + 1):
        arm = s.L[k] if k < upto else extra
        terms.append(scale(arm * s.theta_ddot[k], normal(s.theta[k])))
        terms.append(scale(-arm * s.omega[k] ** 2, along(s.theta[k])))
    return add(*terms)


class NewtonEuler(Formulation):
    name = "newton_euler"
    title = "Newton-Euler (angular momentum balance about each joint)"

    def derive(self, n: int, pinned: bool) -> LinearSystem:
        s = chain_symbols(n)
        joints = _joint_positions(s)
        com = [add(joints[i], scale(s.d[i], along(s.theta[i]))) for i in range(n)]
        a_com = [_point_acceleration(s, i, s.d[i]) for i in range(n)]
        weight = [(sp.Integer(0), -s.m[i] * s.g) for i in range(n)]
        reaction_h = (sp.Symbol("R_Hx", real=True), sp.Symbol("R_Hy", real=True))

        equations, names = [], []
        for j in range(n):
            pivot = joints[j]
            rate = sum(
                (cross(sub(com[i], pivot), scale(s.m[i], a_com[i])) + s.I[i] * s.theta_ddot[i] for i in range(j, n)),
                sp.Integer(0),
            )
            moment = sum((cross(sub(com[i], pivot), weight[i]) for i in range(j, n)), sp.Integer(0))
            # Damping: only the damper at joint j acts across the cut; the ones inside the subchain cancel.
            relative_speed = s.omega[j] - (s.omega[j - 1] if j > 0 else 0)
            moment += -s.damping * relative_speed
            if pinned:
                moment += cross(sub(joints[n], pivot), reaction_h)
            equations.append(rate - moment)
            names.append(f"AMB about joint {j} (bars {j + 1}..{n})")

        unknowns = list(s.theta_ddot)
        tip_rows = None
        tip_reaction_index = None
        if pinned:
            a_tip = _point_acceleration(s, n - 1, s.L[n - 1])
            tip_rows = (len(equations), len(equations) + 1)
            equations += [a_tip[0], a_tip[1]]
            names += ["tip H does not accelerate (x)", "tip H does not accelerate (y)"]
            unknowns += list(reaction_h)
            tip_reaction_index = (n, n + 1)
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
            theta_ddot_index=list(range(n)),
            tip_reaction_index=tip_reaction_index,
            tip_rows=tip_rows,
        )
