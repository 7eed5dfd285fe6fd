"""The maximal-coordinate DAE of :mod:`physics.mechanism.dae` as machine code, for the integrator.

The constraint equations of :mod:`physics.mechanism.constraints` are written again in sympy symbols (the same
closed forms: a pin's two gaps, a slider's offset across its guide and relative rotation, a motor's relative
angle), differentiated by sympy for the Jacobian and ``gamma``, and the augmented system

    [ M  -Phi_q^T ] [ qddot  ]   [ Q                                        ]
    [ Phi_q   0   ] [ lambda ] = [ gamma - 2 alpha (Phi_q qdot - nu) - beta^2 Phi ]

compiled by :mod:`physics.mechanism.native_system`. Nothing is taken from the tree formulations. The numeric
:class:`~physics.mechanism.dae.MechanismDAE` still gives every sample's reactions (and refuses a singular pose);
a test checks that the two give the same accelerations.
"""

from __future__ import annotations

import functools
import json

import sympy as sp

from .dae import MechanismDAE
from .model import Mechanism
from .native_system import NativeSystem
from .tree import BAUMGARTE_GAINS


def _rotation(phi) -> sp.Matrix:
    return sp.Matrix([[sp.cos(phi), -sp.sin(phi)], [sp.sin(phi), sp.cos(phi)]])


def compile_dae(mechanism: Mechanism) -> tuple[NativeSystem, NativeSystem]:
    """Machine code of ``mechanism``'s DAE: the augmented system (parameters ``(t, alpha, beta)``) and the
    constraints' Jacobian and residual ``(Phi_q, Phi)`` (parameter ``t``) for projection; compiled once per
    mechanism description and kept for the process, as the tree formulations are."""
    return _compile(mechanism.model_dump_json())


@functools.lru_cache(maxsize=16)
def _compile(description: str) -> tuple[NativeSystem, NativeSystem]:
    dae = MechanismDAE(Mechanism.model_validate(json.loads(description)))
    constraints = dae.constraints
    size = constraints.size
    q = sp.Matrix(sp.symbols(f"q0:{size}"))
    qdot = sp.Matrix(sp.symbols(f"qd0:{size}"))
    t = sp.Symbol("t", real=True)

    def angle(k: int):
        return sp.Integer(0) if k < 0 else q[3 * k + 2]

    def point(k: int, arm) -> sp.Matrix:
        arm = sp.Matrix([float(arm[0]), float(arm[1])])
        if k < 0:
            return arm
        return sp.Matrix([q[3 * k], q[3 * k + 1]]) + _rotation(q[3 * k + 2]) * arm

    rows: list = []
    speeds: list[float] = []
    for item in constraints._items:
        if item[0] == "pin":
            _, i, s_a, j, s_b = item
            gap = point(i, s_a) - point(j, s_b)
            rows += [gap[0], gap[1]]
            speeds += [0.0, 0.0]
        elif item[0] == "slide":
            _, i, s_p, j, s_t, m, _ = item
            normal = _rotation(angle(j)) * sp.Matrix([float(m[0]), float(m[1])])
            rows += [(normal.T * (point(i, s_p) - point(j, s_t)))[0], angle(i) - angle(j)]
            speeds += [0.0, 0.0]
        else:
            _, i, j, speed = item
            rows.append(angle(j) - angle(i) - speed * t)
            speeds.append(float(speed))
    phi = sp.Matrix(rows)
    jacobian = phi.jacobian(q)
    closures = NativeSystem(list(q), [], [t], jacobian, phi)
    gamma = -(jacobian * qdot).jacobian(q) * qdot
    alpha, beta = BAUMGARTE_GAINS
    gamma -= 2 * alpha * (jacobian * qdot - sp.Matrix(speeds)) + beta**2 * phi
    applied = sp.Matrix(dae.gravity.tolist())
    for a, b, torque in dae._torques:
        if b >= 0:
            applied[3 * b + 2] += torque
        if a >= 0:
            applied[3 * a + 2] -= torque
    for a, b, damping in dae._dampers:
        relative = (qdot[3 * b + 2] if b >= 0 else 0) - (qdot[3 * a + 2] if a >= 0 else 0)
        if b >= 0:
            applied[3 * b + 2] -= damping * relative
        if a >= 0:
            applied[3 * a + 2] += damping * relative
    # viscous sliders: -c (grad s . qdot) grad s, s the sliding point's distance along the guide
    sliders = [item for item in constraints._items if item[0] == "slide"]
    for (_, i, s_p, j, s_t, _, u), damping in zip(sliders, dae.slide_damping):
        if damping:
            along = _rotation(angle(j)) * sp.Matrix([float(u[0]), float(u[1])])
            gradient = sp.Matrix([(along.T * (point(i, s_p) - point(j, s_t)))[0]]).jacobian(q)
            applied -= gradient.T * (float(damping) * (gradient * qdot)[0])
    count = len(rows)
    matrix = sp.zeros(size + count, size + count)
    for k in range(size):
        matrix[k, k] = float(dae.mass_diagonal[k])
    matrix[:size, size:], matrix[size:, :size] = -jacobian.T, jacobian
    return NativeSystem(list(q), list(qdot), [t, alpha, beta], matrix, applied.col_join(gamma)), closures
