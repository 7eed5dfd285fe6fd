"""What the reduced model evaluates, on the compiled engine: the DAE's generated code, the parameter vector and
the joint coordinates as arrays.

Every evaluation of the reduced model in one joint coordinate (:mod:`physics.mechanism.reduced_partition`:
Newton on the positions, the velocity map, the accelerations, the joints' speed shares) is one call of
:func:`physics.kernels.reduced_evaluation.reduced_state` on the mechanism's generated DAE functions
(:func:`physics.mechanism.engine.compiled_system`, method ``"dae"``: ``Phi``, ``Phi_q`` and the time rate of its
speed motors from ``constraints``, the applied forces and ``gamma`` from ``assemble``), its numbers the
parameter vector of :mod:`physics.mechanism.parameters`. The numpy constraints of
:mod:`physics.mechanism.constraints` are not on that path; they stay the reference the tests hold it to.

The candidate coordinates are the joints that carry a tree coordinate (:meth:`~physics.mechanism.joints.
JointKind.freedom`: a pin's relative angle, a slider's travel; a gear carries none), in joint order, as
:class:`physics.mechanism.joint_coordinates.JointCoordinates` names them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import LinkageError
from ..kernels import reduced_evaluation as kernel
from .assembly import sketch_size
from .description import GROUND, Mechanism
from .engine import compiled_system
from .joints import Rotation, Translation, kind_of
from .numeric_dae import MechanismDAE
from .parameters import parameter_vector


# eq=False, repr=False: its arrays compare elementwise and print whole; generating __eq__ and __repr__ cost
# every process about 0.5 ms a class (benchmarks/small_cuts.py)
@dataclass(frozen=True, eq=False, repr=False)
class JointCoordinateArrays:
    """The joint coordinates as :mod:`physics.kernels.reduced_evaluation` reads them: ``names`` (joint order), ``kinds``
    (ANGLE or TRAVEL), ``ends`` (J, 2) the bodies by index (-1 the ground), ``geometry`` (J, 7) a travel's arms,
    guide direction and drawn travel, ``speed_scale`` what turns each one's rate into a speed (the sketch size
    for an angle, 1 for a travel)."""

    names: tuple[str, ...]
    kinds: np.ndarray
    ends: np.ndarray
    geometry: np.ndarray
    speed_scale: np.ndarray


def joint_coordinate_arrays(mechanism: Mechanism) -> JointCoordinateArrays:
    """Every joint's coordinate, read off its kind's :meth:`~physics.mechanism.joints.JointKind.freedom`."""
    index = {body.name: k for k, body in enumerate(mechanism.bodies)}
    centre = {body.name: np.array(body.centre, dtype=float) for body in mechanism.bodies}
    length = sketch_size(mechanism)
    names, kinds, ends, geometry, scale = [], [], [], [], []
    for joint in mechanism.joints:
        kind = kind_of(joint)
        bodies = kind.bodies(joint)
        if bodies is None:
            continue  # a coupler (a gear) joins no two bodies and offers no coordinate
        freedom = kind.freedom(kind.values(joint, mechanism))
        if freedom is None:
            continue
        a, b = bodies
        names.append(joint.name)
        ends.append((-1 if a == GROUND else index[a], -1 if b == GROUND else index[b]))
        if isinstance(freedom, Rotation):
            kinds.append(kernel.ANGLE)
            geometry.append(np.zeros(7))
            scale.append(length)
            continue
        assert isinstance(freedom, Translation)
        arm_a, arm_b = np.asarray(freedom.arm_a, dtype=float), np.asarray(freedom.arm_b, dtype=float)
        u = np.asarray(freedom.direction, dtype=float)
        sliding = arm_a + (centre[a] if a != GROUND else 0.0)  # the two points where the sketch draws them
        through = arm_b + (centre[b] if b != GROUND else 0.0)
        kinds.append(kernel.TRAVEL)
        geometry.append(np.array([*arm_a, *arm_b, *u, float(u @ (sliding - through))]))
        scale.append(1.0)
    return JointCoordinateArrays(
        names=tuple(names), kinds=np.array(kinds, dtype=np.int64), ends=np.array(ends, dtype=np.int64).reshape(-1, 2),
        geometry=np.array(geometry, dtype=float).reshape(-1, 7), speed_scale=np.array(scale, dtype=float))


# eq=False, repr=False: its arrays compare elementwise and print whole; generating __eq__ and __repr__ cost
# every process about 0.5 ms a class (benchmarks/small_cuts.py)
@dataclass(frozen=True, eq=False, repr=False)
class ReducedEngine:
    """One mechanism's compiled reduced model: its generated DAE system (``compiled``, ``assemble`` its address,
    ``layout``), the parameter vector ``params`` (its time slot written at every evaluation), the mass diagonal,
    ``nu`` (``Phi_q qdot = nu``: the speed motors' rates) and the joint coordinates."""

    compiled: object
    assemble: int
    layout: np.ndarray
    params: np.ndarray
    mass: np.ndarray
    nu: np.ndarray
    coordinates: JointCoordinateArrays

    def constraint_states(self, t: np.ndarray, q: np.ndarray, qdot: np.ndarray):
        """``Phi_q`` (K, r, 3 B), ``Phi`` and its rate (K, r) at the states ``(q, qdot)`` (K, 3 B), times ``t``."""
        return self.compiled.constraint_states(t, q, qdot, self.params)  # type: ignore[attr-defined]

    def applied(self, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
        """``Q`` (K, 3 B) at the states: the DAE's balance rows of ``b`` (gravity, torque motors, dampers)."""
        _, b = self.compiled.matrices(q, qdot, self.params)  # type: ignore[attr-defined]
        return b[:, : q.shape[1]]


def reduced_engine(dae: MechanismDAE) -> ReducedEngine:
    """The compiled reduced model of ``dae``'s mechanism (its generated DAE code loaded, or derived once per
    structure and cached)."""
    mechanism = dae.mechanism
    compiled = compiled_system(mechanism, "dae")
    size = dae.constraints.size
    if compiled.constraint_count + 1 != size:
        raise LinkageError(f"{mechanism.name}: {compiled.constraint_count} constraint rows for {size} coordinates; "
                           "the reduced model needs exactly one fewer (mobility 1, no redundant row)")
    params = np.ascontiguousarray(parameter_vector(mechanism, t=0.0), dtype=float).copy()
    sketch = dae.constraints.sketch_pose()
    _, _, rate = compiled.constraint_states(np.zeros(1), sketch, np.zeros(size), params)
    return ReducedEngine(compiled=compiled, assemble=compiled.assemble_function, layout=compiled.layout,
                         params=params, mass=np.ascontiguousarray(dae.mass_diagonal, dtype=float),
                         nu=np.ascontiguousarray(-rate[0]), coordinates=joint_coordinate_arrays(mechanism))
