"""A tree formulation's reactions in closed form, for an open tree of pins: no Jacobian, no QR.

A tree formulation (Newton-Euler, Lagrange) solves for the joint accelerations only; its reactions come after
the run from Newton's second law on every body, ``Phi_q^T lambda = M qddot - Q`` (:func:`physics.mechanism.
engine.body_reactions`), in general by a QR of ``Phi_q^T``. For a mechanism whose joints are all pins of its
spanning tree (a chain, an open tree: no loop, no gear), with speed motors on any of them, that system is block
triangular in tree order: a body's three equations hold the rows of the pin to its parent and those of its
children's pins, so the reactions follow from the leaves to the root (the backward Newton-Euler recursion).

* A pin's rows on its body ``a`` are ``+I`` in the translation columns (``-I`` on ``b``), so a body's force
  balance gives its parent pin's force at once: the force that pin exerts ON its child body is the sum of
  ``m a - F`` over the child's subtree (every body hanging from it). With ``s = +1`` when the child is the pin's
  body ``a`` (the row's reaction is the force ON ``a`` BY ``b``) and ``-1`` when it is ``b``:
  ``lambda_pin = s * sum over the subtree of (M qddot - Q)_xy``, one constant signed incidence matrix over every
  sample at once.
* A speed motor's row ``phi_b - phi_a - omega t`` is ``+1`` in ``b``'s rotation column and ``-1`` in ``a``'s;
  a pin's rows give body ``i`` the torque ``rho x lambda`` (``rho`` the pin's arm from ``i``'s centre of mass,
  turned with the body; sign as above). What the pins leave of a body's moment balance, ``r_i = (I alpha -
  tau)_i - sum of its pins' torques``, is carried by the motors: the motor of the pin above body ``c`` exerts
  ``sum of r over the bodies reached from c through motored pins`` on ``c`` (the torque of an unmotored pin's
  subtree balances to zero, as the pin cannot carry one).

Every reaction row keeps its meaning and sign (``lambda[JOINT: row]``, the force ON body ``a`` BY body ``b``, a
motor's torque on ``b``); the answer is the exact solution of the same consistent system the QR solves, so the
two agree to rounding. The closed form reads the maximal ``q, qdot, qddot`` only, whatever coordinates the
formulation integrated. Loops, gears and sliders keep the QR (:func:`plan` gives None for them).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .constraints import Constraints
from .joints import MOTOR, kind_of
from .model import GROUND
from .topology import Topology

PIN = "revolute"


@dataclass(frozen=True)
class TreeReactions:
    """The constant pieces of the closed form for one mechanism (every array read-only).

    ``linear (3 B, rows)``: the reactions' part linear in the imbalance ``M qddot - Q``: each pin's x and y rows
    ``s`` times the imbalance's x and y summed over the bodies hanging from the pin (itself included), each
    motor's row its sign on the body below its pin (``+1`` for ``b``) times the moment imbalance summed over the
    bodies reached from that body through motored pins. ``side_body, side_pin, side_sign, side_arm`` ``(P,)``,
    ``(P,)``, ``(P,)``, ``(P, 2)``: every pin end on a moving body, its pin, ``+1`` for the pin's body ``a``
    (``-1`` for ``b``) and its arm from the body's centre of mass in the sketch; ``force_rows (J, 2)`` each pin's
    x and y rows; ``motor_rows (K,)`` the speed motors' rows and ``torque_to_motor (P, K)`` what a pin end's
    torque on its body takes from each motor's row (the pose-dependent part)."""

    linear: np.ndarray
    force_rows: np.ndarray
    side_body: np.ndarray
    side_pin: np.ndarray
    side_sign: np.ndarray
    side_arm: np.ndarray
    motor_rows: np.ndarray
    torque_to_motor: np.ndarray

    def solve(self, mass_diagonal: np.ndarray, applied: np.ndarray, q: np.ndarray, qddot: np.ndarray) -> np.ndarray:
        """Every sample's reaction rows ``(T, rows)`` from its poses ``q``, accelerations ``qddot`` and applied
        forces ``applied = Q`` (each ``(T, 3 B)``, finite): one product with :attr:`linear`, and for speed
        motors the pins' torques about each body's centre of mass taken off."""
        out = (mass_diagonal * qddot - applied) @ self.linear  # m a - F, I alpha - tau by body: (T, rows)
        if self.motor_rows.size:
            angle = q[:, 2::3][:, self.side_body]  # (T, P)
            cos, sin = np.cos(angle), np.sin(angle)
            arm_x = cos * self.side_arm[:, 0] - sin * self.side_arm[:, 1]
            arm_y = sin * self.side_arm[:, 0] + cos * self.side_arm[:, 1]
            force_x = out[:, self.force_rows[self.side_pin, 0]] * self.side_sign  # (T, P): on the end's body
            force_y = out[:, self.force_rows[self.side_pin, 1]] * self.side_sign
            out[:, self.motor_rows] -= (arm_x * force_y - arm_y * force_x) @ self.torque_to_motor
        return out


