"""The chains and four-bars of the rest of Linkage Lab, written as mechanisms.

So the general description can be checked against the three derived chain formulations: the same bodies,
the same pins (joint k joins bar k's distal end to bar k+1's proximal end, as in docs/architecture.md, so a
pin's multipliers are the chain's reaction ``R_k``: the force ON bar k+1 BY bar k), and a closed chain's tip
pinned to a ground point ``H``. A chain's joint damping ``c`` (``Settings.damping``: a torque ``-c`` times the
relative rate of the two bars a joint joins, docs/physics.md) is the damping of pins ``O`` and ``J1 .. J(n-1)``;
the tip's pin ``H`` carries no damper, as the chain's Rayleigh function has none there.
"""

from __future__ import annotations

import numpy as np

from ..kinematics import com_positions, com_velocities, joint_positions
from ..model import Chain
from .description import Body, Mechanism, Revolute


def chain_mechanism(chain: Chain, theta_sketch, damping: float = 0.0) -> Mechanism:
    """The chain drawn at angles ``theta_sketch`` (absolute, from the downward vertical), its joints damped by
    ``damping`` (the chain's ``Settings.damping``)."""
    L = chain.array("L")
    theta_sketch = np.asarray(theta_sketch, dtype=float)
    joints = joint_positions(L, theta_sketch)
    coms = com_positions(chain.params(), theta_sketch)
    bodies = []
    for k, bar in enumerate(chain.bars):
        bodies.append(Body(
            name=f"bar{k + 1}",
            points={"P": tuple(joints[k]), "D": tuple(joints[k + 1])},
            mass=bar.m, com=tuple(coms[k]), inertia=bar.I,
        ))
    damping = float(damping)
    pins = [Revolute(name="O", a="bar1.P", b="ground.O", damping=damping)]
    pins += [Revolute(name=f"J{k}", a=f"bar{k + 1}.P", b=f"bar{k}.D", damping=damping) for k in range(1, chain.n)]
    ground = {"O": (0.0, 0.0)}
    if chain.pin is not None:
        ground["H"] = (float(chain.pin[0]), float(chain.pin[1]))
        pins.append(Revolute(name="H", a=f"bar{chain.n}.D", b="ground.H"))
    return Mechanism(name=f"chain of {chain.n}", g=chain.g, ground=ground, bodies=bodies, joints=pins)


def chain_state(chain: Chain, theta_sketch, theta, omega) -> tuple[np.ndarray, np.ndarray]:
    """``(q, qdot)`` of :func:`chain_mechanism` at the chain's state ``(theta, omega)``."""
    params = chain.params()
    centres = com_positions(params, np.asarray(theta, dtype=float))
    rates = com_velocities(params, np.asarray(theta, dtype=float), np.asarray(omega, dtype=float))
    q = np.column_stack([centres, np.asarray(theta) - np.asarray(theta_sketch)]).ravel()
    qdot = np.column_stack([rates, np.asarray(omega, dtype=float)]).ravel()
    return q, qdot


def chain_quantities(chain: Chain, theta_sketch, run) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A run of :func:`chain_mechanism` in the chain's own conventions and shapes: ``(theta, omega)`` (T, n), the
    absolute angles from the downward vertical (the sketch's plus each bar's turn) and their rates, the joint
    reactions ``(T, n, 2)`` (pin ``O``, then ``J1 .. J(n-1)``: the force ON bar k+1 BY bar k, the chain's
    ``R_k``) and, for a pinned chain, the tip's ``(T, 2)`` (pin ``H``: the force ON bar n BY the ground; ``(T, 0)``
    for an open chain). The reactions are the run's own rows: the DAE's multipliers for ``method="dae"``."""
    n = chain.n
    theta = run.q[:, 2::3] + np.asarray(theta_sketch, dtype=float)
    omega = run.qdot[:, 2::3]
    reactions = run.reaction_rows[:, : 2 * n].reshape(-1, n, 2)
    tip = run.reaction_rows[:, 2 * n : 2 * n + 2] if chain.pin is not None else np.zeros((run.t.size, 0))
    return theta, omega, reactions, tip
