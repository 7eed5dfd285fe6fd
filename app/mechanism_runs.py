"""A general mechanism's run as the player sees it: samples in a ring, chunks from ``simulate_mechanism``.

The player (app/player.py) drives chains and mechanisms alike through the members of a run specification
(:class:`app.runs.RunSpec`); :class:`MechanismSpec` gives them for any planar mechanism of
``physics.mechanism``: its state is the maximal coordinates ``q, qdot`` (x, y, phi of every body's centre of
mass), its drawn points are every named point of every body (:class:`Drawing`), and each chunk continues the
run from the last stored sample (``q0, qdot0, t_start``). Plain data and numpy; no viser, no thread.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from physics import INTEGRATORS, METHODS, LinkageError, Settings, Trajectory
from physics.mechanism import Mechanism, Prismatic, Revolute
from physics.mechanism.assembly import sketch_size
from physics.mechanism.constraints import Constraints, points_at_poses
from physics.mechanism.joints import kind_of
from physics.mechanism.run_table import BodyPoints, body_points, coordinate_names, run_table
from physics.mechanism.singularity import jacobian_condition
from physics.mechanism.validation import check_runnable
from physics.model import MECHANISM_MAX_TOLERANCE, MIN_RTOL, IntegratorName, StabilizationName

from .buffers import TrajectoryRing
from .player import SAMPLE_DT

# A chunk's work in the player's unit, a compiled chain right-hand side (about 2.7 us: CHUNK_WORK_BUDGET = 3000
# of them is about 8 ms). Measured on the one engine (CPU time of a chunk of 6 and of 60 samples, simulate and
# store, 2026-11-28): a right-hand side of the slider-crank about 0.9 us (a third of a unit), a sample about
# 2.7 us per body (one unit; the Jansen leg's 54 more samples 1.0 ms); a hosted triple pendulum's chunk about
# 0.9 ms whatever its length. The figures below are rounded up. They were 6 and 75 when a mechanism's stepper and
# samples were Python: on the one engine those kept every chunk at a few samples, so a classroom's sessions paid
# a chunk's fixed cost (about 1 ms) ten times a second each and their frames starved (tests/app/test_load.py).
EVALUATION_WORK = 1
SAMPLE_WORK = 2


def _settings_field(name: str) -> Any:
    """The one :class:`~physics.Settings`' field ``name`` (its default, range and checks), to declare it again."""
    return Settings.model_fields[name]


