"""What every run of one mechanism needs before its first step, built once per mechanism's *content*.

Every run of a mechanism needs the same pieces of the same description: the constraint equations grouped by joint
kind (:class:`~physics.mechanism.constraints.Constraints`), the mass diagonal and gravity
(:class:`~physics.mechanism.numeric_dae.MechanismDAE`), the spanning tree, the parameter vector, the projection's
weights, the names of the coordinates and reaction rows, the named points. None of them depends on anything but
the mechanism's numbers and names, so :func:`prepared` keeps them, keyed on the mechanism's full content (its
JSON, every field: a mechanism edited in the app is another object with other numbers, and so another key; two
equal descriptions share one entry). Never keyed on ``id()``: a pydantic model's lists and dicts can be changed
in place, and a freed object's id is reused. For the same reason every piece is built from a private deep copy
of the description (what a piece reads later, such as the joint coordinates built on first use, cannot see a
change made in place to the caller's object afterwards).

The arrays kept here are read-only, so a caller that wrote into one would fail loudly instead of changing every
later run. Only successes are kept: a mechanism that is refused (a body without mass, a body the ground cannot
reach) is refused again on every call, with the same message.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Hashable
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from ..errors import LinkageError
from .constraints import Constraints
from .description import Mechanism
from .numeric_dae import MechanismDAE
from .parameters import parameter_vector, structure_key
from .run_table import BodyPoints, body_points, coordinate_names
from .topology import Topology, open_tree_of_pins

if TYPE_CHECKING:
    from .joint_coordinates import JointCoordinates
    from .pin_rows import PinRows
    from .tree_reactions import LoopReactions, TreeReactions

# Mechanisms kept: the app's few open ones and a study's sweep over one structure's numbers fit many times over;
# the least recently used goes first.
PREPARED_ENTRIES = 64
ASSEMBLIES_KEPT = 8  # starts remembered per mechanism: the sketch, and a few others a study returns to


# eq=False, repr=False: its arrays compare elementwise and print whole; generating __eq__ and __repr__ cost
# every process about 0.5 ms a class (benchmarks/small_cuts.py)
@dataclass(frozen=True, eq=False, repr=False)
class Prepared:
    """One mechanism's run-independent pieces (every array read-only).

    ``dae``: its mass diagonal, gravity and constraint equations; ``velocity_rhs``: ``nu`` of ``Phi_q qdot =
    nu`` (constant: the speed motors' rates); ``sketch_size``: :func:`~physics.mechanism.assembly.sketch_size`;
    ``assembly_weights`` and ``projection_weights`` the steps' weights of position analysis (rotations in
    lengths) and of the DAE's projection (positions, then velocities nearest in kinetic energy);
    ``parameters``: :func:`~physics.mechanism.parameters.parameter_vector` at ``t = 0``; ``structure_key``
    names its generated code. A mechanism with a massless body has its equations (``constraints``: assembly
    needs no mass) but no equations of motion: ``dae_or_none`` is None and :attr:`dae` refuses it. The time is
    the parameter vector's last entry (:func:`~physics.mechanism.parameters.parameter_names`)."""

    constraints: Constraints
    dae_or_none: MechanismDAE | None
    refusal: str  # why there is no DAE ("" when there is one)
    topology: Topology | None  # None: the ground does not reach every body (assembly refuses it, with the reason)
    velocity_rhs: np.ndarray
    sketch_size: float
    assembly_weights: np.ndarray
    projection_weights: np.ndarray | None
    parameters: np.ndarray
    structure_key: str
    coordinate_names: tuple[str, ...]
    row_names: tuple[str, ...]
    body_points: BodyPoints
    # the last few assemblies, by start (:func:`~physics.mechanism.assembly.assembled_with_jacobian`)
    assemblies: OrderedDict = field(default_factory=OrderedDict, compare=False, repr=False)

    @property
    def dae(self) -> MechanismDAE:
        """The equations of motion; LinkageError, as :class:`MechanismDAE` gives it, for a massless body."""
        if self.dae_or_none is None:
            raise LinkageError(self.refusal)
        return self.dae_or_none

    @cached_property
    def joint_coordinates(self) -> JointCoordinates:
        """Every joint's coordinate as a function of the maximal ones (the tree formulations' state), built on
        first use."""
        from .joint_coordinates import JointCoordinates  # noqa: PLC0415  (it reads assembly, which reads here)

        return JointCoordinates(self.constraints.mechanism, self.constraints)

    @cached_property
    def tree_reactions(self) -> TreeReactions | LoopReactions | None:
        """The closed form of a tree formulation's reactions (:mod:`physics.mechanism.tree_reactions`) when every
        joint is a pin: of the spanning tree (:class:`TreeReactions`) or closing loops (:class:`LoopReactions`);
        None otherwise (the reactions keep the QR). Built on first use."""
        from .tree_reactions import plan, plan_loops  # noqa: PLC0415

        open_tree = plan(self.constraints, self.topology)
        return open_tree if open_tree is not None else plan_loops(self.constraints, self.topology)

    @cached_property
    def pin_rows(self) -> PinRows | None:
        """``Phi`` and ``Phi_q`` at one pose written out for pins (:mod:`physics.mechanism.pin_rows`: the generic
        rows' numbers) when every row is a pin's; None otherwise. Built on first use."""
        from .pin_rows import pin_rows  # noqa: PLC0415

        return pin_rows(self.constraints.mechanism, self.constraints)

    @property
    def full_rank_by_structure(self) -> bool:
        """True when ``Phi_q`` has full row rank at every pose by the structure alone: an open tree of pins
        (:attr:`tree_reactions` a :class:`~physics.mechanism.tree_reactions.TreeReactions`; loops have dead
        centres). Ordered by bodies from the ground, a body's rows (its pin to its
        parent, and the pin's speed motor) hold ``+-I`` in its translation columns and ``+-1`` in its rotation
        column, nothing in its descendants' columns: block triangular, every diagonal block of full row rank.
        Assembly then needs no rank (an SVD) to know the mobility. Asked of the structure
        (:func:`~physics.mechanism.topology.open_tree_of_pins`), not of the closed form: a DAE run never builds
        or imports it."""
        return open_tree_of_pins(self.constraints.mechanism, self.topology)

    def remembered(self, key: Hashable):
        """What :meth:`remember` kept under ``key``, or None."""
        with _lock:
            found = self.assemblies.get(key)
            if found is not None:
                self.assemblies.move_to_end(key)
            return found

    def remember(self, key: Hashable, value) -> None:
        """Keep ``value`` (its arrays read-only) under ``key``, forgetting the oldest beyond
        :data:`ASSEMBLIES_KEPT`."""
        with _lock:
            self.assemblies[key] = value
            self.assemblies.move_to_end(key)
            while len(self.assemblies) > ASSEMBLIES_KEPT:
                self.assemblies.popitem(last=False)

    def parameters_at(self, t: float) -> np.ndarray:
        """A fresh parameter vector with its time slot set to ``t`` (:func:`parameter_vector`'s ``t``)."""
        params = self.parameters.copy()
        params[-1] = t
        return params


