"""Trajectory: what every run returns, a chain's or a general mechanism's, sampled at the requested times, and
its table form for CSV/JSON.

One class for both kinds of run (issue 24, "one pipeline"): the generic fields (time, energies, condition,
status, step counts, traced point) mean the same for both; a chain fills its angles, joints and ``(T, n, 2)``
reactions, a mechanism its maximal coordinates ``q`` and its reaction rows. The fields a run does not have are
empty ``(T, 0)`` arrays, so slicing along axis 0 (a long run's segments, physics/long_run.py) treats every
field alike.

Every point the model names has its path over the run, by name (:attr:`Trajectory.point_names`,
:meth:`Trajectory.point`, :attr:`Trajectory.points`): a chain's joints (already sampled, ``joints``) and its
traced point, a mechanism's body and ground points, computed on request from ``q`` by the mechanism's own
kinematics (:class:`PointPaths`), never while integrating.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from ..errors import LinkageError
from ..status import Status

# A field a run leaves out: the trailing shape it gets, with T rows, so that every per-sample array has T rows
_EMPTY_WIDTH = {
    "theta": (0,), "omega": (0,), "joints": (0, 2), "tip_xy": (0,), "reactions": (0, 2), "tip_reaction": (0,),
    "constraint_xy": (0,), "constraint_velocity": (0,), "joint_reactions": (0, 2), "q": (0,), "qdot": (0,),
    "reaction_rows": (0,),
}


def _absent() -> np.ndarray:
    return np.zeros((0, 0))


class OnRequest:
    """A per-sample field given as the computation that makes it, run when the field is first read and kept.

    A mechanism's run leaves two of its fields to whoever reads them (:mod:`physics.mechanism.engine`): the
    condition of every sample's constraint Jacobian (a batched SVD) and a tree formulation's reaction rows (a
    batched least-squares solve), together more than half of a warm short run's time; the integration and the
    CSV/JSON columns do not need them until a reader asks. A chain's compiled run leaves its reactions, joint
    reactions, tip reaction and condition likewise (every sample's solve of its system, a sixth of seed case C's
    run: :mod:`physics.simulate.mechanism_route`): a reader of the motion, the tip's path or the energy reads
    none of them. ``compute`` returns exactly the array the run would
    have stored (the same function of the same inputs), so reading the field gives the same bits as before."""

    __slots__ = ("compute",)

    def __init__(self, compute: Callable[[], np.ndarray]) -> None:
        self.compute = compute


class _ComputedWhenRead:
    """The descriptor of a :class:`Trajectory` field that may be given as :class:`OnRequest`: reading the field
    runs the computation once and keeps its array (so ``run.condition`` is always an ndarray for a reader).
    ``empty``: the shape of the field left out (a fresh array each time, as a default factory gives it)."""

    def __init__(self, empty: tuple[int, ...]) -> None:
        self.empty = empty

    def __set_name__(self, owner: type, name: str) -> None:
        self.slot = f"_{name}_value"

    def __get__(self, instance: Any, owner: type | None = None) -> np.ndarray:
        if instance is None:  # the dataclass's default: an empty array, made fresh in __set__
            return None  # type: ignore[return-value]
        value = instance.__dict__[self.slot]
        if isinstance(value, OnRequest):
            value = instance.__dict__[self.slot] = value.compute()
        return value

    def __set__(self, instance: Any, value: np.ndarray | OnRequest | None) -> None:
        instance.__dict__[self.slot] = np.zeros(self.empty) if value is None else value


class PointPaths(Protocol):
    """A mechanism's named points and where they are at any poses (:class:`physics.mechanism.run_table.BodyPoints`):
    the run keeps this small description, not the paths, so a long run's memory is its ``q`` alone and the
    integrator never computes a point nobody asked for."""

    @property
    def names(self) -> tuple[str, ...]: ...

    def path(self, q: np.ndarray, index: int) -> np.ndarray:
        """Point ``names[index]`` at every pose of ``q (T, 3 B)`` -> ``(T, 2)``."""
        ...


def chain_joint_names(n: int) -> tuple[str, ...]:
    """A chain's joints 0..n by name: the fixed origin ``O``, ``J1 .. J{n-1}`` between bars, the tip ``H`` (the
    free-body diagrams' and the chain-as-mechanism's pin names; the seed report's E and F are J1 and J2)."""
    return ("O", *(f"J{k}" for k in range(1, n)), "H")