class MechanismSettings(BaseModel):
    """A run's options (``t_end`` and ``samples`` are set per chunk by the player)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    method: Literal["dae", "lagrange", "newton_euler", "reduced", "reduced_fixed"] = "dae"
    stabilization: StabilizationName = "projection"  # the one Settings' names (physics.registry.STABILIZATIONS)
    trace: str | None = None  # "body.point" whose path is drawn
    # and atol, within the span a mechanism's run allows (physics.model; compare mode's reference runs tighter)
    rtol: float = Field(1e-10, ge=MIN_RTOL, le=MECHANISM_MAX_TOLERANCE)
    # any of physics.registry.INTEGRATORS (the one Settings' names) that can run the method (allowed_integrators)
    integrator: IntegratorName = "DOP853"
    # s: the fixed step of midpoint and variational; 1/s: the Baumgarte terms' gains (stabilization = baumgarte):
    # the one Settings' own fields (defaults and ranges), not a copy of them
    step: float = _settings_field("step")
    baumgarte_alpha: float = _settings_field("baumgarte_alpha")
    baumgarte_beta: float = _settings_field("baumgarte_beta")
    # the integrator steps one call may take: the player lowers it per chunk (app/player.py, CHUNK_STEP_CAP), so a
    # motion too stiff to play stops with the sentence naming Radau or LSODA rather than holding the player
    max_steps: int = _settings_field("max_steps")
    # a hosted chain's runs integrate the chain's own coordinates (the spanning tree's, absolute rotations; the DAE
    # in them too), as physics.simulate runs a chain: the same numbers to the last bit, so its compare mode, its
    # departure times and the seed report's figures are the chain's (app/chain_knobs.py sets it)
    chain_coordinates: bool = False
    t_end: float = Field(1.0, gt=0.0)
    samples: int = Field(2, ge=2)


@dataclass(frozen=True)
class Drawing:
    """What to draw of a mechanism, by index into its list of points.

    ``labels[k]`` is ``"body.point"`` of drawn point k (every named point of every body, in the description's
    order); ``owner[k]`` its body's number and ``offset[k]`` its place relative to that body's centre of mass in
    the sketch. ``segments`` are pairs of point indices drawn as bars, with ``segment_body`` their body: a body
    with two points is one bar, a plate of three or more the edges of its outline (convex hull). ``joints``
    holds the points where a revolute joint sits (a body's side of it), ``ground`` the fixed points and the
    sliders' guides on the ground (``guides``: pairs of world points; ``guide_points``: each guide's sliding
    point, an index into ``labels``, whose travel the scene lengthens the guide to cover)."""

    labels: tuple[str, ...]
    owner: np.ndarray
    offset: np.ndarray
    segments: np.ndarray
    segment_body: np.ndarray
    joints: np.ndarray
    ground: np.ndarray
    guides: np.ndarray
    size: float
    # pairs of point indices a coupling joint is drawn between (a gear pair: its two pins)
    meshes: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=int))
    guide_points: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))


def _outline(points: np.ndarray) -> list[int]:
    """Indices of ``points`` around their convex hull, counter-clockwise (all of them when collinear)."""
    order = sorted(range(len(points)), key=lambda k: (points[k, 0], points[k, 1]))

    def cross(o, a, b) -> float:
        return float((points[a, 0] - points[o, 0]) * (points[b, 1] - points[o, 1])
                     - (points[a, 1] - points[o, 1]) * (points[b, 0] - points[o, 0]))

    lower: list[int] = []
    for k in order:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], k) <= 0:
            lower.pop()
        lower.append(k)
    upper: list[int] = []
    for k in reversed(order):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], k) <= 0:
            upper.pop()
        upper.append(k)
    hull = lower[:-1] + upper[:-1]
    return hull if len(hull) >= 3 else order


# of the sketch's size: how far a guide reaches past its slider where the slider is beyond the guide's first
# extent (the scene lengthens a guide as its slider runs further: app/mechanism_scene.py)
GUIDE_MARGIN_FRACTION = 0.1


def drawing(mechanism: Mechanism) -> Drawing:
    """The drawing of ``mechanism`` (see :class:`Drawing`)."""
    labels: list[str] = []
    owner: list[int] = []
    offset: list[np.ndarray] = []
    segments: list[tuple[int, int]] = []
    segment_body: list[int] = []
    for b, body in enumerate(mechanism.bodies):
        first = len(labels)
        centre = np.array(body.centre)
        sketch = np.array(list(body.points.values()), dtype=float).reshape(-1, 2)
        for name, xy in body.points.items():
            labels.append(f"{body.name}.{name}")
            owner.append(b)
            offset.append(np.array(xy) - centre)
        if len(sketch) == 2:
            segments.append((first, first + 1))
            segment_body.append(b)
        elif len(sketch) >= 3:
            ring = _outline(sketch)
            closed = len(ring) >= 3
            pairs = zip(ring, ring[1:] + ring[:1]) if closed else zip(ring, ring[1:])
            for i, j in pairs:
                segments.append((first + i, first + j))
                segment_body.append(b)
    index = {label: k for k, label in enumerate(labels)}
    joint_points = sorted({index[side] for joint in mechanism.joints if isinstance(joint, Revolute)
                           for side in (joint.a, joint.b) if side in index})
    guides = []
    guide_points = []
    size = max(sketch_size(mechanism), 1e-3)
    for joint in mechanism.joints:
        if isinstance(joint, Prismatic) and joint.on == "ground":
            through = np.array(mechanism.ground[joint.through])
            u = np.array(joint.direction) / np.hypot(*joint.direction)
            body = next(b for b in mechanism.bodies if b.name == joint.body)
            at = float(np.dot(np.array(body.points[joint.point]) - through, u))  # the slider in the sketch
            margin = GUIDE_MARGIN_FRACTION * size
            low, high = min(-0.75 * size, at - margin), max(0.75 * size, at + margin)
            guides.append((through + low * u, through + high * u))
            guide_points.append(index[f"{joint.body}.{joint.point}"])
    meshes = [[index[end] for end in kind_of(joint).drawn_between(joint, mechanism)] for joint in mechanism.joints
              if kind_of(joint).drawing == "mesh"]
    return Drawing(
        meshes=np.array([pair for pair in meshes if len(pair) == 2], dtype=int).reshape(-1, 2),
        labels=tuple(labels), owner=np.array(owner, dtype=int), offset=np.array(offset, dtype=float).reshape(-1, 2),
        segments=np.array(segments, dtype=int).reshape(-1, 2), segment_body=np.array(segment_body, dtype=int),
        joints=np.array(joint_points, dtype=int), ground=np.array(list(mechanism.ground.values()),
                                                                  dtype=float).reshape(-1, 2),
        guides=np.array(guides, dtype=float).reshape(-1, 2, 2), size=float(size),
        guide_points=np.array(guide_points, dtype=int),
    )


def points_at(draw: Drawing, q: np.ndarray) -> np.ndarray:
    """Every drawn point at poses ``q`` (..., 3 B) -> (..., P, 2) (the physics: ``points_at_poses``)."""
    return points_at_poses(q, draw.owner, draw.offset)


def centres_at(q: np.ndarray) -> np.ndarray:
    """Every body's centre of mass at poses ``q`` (..., 3 B) -> (..., B, 2)."""
    q = np.asarray(q, dtype=float)
    return np.stack([q[..., 0::3], q[..., 1::3]], axis=-1)