_entries: OrderedDict[str, Prepared] = OrderedDict()
_lock = threading.Lock()


def content_key(mechanism: Mechanism) -> str:
    """Everything the description holds, as text: equal for equal mechanisms, different for any other number or
    name (floats are written to round trip exactly)."""
    return mechanism.model_dump_json()


def prepared(mechanism: Mechanism) -> Prepared:
    """The run-independent pieces of ``mechanism``, from memory or built now (see the module's text)."""
    key = content_key(mechanism)
    with _lock:
        found = _entries.get(key)
        if found is not None:
            _entries.move_to_end(key)
            return found
    built = _build(mechanism)
    with _lock:
        _entries[key] = built
        _entries.move_to_end(key)
        while len(_entries) > PREPARED_ENTRIES:
            _entries.popitem(last=False)
    return built


def clear_prepared() -> None:
    """Forget every prepared mechanism (tests; nothing else needs it: a changed mechanism has another key)."""
    with _lock:
        _entries.clear()


def _build(mechanism: Mechanism) -> Prepared:
    from .assembly import sketch_size  # noqa: PLC0415  (assembly reads this module)
    from .topology import analyse  # noqa: PLC0415

    mechanism = mechanism.model_copy(deep=True)  # the pieces' own: see the module's text
    constraints = Constraints(mechanism)
    dae: MechanismDAE | None = None
    refusal = ""
    try:
        dae = MechanismDAE(mechanism, constraints)
    except LinkageError as error:  # a body without mass: no equations of motion
        refusal = str(error)
    try:
        topology: Topology | None = analyse(mechanism)
    except ValueError:
        topology = None
    size = sketch_size(mechanism)
    bodies = len(mechanism.bodies)
    projection = (None if dae is None else
                  np.concatenate([np.tile([1.0, 1.0, 1.0 / size**2], bodies), 1.0 / dae.mass_diagonal]))
    pieces = Prepared(
        constraints=constraints,
        dae_or_none=dae,
        refusal=refusal,
        topology=topology,
        velocity_rhs=constraints.velocity_rhs(),
        sketch_size=size,
        assembly_weights=np.tile([1.0, 1.0, 1.0 / size], bodies),
        projection_weights=projection,
        parameters=parameter_vector(mechanism, t=0.0),
        structure_key=structure_key(mechanism),
        coordinate_names=coordinate_names(mechanism),
        row_names=tuple(f"{row.joint}: {row.meaning}" for row in constraints.rows),
        body_points=body_points(mechanism),
    )
    arrays = [constraints.centres, constraints.damping, constraints.torque, pieces.velocity_rhs,
              pieces.assembly_weights, pieces.parameters]
    if dae is not None and projection is not None:
        arrays += [dae.mass_diagonal, dae.gravity, projection]
    for array in arrays:
        array.setflags(write=False)
    return pieces