# eq=False: its arrays compare elementwise; repr=False: its own __repr__ below (generating the dataclass's
# __eq__ and __repr__ cost every process about 0.5 ms a class, benchmarks/small_cuts.py)
@dataclass(eq=False, repr=False)
class Trajectory:
    """Samples along axis 0 (``T`` of them, up to where the run stopped if it did: ``status``, ``message``).

    Every run: ``t (T,)``, ``trace_xy (T, 2)`` (the traced point), ``kinetic, potential, energy (T,)``,
    ``condition (T,)`` (how near each pose is to a singular one; empty when not measured), ``n_steps`` (accepted
    integration steps), ``n_rhs`` (right-hand sides evaluated).

    A chain (``links`` > 0): ``theta/omega (T, n)``, ``joints (T, n+1, 2)``, ``tip_xy (T, 2)``, ``reactions
    (T, n, 2)`` for dae else ``(T, 0, 2)``, ``tip_reaction (T, 2)`` for pinned chains else ``(T, 0)``,
    ``constraint_xy / constraint_velocity (T, 2)`` for pinned chains else ``(T, 0)``.

    A general mechanism (:mod:`physics.mechanism`): ``q, qdot (T, 3 B)`` (x, y, phi of every body's centre of
    mass, named by ``coordinate_names``), ``reaction_rows (T, rows)`` (every constraint row's multiplier, named
    by ``row_names``), ``residual (T,)`` (the largest constraint residual), ``coordinates`` (the state the run
    integrated in: ``maximal``, ``tree`` or ``reduced``), ``stabilization`` and ``integrated``
    (False: every sample by position analysis, the motors fix every body), ``body_points`` (its named points).

    Named points, both kinds: :attr:`point_names`, :meth:`point` (``(T, 2)`` by name), :attr:`points` (all of
    them as a read-only mapping, each path computed when it is read)."""

    method: str
    integrator: str
    t: np.ndarray
    trace_xy: np.ndarray
    kinetic: np.ndarray
    potential: np.ndarray
    energy: np.ndarray
    # (a mechanism's run gives it as OnRequest: computed when first read)
    condition: _ComputedWhenRead = _ComputedWhenRead(empty=(0,))
    status: int = Status.OK  # a Status value (0 ok, < 0 failed midway)
    message: str = "ok"
    n_steps: int = 0
    n_rhs: int = 0
    # a chain's
    theta: np.ndarray = field(default_factory=_absent)
    omega: np.ndarray = field(default_factory=_absent)
    joints: np.ndarray = field(default_factory=_absent)
    tip_xy: np.ndarray = field(default_factory=_absent)
    # (a chain's run on the compiled route gives these three as OnRequest: every sample's solve when first read)
    reactions: _ComputedWhenRead = _ComputedWhenRead(empty=(0, 0))
    tip_reaction: _ComputedWhenRead = _ComputedWhenRead(empty=(0, 0))
    constraint_xy: np.ndarray = field(default_factory=_absent)
    constraint_velocity: np.ndarray = field(default_factory=_absent)
    stats: dict = field(default_factory=dict)
    # (T, n, 2) for every method: from the accelerations by Newton's law per bar (physics/chain_reactions.py),
    # equal to the DAE's own ``reactions`` where it has them; not part of the CSV/JSON columns.
    joint_reactions: _ComputedWhenRead = _ComputedWhenRead(empty=(0, 0))
    trace_is_explicit: bool = False  # open chains list trace_x/y only when a point other than the tip was asked
    # a general mechanism's
    q: np.ndarray = field(default_factory=_absent)
    qdot: np.ndarray = field(default_factory=_absent)
    coordinate_names: tuple[str, ...] = ()
    reaction_rows: _ComputedWhenRead = _ComputedWhenRead(empty=(0, 0))  # a tree formulation's: OnRequest
    row_names: tuple[str, ...] = ()
    residual: np.ndarray = field(default_factory=lambda: np.zeros(0))
    stabilization: str = ""  # how the closures were held ("projection", "baumgarte", "none"); "" for a chain
    # the state a mechanism's run integrated or solved in, which ``method`` alone does not say (the DAE runs in
    # either): "maximal" (every body's x, y, phi), "tree" (the spanning tree's joint coordinates: Lagrange,
    # Newton-Euler, the DAE with coordinates="tree"), "reduced" (one joint coordinate); "" for a chain
    coordinates: str = ""
    integrated: bool = True  # False: every sample by position analysis (the motors fix every body)
    body_points: PointPaths | None = None  # a mechanism's named points; None: none named (a chain names its joints)

    def __post_init__(self) -> None:
        """The fields a run left out become ``(T, 0)`` arrays (``(T, 0, 2)`` for per-joint vectors)."""
        count = self.t.shape[0]
        stored = self.__dict__
        for name, key, width in _EMPTY_FIELDS:  # read from __dict__: one look-up a field (this runs every run)
            value = stored[key]
            if isinstance(value, OnRequest):
                continue  # its computation gives its T rows when it is read
            if value.size == 0 and value.shape[:1] != (count,):
                setattr(self, name, np.zeros((count, *width)))

    @classmethod
    def of_chain(cls, method: str, integrator: str, t: np.ndarray, trace_xy: np.ndarray, kinetic: np.ndarray,
                 potential: np.ndarray, energy: np.ndarray, condition: np.ndarray | OnRequest, theta: np.ndarray,
                 omega: np.ndarray, joints: np.ndarray, tip_xy: np.ndarray, reactions: np.ndarray | OnRequest,
                 tip_reaction: np.ndarray | OnRequest, constraint_xy: np.ndarray, constraint_velocity: np.ndarray,
                 joint_reactions: np.ndarray | OnRequest, trace_is_explicit: bool) -> Trajectory:
        """A chain's run, the same object as ``Trajectory(...)`` with these fields (every one given with its
        ``T`` rows) gives, made without the dataclass's ``__init__``: its defaults, its default factories and
        ``__post_init__``'s check of twelve fields are a tenth of a short compiled run's time around its
        native calls (the entries in the order ``__init__`` sets them; ``tests/physics/test_trajectory_of_chain.py``
        compares the two)."""
        count = t.shape[0]
        run = cls.__new__(cls)
        run.__dict__.update({
            "method": method, "integrator": integrator, "t": t, "trace_xy": trace_xy, "kinetic": kinetic,
            "potential": potential, "energy": energy, "_condition_value": condition, "status": Status.OK,
            "message": "ok", "n_steps": 0, "n_rhs": 0, "theta": theta, "omega": omega, "joints": joints,
            "tip_xy": tip_xy, "_reactions_value": reactions, "_tip_reaction_value": tip_reaction,
            "constraint_xy": constraint_xy, "constraint_velocity": constraint_velocity, "stats": {},
            "_joint_reactions_value": joint_reactions,
            "trace_is_explicit": trace_is_explicit, "q": np.zeros((count, 0)), "qdot": np.zeros((count, 0)),
            "coordinate_names": (), "_reaction_rows_value": np.zeros((count, 0)), "row_names": (),
            "residual": np.zeros(0), "stabilization": "", "coordinates": "", "integrated": True,
            "body_points": None,
        })
        return run

    def __getstate__(self) -> dict[str, Any]:
        """Pickled (a study's worker process, a copy) with every field computed: a computation is not data."""
        for name in _ON_REQUEST:
            getattr(self, name)
        return self.__dict__

    @property
    def success(self) -> bool:
        return self.status == Status.OK

    @property
    def is_mechanism(self) -> bool:
        """A general mechanism's run (coordinates ``q``, reaction rows), not a chain's (angles ``theta``)."""
        return self.theta.shape[1] == 0

    @property
    def n(self) -> int:
        """A chain's links (0 for a mechanism's run)."""
        return self.theta.shape[1]

    @property
    def bodies(self) -> int:
        """A mechanism's bodies (x, y, phi each in ``q``; 0 for a chain's run)."""
        return self.q.shape[1] // 3 if self.q.ndim == 2 else 0

    @property
    def point_names(self) -> tuple[str, ...]:
        """Every point the run can give the path of, in order. A chain's joints ``O, J1 .. J{n-1}, H`` (joint k at
        ``sum_{i<=k} L_i (sin theta_i, -cos theta_i)``, docs/physics.md), then ``trace`` when a point other than
        the tip was traced. A mechanism's body points ``BODY.POINT`` (its drawing's labels, in the description's
        order), then its ground points ``ground.NAME``; its traced point (``trace_xy``) is one of them."""
        if self.is_mechanism:
            return self.body_points.names if self.body_points is not None else ()
        names = chain_joint_names(self.n)
        return (*names, "trace") if self.trace_is_explicit else names

    def point(self, name: str) -> np.ndarray:
        """The path ``(T, 2)`` of the point called ``name`` (one of :attr:`point_names`); another name raises
        LinkageError naming the allowed ones. A chain's is a view of ``joints`` (or ``trace_xy``); a mechanism's
        is computed from ``q`` now, by its own kinematics."""
        names = self.point_names
        if not isinstance(name, str) or name not in names:
            allowed = ", ".join(names) if names else "none (this run names no points)"
            raise LinkageError(f"point = {name!r}: allowed names {allowed}")
        if self.is_mechanism:
            assert self.body_points is not None  # names is empty without it
            return self.body_points.path(self.q, names.index(name))
        if name == "trace":
            return self.trace_xy
        return self.joints[:, names.index(name)]

    @property
    def points(self) -> Mapping[str, np.ndarray]:
        """Every named point's path by name (``dict(run.points)`` computes them all; ``run.points["H"]`` one)."""
        return _NamedPoints(self)

    def __repr__(self) -> str:
        """One line for a notebook or a log (the dataclass's own repr printed every array: 48,777 characters
        for 201 samples); the arrays stay on the attributes and in :meth:`columns`."""
        try:
            status = Status(self.status).name.lower()
        except ValueError:
            status = str(self.status)
        extra = f", message={self.message!r}" if self.message and status != "ok" else ""
        if not self.is_mechanism:
            size = f"links={self.n}"
        elif self.integrated:
            size = (f"bodies={self.bodies}, coordinates={self.coordinates!r}, stabilization={self.stabilization!r}, "
                    f"n_steps={self.n_steps}")
        else:
            size = f"bodies={self.bodies}, coordinates={self.coordinates!r}"
        return (f"Trajectory(method={self.method!r}, integrator={self.integrator!r}, {size}, "
                f"samples={self.t.shape[0]}, t={time_span(self.t)}, status={status}{extra})")

    def energy_drift(self) -> float:
        """max |E(t) - E(0)| / max(|E(0)|, scale), scale = the largest of |T|, |V| seen (so E(0) = 0 is fine)."""
        if self.energy.size == 0:
            return 0.0
        scale = max(abs(self.energy[0]), np.max(np.abs(self.kinetic)), np.max(np.abs(self.potential)), 1e-300)
        return float(np.max(np.abs(self.energy - self.energy[0])) / scale)

    def columns(self) -> dict[str, np.ndarray]:
        """Named 1-D columns: the CSV header and the JSON keys (the command line's contract).

        A chain's (``simulate``, docs/cli.md): ``t, theta1..n, omega1..n, tip_x, tip_y, kinetic, potential,
        energy``, then ``R0x, R0y, ...`` for dae, then for a pinned chain ``RHx, RHy, constraint_x, constraint_y,
        constraint_vx, constraint_vy`` and ``trace_x, trace_y`` (the traced point; open chains add it only when a
        trace point was given). A mechanism's (``mechanism``, docs/mechanisms.md): ``t``, the traced point, the
        energies, the largest constraint residual and every reaction row as ``lambda[JOINT: row]``."""
        return self._mechanism_columns() if self.is_mechanism else self._chain_columns()

    def _mechanism_columns(self) -> dict[str, np.ndarray]:
        columns = {"t": self.t, "trace_x": self.trace_xy[:, 0], "trace_y": self.trace_xy[:, 1],
                   "kinetic": self.kinetic, "potential": self.potential, "energy": self.energy,
                   "constraint_residual": self.residual}
        for k, name in enumerate(self.row_names):
            columns[f"lambda[{name}]"] = self.reaction_rows[:, k]
        return columns

    def _chain_columns(self) -> dict[str, np.ndarray]:
        n = self.n
        cols = {"t": self.t}
        for i in range(n):
            cols[f"theta{i + 1}"] = self.theta[:, i]
        for i in range(n):
            cols[f"omega{i + 1}"] = self.omega[:, i]
        cols["tip_x"] = self.tip_xy[:, 0]
        cols["tip_y"] = self.tip_xy[:, 1]
        cols["kinetic"] = self.kinetic
        cols["potential"] = self.potential
        cols["energy"] = self.energy
        for k in range(self.reactions.shape[1]):
            cols[f"R{k}x"] = self.reactions[:, k, 0]
            cols[f"R{k}y"] = self.reactions[:, k, 1]
        if self.tip_reaction.shape[1] == 2:
            cols["RHx"] = self.tip_reaction[:, 0]
            cols["RHy"] = self.tip_reaction[:, 1]
        if self.constraint_xy.shape[1] == 2:
            cols["constraint_x"] = self.constraint_xy[:, 0]
            cols["constraint_y"] = self.constraint_xy[:, 1]
            cols["constraint_vx"] = self.constraint_velocity[:, 0]
            cols["constraint_vy"] = self.constraint_velocity[:, 1]
        if self.trace_is_explicit or self.constraint_xy.shape[1] == 2:
            cols["trace_x"] = self.trace_xy[:, 0]
            cols["trace_y"] = self.trace_xy[:, 1]
        return cols