def plan(constraints: Constraints, topology: Topology | None) -> TreeReactions | None:
    """The closed form's pieces for a mechanism whose joints are all pins of its spanning tree (speed and
    torque motors on any of them allowed); None for anything else (a loop, a gear, a slider, a body the ground
    does not reach), whose reactions keep the QR."""
    mechanism = constraints.mechanism
    if topology is None or topology.loops or not mechanism.joints:
        return None
    if any(kind_of(joint).name != PIN for joint in mechanism.joints):
        return None
    bodies = {name: k for k, name in enumerate(topology.bodies)}
    row_of = {(row.joint, row.meaning): number for number, row in enumerate(constraints.rows)}
    meanings = kind_of(mechanism.joints[0]).meanings
    pin_of = {joint.name: number for number, joint in enumerate(mechanism.joints)}
    child_of: dict[str, str] = {joint: child for child, (joint, _) in topology.parent.items()}
    if set(child_of) != set(pin_of):
        return None
    count = len(bodies)
    below: dict[str, list[str]] = {}
    for child, (_, parent_body) in topology.parent.items():
        below.setdefault(parent_body, []).append(child)
    speeds = {driver.joint for driver in mechanism.drivers if driver.speed is not None}

    def subtree(body: str, through_motors: bool) -> list[int]:
        found, stack = [], [body]
        while stack:
            here = stack.pop()
            found.append(bodies[here])
            stack += [child for child in below.get(here, ())
                      if not through_motors or topology.parent[child][0] in speeds]
        return found

    force_rows = np.empty((len(pin_of), 2), dtype=int)
    linear = np.zeros((3 * count, len(constraints.rows)))
    motor_rows, motor_bodies = [], []
    side_body, side_pin, side_sign, side_arm = [], [], [], []
    for number, joint in enumerate(mechanism.joints):
        ends = kind_of(joint).bodies(joint)
        assert ends is not None  # a pin joins two bodies
        a, b = ends
        child = child_of[joint.name]
        sign = 1.0 if child == a else -1.0
        force_rows[number] = [row_of[(joint.name, meaning)] for meaning in meanings]
        hanging = np.array(subtree(child, False))
        linear[3 * hanging, force_rows[number, 0]] = sign
        linear[3 * hanging + 1, force_rows[number, 1]] = sign
        values = kind_of(joint).values(joint, mechanism)
        for body, arm, end_sign in ((a, values[0:2], 1.0), (b, values[2:4], -1.0)):
            if body != GROUND:
                side_body.append(bodies[body])
                side_pin.append(number)
                side_sign.append(end_sign)
                side_arm.append(arm)
        if joint.name in speeds:
            motor_rows.append(row_of[(joint.name, MOTOR.meanings[0])])
            turning = np.zeros(count)
            turning[subtree(child, True)] = 1.0 if child == b else -1.0
            linear[2::3, motor_rows[-1]] = turning
            motor_bodies.append(turning)
    incidence = np.zeros((len(side_body), count))
    incidence[np.arange(len(side_body)), side_body] = 1.0
    built = TreeReactions(
        linear=linear, force_rows=force_rows, side_body=np.array(side_body, dtype=int),
        side_pin=np.array(side_pin, dtype=int), side_sign=np.array(side_sign),
        side_arm=np.array(side_arm, dtype=float).reshape(-1, 2), motor_rows=np.array(motor_rows, dtype=int),
        torque_to_motor=incidence @ np.array(motor_bodies).reshape(-1, count).T)
    for name in TreeReactions.__dataclass_fields__:
        getattr(built, name).setflags(write=False)
    return built