def pin_arrows(mechanism: Mechanism, draw: Drawing,
               row_names: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where each pin's reaction arrow is drawn, computed once per mechanism (not per frame): the drawn point,
    the reaction row of its x component (y is the next) and a sign. The multipliers are the force ON body a BY
    body b; a pin to the ground (a = ground) is drawn at the body's point with the force the ground exerts on
    the body, minus the multiplier."""
    index = {label: k for k, label in enumerate(draw.labels)}
    points, rows, signs = [], [], []
    for joint in mechanism.joints:
        name = f"{joint.name}: x gap"
        if not isinstance(joint, Revolute) or name not in row_names:
            continue
        side, sign = (joint.a, 1.0) if joint.a in index else (joint.b, -1.0)
        if side in index:
            points.append(index[side])
            rows.append(row_names.index(name))
            signs.append(sign)
    return np.array(points, dtype=int), np.array(rows, dtype=int), np.array(signs, dtype=float)


def torque_rows(row_names: tuple[str, ...]) -> list[int]:
    """Reaction rows that are a speed motor's torque (``"O2: driven angle"``)."""
    return [k for k, name in enumerate(row_names) if name.endswith(": driven angle")]


@dataclass
class MechanismChunk:
    """One chunk as the player reads a physics trajectory: ``status``, ``message``, work counts, the run."""

    run: object
    status: int = 0
    message: str = ""
    n_rhs: int = 0
    n_steps: int = 0

    @property
    def t(self) -> np.ndarray:
        return self.run.t  # type: ignore[attr-defined]


@dataclass
class MechanismSpec:
    """A mechanism's run for the player (the members of :class:`app.runs.RunSpec`)."""

    label: str
    chain: Mechanism  # the player's name for "the model"; here a general mechanism
    settings: MechanismSettings
    row_names: tuple[str, ...] = ()
    pin_arrows: tuple[np.ndarray, np.ndarray, np.ndarray] = field(init=False)  # see pin_arrows()
    # computes a chunk elsewhere (app/mechanism_workers.py: a worker process), with simulate_mechanism's
    # arguments; None: in this interpreter
    runner: Callable[..., object] | None = None
    draw: Drawing = field(init=False)
    points: BodyPoints = field(init=False)  # its named points (physics.mechanism.run_table): the drawing's paths
    # what a state ``q, qdot`` belongs to (structure_of), compared on each frame and on each edit
    structure: str = field(init=False)
    constraints: Constraints = field(init=False)  # its Phi(q, t): the condition at a shown sample (condition_at)
    # the traced point's path of states ``q`` (T, 3 n) -> (T, 2) where it is no named point (a hosted chain's
    # TracePoint: a coupler point, a centre of mass; app/chain_knobs.py ChainTrace); None: the named point's
    trace_of: Callable[[np.ndarray], np.ndarray] | None = None

    state_fields = ("q", "qdot")
    pinned = False

    def __post_init__(self) -> None:
        self.draw = drawing(self.chain)
        self.points = body_points(self.chain)
        self.structure = structure_of(self.chain)
        self.constraints = Constraints(self.chain)
        if not self.row_names:
            self.row_names = tuple(f"{row.joint}: {row.meaning}" for row in self.constraints.rows)
        self.pin_arrows = pin_arrows(self.chain, self.draw, self.row_names)

    @property
    def mechanism(self) -> Mechanism:
        return self.chain

    @property
    def n(self) -> int:
        """The number of bodies (the player scales its chunk lengths by it)."""
        return len(self.chain.bodies)

    @property
    def work_n(self) -> int:
        """The player's chunk budget is the triple pendulum's: the work units above are measured in it."""
        return 3

    @property
    def layout(self) -> tuple:
        return ("mechanism", self.draw.labels, self.row_names)

    def fields(self) -> dict[str, tuple[int, ...]]:
        size = 3 * self.n
        return {
            "q": (size,), "qdot": (size,), "joints": (len(self.draw.labels), 2), "com": (self.n, 2),
            "trace_xy": (2,), "kinetic": (), "potential": (), "energy": (), "residual": (), "condition": (),
            "reactions": (len(self.row_names),),
        }

    def new_ring(self, capacity: int, dt: float) -> TrajectoryRing:
        return TrajectoryRing(self.n, False, capacity, dt, fields=self.fields())

    def com_ratio(self) -> np.ndarray:
        return np.zeros(0)

    def trace_index(self) -> int | None:
        trace = self.settings.trace or self.chain.trace
        return self.draw.labels.index(trace) if trace in self.draw.labels else None

    def _samples(self, t, q, qdot, kinetic, potential, residual, reactions, condition=None, *,
                 paths: BodyPoints) -> dict[str, np.ndarray]:
        """A chunk's stored samples. Every drawn point's path is the run's own (``paths``: physics' named
        points, :class:`~physics.mechanism.run_table.BodyPoints`, whose first names are the drawing's labels), never
        computed here again; the traced one is one of them, else the first body's centre."""
        points = paths.paths(q, len(self.draw.labels))
        k = self.trace_index()
        if self.trace_of is not None:
            trace = self.trace_of(q)
        else:
            trace = points[:, k] if k is not None else centres_at(q)[:, 0]
        return {
            "t": np.asarray(t, dtype=float), "q": q, "qdot": qdot, "joints": points, "com": centres_at(q),
            "trace_xy": trace, "kinetic": kinetic, "potential": potential, "energy": kinetic + potential,
            "residual": residual, "reactions": reactions,
            **({"condition": condition} if condition is not None and len(condition) == len(q) else {}),
        }

    def chunk(self, traj: MechanismChunk) -> dict[str, np.ndarray]:
        """A chunk's stored samples. The run's ``condition`` (every sample's SVD of ``Phi_q``, computed when
        first read: physics.simulate.trajectory.OnRequest) is not read: only the status line shows it, at one
        sample, so each sample of a run that measures it is stored as NaN, "measure it when shown"
        (:meth:`condition_at`). The reduced model's run measures none (0 stored, as before)."""
        run = traj.run
        deferred = np.full(len(run.t), np.nan) if not is_reduced(self.settings.method) else None  # type: ignore[attr-defined]
        return self._samples(run.t, run.q, run.qdot, run.kinetic, run.potential, run.residual,  # type: ignore[attr-defined]
                             run.reaction_rows, deferred,  # type: ignore[attr-defined]
                             paths=run.body_points or self.points)  # type: ignore[attr-defined]

    def condition_at(self, ring: TrajectoryRing, index: int) -> float:
        """The condition of ``Phi_q`` at stored sample ``index`` (how near a singular pose it is), measured now
        when the chunk left it to the reader (NaN, :meth:`chunk`): the run's own measure of its samples
        (physics.mechanism.singularity.jacobian_condition, largest over smallest singular value; infinite at a
        pose that is not finite), of one pose instead of every sample of every chunk."""
        stored = float(ring.get("condition", index))
        if not math.isnan(stored):
            return stored
        q = ring.get("q", index)
        return jacobian_condition(self.constraints, q) if np.all(np.isfinite(q)) else math.inf

    def still_sample(self, t0: float, q0: np.ndarray, qdot0: np.ndarray) -> dict[str, np.ndarray]:
        """The start pose alone (a start that cannot move): no energies or reactions."""
        if np.shape(q0) != (3 * self.n,):
            raise LinkageError(f"a start of {np.size(q0) // 3} bodies cannot be drawn as {self.chain.name} "
                               f"({self.n} bodies)")
        q = np.where(np.isfinite(q0), q0, 0.0)[None, :]
        zero = np.zeros(1)
        return self._samples([t0], q, np.zeros_like(q), zero, zero, zero, np.zeros((1, len(self.row_names))),
                             paths=self.points)

    def simulate(self, mechanism: Mechanism, q0, qdot0, settings: MechanismSettings, t_start: float = 0.0,
                 continuing: bool = False) -> MechanismChunk:
        """One chunk: ``settings.samples`` samples over ``settings.t_end`` from ``t_start``. A failure midway
        (a singular pose, a blow-up) comes back as the run's status and message with the samples before it, and
        a start that cannot move raises LinkageError; the player turns either into the run's end."""
        if self.runner is not None:
            run: Trajectory = self.runner(mechanism, settings.t_end, settings.samples, q0, qdot0,  # type: ignore[assignment]
                                          t_start, settings.method, settings.stabilization, settings.rtol,
                                          settings.integrator, settings.step,
                                          (settings.baumgarte_alpha, settings.baumgarte_beta), settings.max_steps,
                                          continuing, *route_options(settings))
        else:  # in this interpreter: the formulations (sympy, scipy) load only here
            from physics.mechanism.simulate import simulate_mechanism  # noqa: PLC0415

            run = simulate_mechanism(mechanism, settings.t_end, settings.samples, q0=q0, qdot0=qdot0,
                                     t_start=t_start, settings=run_settings(
                                         settings.t_end, settings.samples, settings.method, settings.stabilization,
                                         settings.rtol, settings.integrator, settings.step,
                                         (settings.baumgarte_alpha, settings.baumgarte_beta), settings.max_steps),
                                     continuing=continuing, coordinates=route_options(settings)[0],
                                     rotations=route_options(settings)[1])
        # The player sizes chunks by their work, never by the wall clock (app/player.py), so a chunk stays
        # under a frame of compute and the frames keep their pace
        work = EVALUATION_WORK * run.n_rhs + SAMPLE_WORK * self.n * settings.samples
        return MechanismChunk(run=run, n_rhs=work, n_steps=run.n_steps, status=run.status, message=run.message)


def run_file(spec: MechanismSpec, samples: dict[str, np.ndarray], fmt: str) -> bytes:
    """The stored ``samples`` of a run (app/readout.py's history) as the ``mechanism`` command writes a run
    (``csv`` or ``json``: the same columns, ``lambda[JOINT: row]`` and all; docs/mechanisms.md). The traced point
    is NaN when none is chosen, as there."""
    trace = samples["trace_xy"] if spec.trace_index() is not None else np.full_like(samples["trace_xy"], np.nan)
    # integrator: the app's runs use simulate_mechanism's default; the table does not name it
    run = Trajectory(t=samples["t"], q=samples["q"], qdot=samples["qdot"], coordinate_names=coordinate_names(spec.chain),
                     reaction_rows=samples["reactions"], kinetic=samples["kinetic"], potential=samples["potential"],
                     energy=samples["kinetic"] + samples["potential"], residual=samples["residual"], trace_xy=trace,
                     row_names=spec.row_names, method=spec.settings.method, integrator="DOP853",
                     stabilization=spec.settings.stabilization, condition=samples["condition"])
    return run_table(run, fmt)


def structure_of(mechanism: Mechanism) -> str:
    """The geometry a state ``q, qdot`` of ``mechanism`` belongs to: the bodies' points and the joints, not
    the masses, motors or gravity, which an edit changes while the run goes on from the displayed state."""
    bodies = [(body.name, body.points, body.com) for body in mechanism.bodies]
    return repr((bodies, mechanism.ground, [joint.model_dump() for joint in mechanism.joints]))


def start_state(mechanism: Mechanism) -> tuple[np.ndarray, np.ndarray, int]:
    """The assembled start (nearest the sketch) at rest, and the mobility, of a mechanism that can run
    (physics.mechanism.validation: masses, motors the player's samples can follow, joints that close, equations
    that can be solved); LinkageError naming the body, joint or motor otherwise. Every way a mechanism enters
    the app goes through here (``--mechanism``, a preset, an upload, Reset) before anything shown changes."""
    assembled = check_runnable(mechanism, SAMPLE_DT)
    return assembled.q, np.zeros_like(assembled.q), assembled.mobility


def is_reduced(method: str) -> bool:
    """A reduced model in one joint coordinate (``reduced``, switching; ``reduced_fixed``, its first free joint
    kept): no stabilisation, its own DOP853 (the one registry, physics.METHODS)."""
    return bool(METHODS[method].reduced) if method in METHODS else False


def check_method(method: str, mobility: int) -> None:
    """The reduced model needs one free coordinate; say so in the words of the menu."""
    if is_reduced(method) and mobility != 1:
        raise LinkageError(f"method = {method}: needs 1 degree of freedom left free by the motors (this one has "
                           f"{mobility} free); "
                           "choose dae, lagrange or newton_euler")


# The reduced model's one integrator (physics.registry.REDUCED_INTEGRATOR, not public: the app reads physics'
# public names only; tests/app/test_mechanism_knobs.py checks the two agree)
REDUCED_INTEGRATOR = "DOP853"


def allowed_integrators(method: str) -> tuple[str, ...]:
    """The integrators of the registry that can run ``method`` on a mechanism: every one for a formulation
    except those that need a Lagrangian (the variational integrator: method lagrange); the reduced model
    integrates with its own DOP853 only (physics/mechanism/simulate.py)."""
    if is_reduced(method):
        return (REDUCED_INTEGRATOR,)
    return tuple(name for name, spec in INTEGRATORS.items()
                 if not (spec.needs_lagrangian and not METHODS[method].has_lagrangian))


def check_integrator(method: str, integrator: str) -> None:
    """``integrator`` can run ``method``, or one line naming why not and what is allowed."""
    allowed = allowed_integrators(method)
    if integrator in allowed:
        return
    if is_reduced(method):
        reason = f"method {method} integrates with {REDUCED_INTEGRATOR} only (its own switching right-hand side)"
    elif INTEGRATORS[integrator].needs_lagrangian:
        reason = "it discretises the Lagrangian T - V, so it needs method = lagrange"
    else:
        reason = f"it cannot run method {method}"
    raise LinkageError(f"integrator = {integrator}: does not apply to method {method} ({reason}); allowed "
                       f"{', '.join(allowed)}")


def route_options(settings: MechanismSettings) -> tuple[str, str]:
    """``(coordinates, rotations)`` of simulate_mechanism for these settings: maximal coordinates and relative
    rotations, or a hosted chain's own (``chain_coordinates``): the tree's coordinates (the DAE's too) with
    absolute rotations, as physics.simulate integrates a chain (the reduced models keep theirs)."""
    if not settings.chain_coordinates or is_reduced(settings.method):
        return "maximal", "relative"
    return ("tree" if settings.method == "dae" else "maximal"), "absolute"


def run_settings(t_end: float, samples: int, method: str, stabilization: str, rtol: float, integrator: str,
                 step: float | None, baumgarte: tuple[float, float] | None,
                 max_steps: int | None = None) -> Settings:
    """physics' one :class:`~physics.Settings` of one chunk (rtol = atol, as the chain panel sets them), every
    option, the Baumgarte gains too, checked by physics' own ``run_options`` (its one-line refusals: ``method =
    'euler': allowed values ...``). Loads the simulation: call it where a chunk is computed (a worker, or this
    interpreter's fallback)."""
    from physics.mechanism.simulate import run_options  # noqa: PLC0415 - scipy and the engine: only here

    alpha, beta = (None, None) if baumgarte is None else baumgarte
    return run_options(t_end=t_end, samples=samples, method=method, stabilization=stabilization, rtol=rtol,
                       atol=rtol, integrator=integrator, step=step, baumgarte_alpha=alpha, baumgarte_beta=beta,
                       max_steps=None if max_steps is None else int(max_steps))
