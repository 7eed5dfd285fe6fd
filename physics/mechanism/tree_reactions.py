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
formulation integrated.

**Loops of pins** (:class:`LoopReactions`, :func:`plan_loops`: every joint a pin, each loop closed by a cut pin,
speed motors on any pin; the four-bar, a chain with its tip pinned to the ground): the cut pins' forces and the
speed motors' torques are the unknowns of a small system, the rest follows from the force balances as above.
Turning the subtree below a tree pin ``k`` about that pin's point ``P_k`` moves no tree pin, so the moment of
the subtree's imbalance ``M qddot - Q`` about ``P_k`` is carried by the cut pins' forces and the motors' torques
that cross the subtree's boundary alone: one equation per tree pin, ``(P_a - P_k) x lambda_C`` for a cut pin
whose body ``a`` hangs below ``k`` (``-(P_b - P_k) x lambda_C`` for its ``b``, each end at its own point, as in
``Phi_q``), ``+-mu`` for a motor with one body below ``k``. It is ``Phi_q^T lambda = M qddot - Q`` multiplied by
the tree's velocity modes (``(Phi_C J)^T lambda_C = J^T (M qddot - Q)``, the closure's Jacobian in tree
coordinates): ``B`` equations (one per body) for ``2 C + K`` unknowns (``C`` cut pins, ``K`` speed motors, at most
``B`` when the mobility is not negative), solved in the least-squares sense by a modified Gram-Schmidt QR
written out over every sample at once (a few columns, no LAPACK call per sample). Then a tree pin's force is
``s`` times the subtree's summed force imbalance less the cut pins' forces on the subtree. A run has the small
system's answer already: its tree formulation holds the cut joints' and speed motors' rows and solved for their
multipliers (in the DAE's meaning), so a run's reactions take those (:func:`physics.mechanism.engine.
_loop_multipliers`) and compute only the tree pins' rows; the small system answers any other samples. A sample
whose small system is near losing rank (a dead centre) gets NaN rows, which :func:`physics.mechanism.engine.body_reactions`
solves by the QR of ``Phi_q^T`` as before. Gears and sliders keep the QR (:func:`plan` and :func:`plan_loops`
give None for them).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .constraints import Constraints
from .description import GROUND
from .joints import MOTOR, kind_of
from .topology import PIN, Topology, open_tree_of_pins


# eq=False, repr=False: its arrays compare elementwise and print whole; generating __eq__ and __repr__ cost
# every process about 0.5 ms a class (benchmarks/small_cuts.py)
@dataclass(frozen=True, eq=False, repr=False)
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
    if not open_tree_of_pins(mechanism, topology):
        return None
    assert topology is not None  # open_tree_of_pins is False without one
    bodies = {name: k for k, name in enumerate(topology.bodies)}
    row_of = {(row.joint, row.meaning): number for number, row in enumerate(constraints.rows)}
    meanings = kind_of(mechanism.joints[0]).meanings
    pin_of = {joint.name: number for number, joint in enumerate(mechanism.joints)}
    child_of: dict[str, str] = {joint: child for child, (joint, _) in topology.parent.items()}
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


# A sample whose small system's QR has min |R_jj| below this times max |R_jj| is left to the QR of Phi_q^T (NaN
# rows): stricter than the QR's own rank test (engine._QR_RANK_RATIO), so near a dead centre the reference path
# answers.
_LOOP_RANK_RATIO = 1e-8


# eq=False, repr=False: its arrays compare elementwise and print whole; generating __eq__ and __repr__ cost
# every process about 0.5 ms a class (benchmarks/small_cuts.py)
@dataclass(frozen=True, eq=False, repr=False)
class LoopReactions:
    """The constant pieces of the closed form of a mechanism of pins with loops (every array read-only): every
    quantity the small system needs is linear in ``q`` and each body's ``cos phi, sin phi`` (the pins' points,
    arms and gaps) or in the imbalance ``M qddot - Q`` (the subtrees' sums), so each comes out of one product
    with a constant matrix. ``N`` tree pins (one per body), ``P`` pairs (tree pin ``k``, body ``i`` below it),
    ``C`` cut pins, ``K`` speed motors, ``U = 2 C + K`` unknowns.

    ``geometry (5 B, 2 P + 2 N + 2 C N)`` and ``geometry_constant`` (the ground's points): from ``[q, cos phi,
    sin phi]``, the pairs' ``x_i - P_k`` and the tree pins' gaps ``P_a - P_b`` (x), the same in y, then each
    cut pin's two columns of the small system (``-arm_y``, ``arm_x``: its force's moment about each ``P_k``,
    an end ``a`` below ``k`` at ``P_a - P_k``, an end ``b`` at minus that, less the gaps of the tree pins inside
    that carry it). ``sums (3 B, rows + 2 P + 3 N)``: from the imbalance, every row's part before the unknowns
    (each tree pin's x and y rows ``s`` times the subtree's summed force, as :attr:`TreeReactions.linear`), the
    pairs' ``f_y`` with the tree pins' ``-lambda_y``, then ``f_x`` with ``-lambda_x``, then each subtree's summed
    torque. ``moments (P + N, N)``: the pairs' and the inner tree pins' (a tree pin ``j`` joining two bodies
    below ``k``) share of each moment equation. ``motor_columns (N, K)``: a motor's torque in each moment
    equation (``+1`` for its ``b`` below ``k``, ``-1`` for its ``a``). ``unknowns_to_rows (U, rows)``: the
    unknowns' own rows, and each cut pin's force taken off the tree pins whose subtree holds one of its bodies."""

    geometry: np.ndarray
    geometry_constant: np.ndarray
    sums: np.ndarray
    moments: np.ndarray
    motor_columns: np.ndarray
    unknowns_to_rows: np.ndarray

    def solve(self, mass_diagonal: np.ndarray, applied: np.ndarray, q: np.ndarray, qddot: np.ndarray,
              multipliers: np.ndarray | None = None) -> np.ndarray:
        """Every sample's reaction rows ``(T, rows)`` as :meth:`TreeReactions.solve` gives them; a sample whose
        small system is near losing rank gets NaN rows (the caller's QR answers it). ``multipliers (T, U)``:
        the tree formulation's own multipliers of the samples when the caller holds them (its rows are the cut
        joints' in joint order, then the speed motors' in driver order, in the DAE's meaning:
        :mod:`physics.mechanism.symbolic_tree`), which are the small system's answer: only the tree pins' rows
        are computed. Computed with the samples along the last axis (each quantity a contiguous row of ``T``
        numbers), so the small system's columns are rows of one product, not copies."""
        rows = self.unknowns_to_rows.shape[1]
        if multipliers is not None:
            linear = self.sums[:, :rows]  # the tree pins' rows: the subtrees' summed force imbalance
            return (mass_diagonal * qddot - applied) @ linear + multipliers @ self.unknowns_to_rows
        count = self.motor_columns.shape[0]
        half = self.moments.shape[0]  # P + N
        summed = self.sums.T @ (mass_diagonal * qddot - applied).T  # (rows + 2 P + 3 N, T)
        pose = q.T
        angle = pose[2::3]
        shape = (self.geometry.T @ np.concatenate((pose, np.cos(angle), np.sin(angle)))
                 + self.geometry_constant[:, None])  # (2 P + 2 N + 2 C N, T)
        # each tree pin's moment equation: the subtree's imbalance about its point, and gap x lambda of the pins
        # inside (the pose's closure residual: exact for any pose, as Phi_q's rows are)
        moment = (self.moments.T @ (shape[:half] * summed[rows:rows + half]
                                    - shape[half:2 * half] * summed[rows + half:rows + 2 * half])
                  + summed[rows + 2 * half:])  # (N, T)
        columns = [shape[start:start + count] for start in range(2 * half, shape.shape[0], count)]
        columns += [np.broadcast_to(column[:, None], moment.shape) for column in self.motor_columns.T]
        out = summed[:rows] + self.unknowns_to_rows.T @ _least_squares(columns, moment)
        return np.ascontiguousarray(out.T)


def _least_squares(columns: list[np.ndarray], rhs: np.ndarray) -> np.ndarray:
    """``(U, T)``: the least-squares solution of every sample's ``[columns] z = rhs`` (each column and ``rhs``
    ``(N, T)``, a sample per column) by modified Gram-Schmidt with the right-hand side carried along (backward
    stable for least squares, Bjorck) and back substitution; NaN where the columns are near dependent
    (:data:`_LOOP_RANK_RATIO`)."""
    count = len(columns)
    work = list(columns)
    diagonal, triangle, projected = [], {}, []
    with np.errstate(divide="ignore", invalid="ignore"):  # a zero column: its NaN is caught by the rank test
        for j in range(count):
            norm = np.sqrt(np.einsum("nt,nt->t", work[j], work[j]))
            diagonal.append(norm)
            unit = work[j] / norm
            for later in range(j + 1, count):
                triangle[j, later] = np.einsum("nt,nt->t", unit, work[later])
                work[later] = work[later] - triangle[j, later] * unit
            projected.append(np.einsum("nt,nt->t", unit, rhs))
            rhs = rhs - projected[-1] * unit
        out = np.empty((count, rhs.shape[1]))
        for j in reversed(range(count)):
            value = projected[j]
            for later in range(j + 1, count):
                value = value - triangle[j, later] * out[later]
            out[j] = value / diagonal[j]
        norms = np.array(diagonal).reshape(count, -1)
        near = ~(norms.min(axis=0, initial=np.inf) > _LOOP_RANK_RATIO * norms.max(axis=0, initial=0.0))
    if near.any():
        out[:, near] = np.nan
    return out


def plan_loops(constraints: Constraints, topology: Topology | None) -> LoopReactions | None:
    """The closed form's pieces for a mechanism of pins with loops (speed and torque motors on any pin); None
    for anything else: an open tree (:func:`plan`), a gear or a slider, more unknowns than bodies (a mobility
    below zero: redundant rows, the QR's minimum-norm answer)."""
    mechanism = constraints.mechanism
    if topology is None or not topology.loops or any(kind_of(joint).name != PIN for joint in mechanism.joints):
        return None
    bodies = {name: k for k, name in enumerate(topology.bodies)}
    row_of = {(row.joint, row.meaning): number for number, row in enumerate(constraints.rows)}
    meanings = kind_of(mechanism.joints[0]).meanings
    joints = {joint.name: joint for joint in mechanism.joints}
    tree = list(topology.parent.items())  # (child, (pin, parent)), parents before children
    cuts = [joints[loop.cut_joint] for loop in topology.loops]
    speeds = [driver.joint for driver in mechanism.drivers if driver.speed is not None]
    count = len(bodies)
    if len(tree) != count or 2 * len(cuts) + len(speeds) > count:
        return None
    below: dict[str, list[str]] = {}
    for child, (_, parent_body) in tree:
        below.setdefault(parent_body, []).append(child)

    def subtree(body: str) -> list[int]:
        found, stack = [], [body]
        while stack:
            here = stack.pop()
            found.append(bodies[here])
            stack += below.get(here, [])
        return found

    features = 5 * count  # [q (3 B), cos phi (B), sin phi (B)]

    def point(body: str, arm) -> tuple[np.ndarray, np.ndarray, tuple[float, float]]:
        """A point's x and y as coefficients of the features, and its constant part (a ground point's)."""
        x, y = np.zeros(features), np.zeros(features)
        if body == GROUND:
            return x, y, (float(arm[0]), float(arm[1]))
        b = bodies[body]
        x[3 * b], x[3 * count + b], x[4 * count + b] = 1.0, arm[0], -arm[1]
        y[3 * b + 1], y[3 * count + b], y[4 * count + b] = 1.0, arm[1], arm[0]
        return x, y, (0.0, 0.0)

    def ends(joint) -> list[tuple[np.ndarray, np.ndarray, tuple[float, float]]]:
        values = kind_of(joint).values(joint, mechanism)
        a, b = _ends(joint)
        return [point(a, values[0:2]), point(b, values[2:4])]

    rows = len(constraints.rows)
    hanging = np.zeros((count, count))  # hanging[k, i]: body i hangs below tree pin k (its child included)
    signs, force_rows, pivots, gaps = [], [], [], []
    for k, (child, (pin_name, _)) in enumerate(tree):
        pin = joints[pin_name]
        a, _ = _ends(pin)
        signs.append(1.0 if child == a else -1.0)
        force_rows.append([row_of[(pin_name, meaning)] for meaning in meanings])
        hanging[k, subtree(child)] = 1.0
        (ax, ay, a_constant), (bx, by, b_constant) = ends(pin)
        pivots.append((ax, ay) if child == a else (bx, by))  # the pin's point on its child: never the ground
        gaps.append((ax - bx, ay - by, (a_constant[0] - b_constant[0], a_constant[1] - b_constant[1])))
    inner = hanging[:, [bodies[child] for child, _ in tree]].T.copy()  # inner[j, k]: j's child below k
    np.fill_diagonal(inner, 0.0)
    pair_pin, pair_body = np.nonzero(hanging)
    pairs = pair_pin.size
    unknowns = 2 * len(cuts) + len(speeds)
    geometry = np.zeros((features, 2 * pairs + 2 * count + 2 * len(cuts) * count))
    constant = np.zeros(geometry.shape[1])
    half = pairs + count
    for number, (pin_k, body_i) in enumerate(zip(pair_pin.tolist(), pair_body.tolist(), strict=True)):
        geometry[3 * body_i, number], geometry[3 * body_i + 1, half + number] = 1.0, 1.0  # x_i - P_k, y_i - P_k
        geometry[:, number] -= pivots[pin_k][0]
        geometry[:, half + number] -= pivots[pin_k][1]
    for j, (gap_x, gap_y, gap_constant) in enumerate(gaps):
        geometry[:, pairs + j], geometry[:, half + pairs + j] = gap_x, gap_y
        constant[pairs + j], constant[half + pairs + j] = gap_constant

    def below_pin(body: str) -> np.ndarray:
        return hanging[:, bodies[body]] if body != GROUND else np.zeros(count)

    unknowns_to_rows = np.zeros((unknowns, rows))
    for number, cut in enumerate(cuts):
        a, b = _ends(cut)
        below_a, below_b = below_pin(a), below_pin(b)
        weight = np.array(signs) * (below_a - below_b)  # how much of lambda_C tree pin j's rows lose
        (ax, ay, a_constant), (bx, by, b_constant) = ends(cut)
        for k in range(count):  # the arm of lambda_C in tree pin k's moment equation
            arm_x = below_a[k] * (ax - pivots[k][0]) - below_b[k] * (bx - pivots[k][0])
            arm_y = below_a[k] * (ay - pivots[k][1]) - below_b[k] * (by - pivots[k][1])
            arm_constant = below_a[k] * np.array(a_constant) - below_b[k] * np.array(b_constant)
            for j in np.flatnonzero(inner[:, k]).tolist():
                arm_x = arm_x - weight[j] * gaps[j][0]
                arm_y = arm_y - weight[j] * gaps[j][1]
                arm_constant = arm_constant - weight[j] * np.array(gaps[j][2])
            column = 2 * half + 2 * number * count + k  # -arm_y (lambda_x's column), then arm_x (lambda_y's)
            geometry[:, column], constant[column] = -arm_y, -arm_constant[1]
            geometry[:, column + count], constant[column + count] = arm_x, arm_constant[0]
        for axis, meaning in enumerate(meanings):
            unknowns_to_rows[2 * number + axis, row_of[(cut.name, meaning)]] = 1.0
            for k in range(count):
                unknowns_to_rows[2 * number + axis, force_rows[k][axis]] -= weight[k]
    motor_columns = np.zeros((count, len(speeds)))
    for number, joint_name in enumerate(speeds):
        a, b = _ends(joints[joint_name])
        motor_columns[:, number] = below_pin(b) - below_pin(a)  # its torque: +mu on b, -mu on a
        unknowns_to_rows[2 * len(cuts) + number, row_of[(joint_name, MOTOR.meanings[0])]] = 1.0
    sums = np.zeros((3 * count, rows + 2 * half + count))
    for k in range(count):
        members = np.flatnonzero(hanging[k])
        for axis in (0, 1):
            sums[3 * members + axis, force_rows[k][axis]] = signs[k]
        sums[3 * members + 2, rows + 2 * half + k] = 1.0  # the subtree's torque
    for number, body_i in enumerate(pair_body.tolist()):
        sums[3 * body_i + 1, rows + number] = 1.0  # f_y of the pair's body
        sums[3 * body_i, rows + half + number] = 1.0  # f_x
    sums[:, rows + pairs:rows + half] = -sums[:, [y for _, y in force_rows]]  # -lambda_y of each tree pin
    sums[:, rows + half + pairs:rows + 2 * half] = -sums[:, [x for x, _ in force_rows]]  # -lambda_x
    moments = np.zeros((half, count))
    moments[np.arange(pairs), pair_pin] = 1.0
    moments[pairs:] = inner
    built = LoopReactions(geometry=geometry, geometry_constant=constant, sums=sums, moments=moments,
                          motor_columns=motor_columns, unknowns_to_rows=unknowns_to_rows)
    for name in LoopReactions.__dataclass_fields__:
        getattr(built, name).setflags(write=False)
    return built


def _ends(joint) -> tuple[str, str]:
    """A pin's two bodies (``"ground"`` for a ground point)."""
    ends = kind_of(joint).bodies(joint)
    assert ends is not None  # a pin joins two bodies
    return ends