# (field, where an instance's __dict__ holds its value: a _ComputedWhenRead field under its slot's name, the
# others under their own, and the trailing shape it gets when left out): Trajectory.__post_init__ reads these
_EMPTY_FIELDS = tuple(
    (name, descriptor.slot if isinstance(descriptor := Trajectory.__dict__.get(name), _ComputedWhenRead) else name,
     width)
    for name, width in _EMPTY_WIDTH.items()
)


# the fields a run may give as OnRequest
_ON_REQUEST = tuple(name for name, value in vars(Trajectory).items() if isinstance(value, _ComputedWhenRead))


class _NamedPoints(Mapping[str, np.ndarray]):
    """:attr:`Trajectory.points`: the names are the run's, each path is read through :meth:`Trajectory.point`
    when asked for (a mapping of computed arrays would hold every path of a long run in memory)."""

    def __init__(self, run: Trajectory) -> None:
        self._run = run

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in self._run.point_names:
            raise KeyError(name)
        return self._run.point(name)

    def __contains__(self, name: object) -> bool:
        return name in self._run.point_names  # without computing a path

    def __iter__(self) -> Iterator[str]:
        return iter(self._run.point_names)

    def __len__(self) -> int:
        return len(self._run.point_names)

    def __repr__(self) -> str:
        return f"points({', '.join(self._run.point_names)})"


def time_span(t: np.ndarray) -> str:
    """``0..20 s`` for the reprs of run results; ``none`` when there are no samples."""
    return f"{float(t[0]):g}..{float(t[-1]):g} s" if t.size else "none"
