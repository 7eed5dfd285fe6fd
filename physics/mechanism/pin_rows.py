"""``Phi`` and ``Phi_q`` at one pose of a mechanism whose every constraint row is a pin's gap (chains, open or
closed by a pin to the ground, and any linkage of pins without speed motors), written out for pins.

Why: a run assembles its start (:func:`physics.mechanism.assembly.assembled_with_jacobian`) through the joint
kinds' generic rows (:class:`~physics.mechanism.constraints.Constraints`, the rows every kind shares with the
symbolic derivations), about 0.25 ms for seed case C's three pins, more than half of what the chain engine
spends on its whole run (issue 24: a chain handed to the mechanism engine with a new start each call). A pin's
rows are two lines: its two points' gap, ``r_a + R(phi_a) s_a - r_b - R(phi_b) s_b``, and their gradient,
``+-1`` in the translation columns and ``-+`` the turned arm's other component in the rotation column; the pin's
kind gives them batched over pins (:meth:`~physics.mechanism.joints.revolute.RevoluteKind.rows_at_pose`), and
this module lays them into ``Phi`` and ``Phi_q``.

The numbers are the generic rows' bit for bit (``tests/physics/test_pin_rows.py`` holds them to it): the same
cosines and sines of the same pose array (:class:`~physics.mechanism.constraints._Frame`), the same products and
sums in the same order, and the Jacobian's entries are what the generic rows read off their velocity forms at
unit rates (exact: ``1``, the arm's components, zeros of either sign summed onto ``+0.0``).
"""

from __future__ import annotations

import numpy as np

from .constraints import Constraints, _Frame
from .description import GROUND, Mechanism
from .joints import kind_of
from .joints.revolute import KIND as PIN

_rows_at_pose = PIN.rows_at_pose  # looked up once: rows_at is a run's assembly's inner step


class PinRows:
    """Every row of a mechanism of pins as arrays over its pins' ends (in the description's order, as
    :class:`Constraints` numbers their rows: each pin's x gap, then its y gap): ``ends`` the bodies each pin
    joins, every pin's ``a`` then every pin's ``b`` (the ground as body ``B``), ``arm`` their points from the
    centres of mass by component, and where each Jacobian entry goes."""

    def __init__(self, mechanism: Mechanism, constraints: Constraints) -> None:
        spare = len(mechanism.bodies)

        def body(name: str) -> int:
            return spare if name == GROUND else constraints.body_index[name]

        reach, arms = [], []
        for joint in mechanism.joints:
            kind = kind_of(joint)
            reach.append(kind.structure_bodies(joint, body, mechanism))
            arms.append(kind.values(joint, mechanism)[:4])
        pins = len(reach)
        self.pins = pins
        self.size = 3 * spare
        self.ends = np.array([end[0] for end in reach] + [end[1] for end in reach], dtype=int)  # (2 P,)
        values = np.array(arms, dtype=float).reshape(-1, 4)
        self.arm = (np.concatenate([values[:, 0], values[:, 2]]), np.concatenate([values[:, 1], values[:, 3]]))
        self.sign = np.concatenate([np.ones(pins), -np.ones(pins)])  # a's point minus b's
        rows_x = np.tile(2 * np.arange(pins), 2)
        width = self.size + 3  # three spare columns take the ground's entries
        self.flat = np.concatenate([rows_x * width + 3 * self.ends, (rows_x + 1) * width + 3 * self.ends + 1,
                                    rows_x * width + 3 * self.ends + 2, (rows_x + 1) * width + 3 * self.ends + 2])
        self.width = width
        for array in (self.ends, *self.arm, self.sign, self.flat):
            array.setflags(write=False)

    def rows_at(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(Phi(q) (2 P,), Phi_q(q) (2 P, 3 B))`` at one pose ``q`` (3 B): :meth:`Constraints.residual`'s and
        :meth:`Constraints.jacobian`'s numbers. The pin's own batched rows
        (:meth:`~physics.mechanism.joints.revolute.RevoluteKind.rows_at_pose`: its gaps and gradient, as the
        generic rows compute them), laid out here by row and column."""
        frame = _Frame(q)
        ends, pins, (arm_x, arm_y) = self.ends, self.pins, self.arm
        (gap_x, gap_y), gradient = _rows_at_pose(frame.cos[ends], frame.sin[ends], frame.x[ends], frame.y[ends],
                                                 arm_x, arm_y, self.sign)
        residual = np.empty(2 * pins)
        residual[0::2] = gap_x
        residual[1::2] = gap_y
        entries = np.zeros(2 * pins * self.width)
        entries[self.flat] = np.concatenate(gradient)
        entries += 0.0  # a zero of either sign summed onto +0.0, as the generic rows' sum gives it
        return residual, entries.reshape(2 * pins, self.width)[:, : self.size]


def pin_rows(mechanism: Mechanism, constraints: Constraints) -> PinRows | None:
    """The mechanism's :class:`PinRows` when every constraint row is a pin's (no slider, gear or speed motor;
    torque motors add no row); None otherwise."""
    if not mechanism.joints or any(kind_of(joint).name != PIN.name for joint in mechanism.joints):
        return None
    if len(constraints.rows) != 2 * len(mechanism.joints):  # a speed motor's row
        return None
    return PinRows(mechanism, constraints)
