"""One choice of independent joint coordinate ``s`` of a one-degree-of-freedom mechanism: its positions, its
velocity transformation and its one equation of motion.

Bordering the constraint Jacobian with the coordinate's gradient gives a square matrix ``A = [Phi_q; c_q]``
(``3 B x 3 B`` when the mobility is 1 and no constraint is redundant, which assembly guarantees):

* positions: ``Phi(q, t) = 0, c(q) = s`` solved by Newton's method from the previous pose, predicted to first
  order, so the branch the mechanism is on is kept (a chord iteration on the previous pose's ``A^{-1}``; then
  ``A`` is inverted afresh at the converged pose);
* velocities: ``A qdot = [nu; sdot]``, i.e. ``qdot = B sdot + D`` with ``B = A^{-1} e`` (the velocity
  transformation) and ``D = A^{-1} [nu; 0]`` (non-zero only with a speed motor);
* accelerations: ``qddot = B sddot + a0`` with ``a0 = A^{-1} [gamma; gamma_c]`` (``a0`` is ``Bdot sdot`` for a
  mechanism without motors);
* ``M qddot = Q + Phi_q^T lambda`` projected on ``B`` (``Phi_q B = 0`` removes every reaction):
  ``(B^T M B) sddot = B^T (Q - M a0)``.

``A`` is singular where ``c`` stands still while the mechanism moves (a dead centre of that coordinate): the
reduced model switches coordinate long before (:mod:`physics.mechanism.reduced`).

Each evaluation is one compiled call (:func:`physics.kernels.reduced_evaluation.reduced_state`) on the mechanism's
generated DAE code (:mod:`physics.mechanism.reduced_engine`): ``Phi``, ``Phi_q``, ``gamma`` and ``Q`` are never
evaluated in Python on this path, which is what makes the model about as fast as the four-bar's own
(BENCHMARKS.md, "The reduced model on the compiled engine").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import LinkageError
from ..kernels import reduced_evaluation as kernel
from ..kernels.first_compile import call_announced
from .joint_coordinates import JointCoordinates
from .numeric_dae import MechanismDAE
from .reduced_engine import ReducedEngine, reduced_engine

NEWTON_STEPS = 30
# Newton stops when a step moves no coordinate by more than this times the mechanism's size (rotations counted
# as lengths), or when steps below NEWTON_NOISE times the size stop shrinking (rounding noise). The steps use
# the reference pose's inverse (a chord iteration) while each is below CHORD_RATE times the one before, and a
# fresh inverse otherwise, so what is left after the last step is below CHORD_RATE times it: rounding level.
NEWTON_STEP_TOLERANCE = 1e-14
NEWTON_NOISE = 1e-12
CHORD_RATE = 0.1
# A pose whose residual stays above this (times the size) after NEWTON_STEPS has lost the branch.
NEWTON_FAILURE = 1e-9
# States kept for a repeated evaluation: scipy's DOP853 asks for the state at a step's end, then for three more
# inside the step (its dense output), then for the step's end again (the switching event).
REMEMBERED = 8


# eq=False, repr=False: its arrays compare elementwise and print whole; generating __eq__ and __repr__ cost
# every process about 0.5 ms a class (benchmarks/small_cuts.py)
@dataclass(frozen=True, eq=False, repr=False)
class ReducedState:
    """Everything at one ``(t, s, sdot)``: the pose ``q``, velocities ``qdot``, accelerations ``qddot``, the
    velocity transformation ``B`` (``dq/ds``), the generalised mass ``B^T M B``, ``sddot`` and every joint's
    speed share along ``B`` (``shares``, the order of the joint coordinates' names)."""

    t: float
    s: float
    sdot: float
    q: np.ndarray
    qdot: np.ndarray
    qddot: np.ndarray
    velocity_map: np.ndarray
    generalised_mass: float
    sddot: float
    shares: np.ndarray


class Partition:
    """The reduced model in the joint coordinate number ``which`` of ``coordinates``, started at pose ``q``.

    Every evaluation is one compiled call (:func:`physics.kernels.reduced_evaluation.reduced_state`) on ``engine``, the
    mechanism's generated DAE code (:mod:`physics.mechanism.reduced_engine`; made from ``dae`` when not given:
    a run passes its one engine to every partition)."""

    def __init__(self, dae: MechanismDAE, coordinates: JointCoordinates, which: int, q: np.ndarray, t: float,
                 length: float, engine: ReducedEngine | None = None) -> None:
        self.dae = dae
        self.coordinates = coordinates
        self.engine = engine if engine is not None else reduced_engine(dae)
        if self.engine.coordinates.names != coordinates.names:
            raise ValueError(f"joint coordinates {self.engine.coordinates.names} and {coordinates.names} differ")
        self.which = which
        self.name = coordinates.names[which]
        self.length = length
        self.weights = np.tile([1.0, 1.0, length], len(dae.mechanism.bodies))  # rotations counted as lengths
        self._numbers = np.zeros(kernel.NUMBERS)
        self._numbers[kernel.NUMBER_LENGTH] = length
        self._numbers[kernel.NUMBER_STEP_TOLERANCE] = NEWTON_STEP_TOLERANCE
        self._numbers[kernel.NUMBER_NOISE] = NEWTON_NOISE
        self._numbers[kernel.NUMBER_CHORD_RATE] = CHORD_RATE
        self._numbers[kernel.NUMBER_FAILURE] = NEWTON_FAILURE
        self._numbers[kernel.NUMBER_STEPS] = NEWTON_STEPS
        size = dae.constraints.size
        self._inverse = np.empty((size, size))
        self._remembered: dict[tuple[float, float, float], ReducedState] = {}
        self.evaluations = 0
        self.reset(q, t)

    def reset(self, q: np.ndarray, t: float) -> None:
        """Make ``q`` (at time ``t``, on the branch wanted) the pose the next one is predicted from (to first
        order in ``s``: its rates are not known here)."""
        engine, arrays = self.engine, self.engine.coordinates
        q = np.array(q, dtype=float)
        self._check(kernel.bordered_inverse(engine.layout, engine.params, arrays.kinds, arrays.ends, arrays.geometry,
                                            self.which, q, float(t), self._inverse), t, math.nan)
        s, _ = self.coordinate_of(q, np.zeros_like(q))
        self._reference = np.vstack([q, np.zeros_like(q), np.zeros_like(q), self._inverse[:, -1]])
        self._reference_numbers = np.array([float(t), s, 0.0, 0.0])
        self._remembered.clear()

    def _check(self, status: int, t: float, residual: float) -> None:
        """The sentence (or numpy's LinAlgError, as ``inv`` raises it) of a failed compiled evaluation."""
        if status == kernel.OK:
            return
        name = self.dae.mechanism.name
        if status == kernel.NOT_CONVERGED:
            raise LinkageError(f"{name}: position analysis in joint {self.name!r} at t = {t:.6g} s did not "
                               f"converge (residual {residual:.3g}); a dead centre was passed between two steps")
        if status == kernel.NOT_FINITE:
            raise LinkageError(f"{name}: non-finite pose while solving for joint {self.name!r}")
        raise np.linalg.LinAlgError("Singular matrix")

    def state(self, t: float, s: float, sdot: float) -> ReducedState:
        """Pose, velocities and accelerations at ``(t, s, sdot)`` (the pose on the branch of the reference: see
        the module's docstring); becomes the reference of the next pose."""
        key = (t, s, sdot)
        remembered = self._remembered.get(key)
        if remembered is not None:
            return remembered
        self.evaluations += 1
        engine, arrays, numbers = self.engine, self.engine.coordinates, self._numbers
        numbers[kernel.NUMBER_T] = t
        numbers[kernel.NUMBER_S] = s
        numbers[kernel.NUMBER_SDOT] = sdot
        rows = np.empty_like(self._reference)
        scalars = np.empty(kernel.SCALARS)
        shares = np.empty(arrays.kinds.shape[0])
        arguments = (engine.assemble, engine.layout, engine.params, engine.mass, engine.nu, arrays.kinds, arrays.ends,
                     arrays.geometry, arrays.speed_scale, self.which, self.weights, numbers, self._reference,
                     self._reference_numbers, self._inverse, rows, scalars, shares)
        if self.evaluations == 1:  # one line before an installation's first compilation of the kernel
            status = call_announced(kernel.reduced_state, arguments, "reduced model's")
        else:
            status = kernel.reduced_state(*arguments)
        if status != kernel.OK:
            self._check(status, t, float(scalars[kernel.SCALAR_RESIDUAL]))
        sddot = float(scalars[kernel.SCALAR_SDDOT])
        state = ReducedState(t=float(t), s=float(s), sdot=float(sdot), q=rows[kernel.ROW_Q], qdot=rows[kernel.ROW_QDOT],
                             qddot=rows[kernel.ROW_QDDOT], velocity_map=rows[kernel.ROW_MAP],
                             generalised_mass=float(scalars[kernel.SCALAR_MASS]), sddot=sddot, shares=shares)
        self._reference = rows
        self._reference_numbers = np.array([state.t, state.s, state.sdot, sddot])
        if len(self._remembered) >= REMEMBERED:
            del self._remembered[next(iter(self._remembered))]
        self._remembered[key] = state
        return state

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """``d/dt (s, sdot)``: the one ODE scipy integrates."""
        state = self.state(t, float(y[0]), float(y[1]))
        return np.array([state.sdot, state.sddot])

    def share(self, state: ReducedState) -> float:
        """This coordinate's speed share along the motion (1: the fastest joint, 0: a dead centre)."""
        return float(state.shares[self.which])

    def coordinate_of(self, q: np.ndarray, qdot: np.ndarray) -> tuple[float, float]:
        """``(s, sdot)`` of a state given in maximal coordinates: read off exactly, nothing integrated."""
        arrays = self.engine.coordinates
        out = np.empty(2)
        kernel.coordinate_state(arrays.kinds, arrays.ends, arrays.geometry, self.which,
                                np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(qdot, dtype=float), out)
        return float(out[0]), float(out[1])
