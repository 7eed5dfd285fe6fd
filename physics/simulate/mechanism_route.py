"""A chain's run on the general mechanism engine: the chain written as a mechanism, its Trajectory in the chain's
terms (issue 24, "one pipeline").

:func:`physics.simulate` runs every chain here, on the engine that runs every mechanism
(:mod:`physics.mechanism.engine`); there is no other route. The chain's own symbolic derivations
(:mod:`physics.derive`, loaded by :func:`physics.codegen.load_compiled`) remain as the independent formulas the
tests check this route against; the Equations tab shows this route's own system
(:func:`physics.equations_of_motion`). The chain is drawn hanging straight down
(:func:`physics.mechanism.chains.chain_mechanism` at ``theta = 0``; bars ``bar1..barn``, pins ``O``, ``J1 ..
J(n-1)`` and, for a pinned chain, ``H``; the chain's damping on every pin but ``H``), and its tree formulations
use absolute rotations (docs/mechanisms.md, "Absolute rotations"): a pin's tree coordinate is then the child's
own angle from the sketch, so the state integrated IS the chain's ``(theta, omega)``, permuted into the spanning
tree's order (the four-bar's ``(theta1, theta3, theta2)``, its closure ``J2``). What maps to what:

* ``newton_euler`` and ``lagrange``: the mechanism's formulation of that name in tree coordinates; ``dae``: the
  mechanism's DAE in tree coordinates (:mod:`physics.mechanism.tree_dae`), the chain's DAE integrating angles
  with every joint's multipliers; the reduced methods: the mechanism's reduced model as before
  (:mod:`physics.simulate.reduced_adapter`), its samples read by the mechanism's Lagrange system.
* The integration is the engine's (the same compiled kernels with dense output, scipy's solvers on the scipy
  back end), with the chain's stabilisation rule (an open chain has no constraint to hold) and the chain's sample
  times; a compiled RK45/DOP853 run and its samples are one buffer (:mod:`physics.codegen.mechanism_run`), any
  other run :func:`physics.mechanism.engine.integrate` then the same samples' functions.
* Every sample is solved by the mechanism's system (with the run's Baumgarte terms, as the chain's samples are):
  its reactions are the DAE's multipliers, or a tree formulation's by Newton's second law on every body in
  closed form (:mod:`physics.mechanism.tree_reactions`); pin ``O`` and ``J1 .. J(n-1)`` are the chain's joint
  reactions ``R_k`` (the force ON bar k+1 BY bar k), pin ``H`` the tip's. The condition is the solved system's:
  the kernel's estimate for an open chain, the 2-norm condition number of the matrix solved for a pinned one, as
  the chain's run reports it. Positions, energies, the traced point and the tip's velocity are the generic
  observables of :mod:`physics.codegen.mechanism_observables` (points reached from ``O`` along the bars, as the
  chain's own kinematics places them; the same to rounding).
* Failures are the chain's: a status and the chain's sentence (no mechanism name), never an exception midway.

This module is imported at a process's first run (by :func:`physics.simulate`), not by ``import physics``.

A warm route loads no :mod:`physics.mechanism` module (not :mod:`physics.mechanism.engine` either):
:func:`chain_route` reads the structure's record (:mod:`physics.simulate.chain_record`: the number-free pieces, kept
beside the generated code) and maps the chain's numbers itself; only a structure's first route (or a record not
trusted) writes the chain as a mechanism and derives the pieces, and the mechanism's description, prepared pieces
and dynamics are built when a caller asks for them (:attr:`ChainAsMechanism.mechanism`, ``pieces``, ``dynamics``)."""


from __future__ import annotations

import math
import threading
from collections.abc import Callable
from operator import is_ as _is
from typing import TYPE_CHECKING

import numpy as np

from ..codegen import mechanism_run, native_integrators
from ..codegen.cache import CompiledSystem, load_generated
from ..codegen.mechanism_observables import ObservablesPlan, PathPoints
from ..codegen.mechanism_run import solve_samples
from ..codegen.mechanism_samples import generic_solve, mechanism_samples
from ..model import Chain, Settings
from ..registry import INTEGRATORS, METHODS, SCIPY
from ..status import Status
from . import chain_record
from .chain_prepared import chain_arrays, sample_times, stabilization_gains, trace_point
from .chain_record import ChainRecord
from .trajectory import OnRequest, Trajectory

if TYPE_CHECKING:  # the mechanism package: loaded when a route is first derived, or its geometry asked for
    from ..mechanism.description import Mechanism
    from ..mechanism.numeric_dae import MechanismDAE
    from ..mechanism.prepared import Prepared

__all__ = ["chain_route", "chain_trajectory", "simulate_on_mechanism"]

ABSOLUTE = "absolute"


class _RecordMiss(Exception):
    """The record names a generated system the cache folder no longer holds: the route is derived again."""


class ChainAsMechanism:
    """A chain written as a mechanism for one method: its compiled system (absolute rotations), the permutation
    between the chain's bar order and the tree coordinates', the reaction rows, the parameter vector and the
    observables' constants; the mechanism's description, prepared pieces and dynamics on demand (a plain class:
    a warm route is built from a record without the mechanism package, which these properties load)."""

    def __init__(self, chain: Chain, damping: float, compiled: CompiledSystem, record: ChainRecord,
                 parameters: np.ndarray, mass_diagonal: np.ndarray, constant_force: np.ndarray,
                 damping_matrix: np.ndarray, sketch: tuple[np.ndarray, np.ndarray, np.ndarray],
                 mechanism: Mechanism | None = None, pieces: Prepared | None = None,
                 dynamics: MechanismDAE | None = None) -> None:
        self.chain, self.bars, self.damping = chain, tuple(chain.bars), float(damping)
        self.compiled = compiled
        self.record = record
        self.order = record.order  # tree coordinate k is the angle of bar order[k] (0-based)
        self.inverse = np.argsort(record.order)  # chain bar j is tree coordinate inverse[j]
        self.joint_rows = record.joint_rows  # the reaction rows of pins O, J1 .. J(n-1), x then y each: (2 n,)
        self.tip_rows = record.tip_rows  # pin H's two rows; empty for an open chain
        self.own_reactions = record.own_reactions  # the system's multipliers are every joint's reactions (the DAE)
        self.parameters = parameters  # the mechanism's parameter vector at t = 0 (never handed out: see below)
        self.mass_diagonal, self.constant_force, self.damping_matrix = mass_diagonal, constant_force, damping_matrix
        self.sketch = sketch  # each bar's P, D and centre (n, 2) in the sketch
        self._mechanism, self._pieces, self._dynamics = mechanism, pieces, dynamics

    def parameters_at(self, t: float) -> np.ndarray:
        """A fresh parameter vector with its time slot set to ``t`` (an integrator writes into it)."""
        params = self.parameters.copy()
        params[-1] = t
        return params

    @property
    def mechanism(self) -> Mechanism:
        """The chain drawn hanging down (:func:`~physics.mechanism.chains.chain_mechanism`), its pins damped."""
        if self._mechanism is None:
            from ..mechanism.chains import chain_mechanism  # noqa: PLC0415

            chain = self.chain
            if len(chain.bars) != len(self.bars) or not all(a is b for a, b in zip(chain.bars, self.bars)):
                chain = chain.model_copy(update={"bars": list(self.bars)})  # the bars this route was made of
            self._mechanism = chain_mechanism(chain, np.zeros(chain.n), damping=self.damping)
        return self._mechanism

    @property
    def pieces(self) -> Prepared:
        """The mechanism's prepared pieces (:func:`physics.mechanism.prepared.prepared`)."""
        if self._pieces is None:
            from ..mechanism.prepared import prepared  # noqa: PLC0415

            self._pieces = prepared(self.mechanism)
        return self._pieces

    @property
    def dynamics(self) -> MechanismDAE:
        """Its bodies' masses and applied forces (the chain's bars may be massless: read, never inverted)."""
        if self._dynamics is None:
            self._dynamics = _dynamics_of(self.mechanism, self.pieces)
        return self._dynamics


def _dynamics_of(mechanism: Mechanism, pieces: Prepared) -> MechanismDAE:
    """A chain's bar may have no mass or inertia (its tree formulation stays regular when the chain's does): the
    bodies' numbers are read for Newton's law on them only, never inverted."""
    if pieces.dae_or_none is not None:
        return pieces.dae_or_none
    from ..mechanism.numeric_dae import MechanismDAE  # noqa: PLC0415

    return MechanismDAE(mechanism, pieces.constraints, massless_allowed=True)


_lock = threading.Lock()
# (id(chain), method, damping) -> (the chain, its bars, the route); holding the chain keeps its id from reuse.
_routes: dict[tuple[int, str, float], tuple[Chain, tuple, ChainAsMechanism]] = {}
MAX_ROUTES = 32  # routes remembered at once (the oldest forgotten first): a few presets and the app's chains
# False: every route derived from the chain written as a mechanism (the tests compare the two ways)
USE_RECORDS = True


def chain_route(chain: Chain, method: str, damping: float) -> ChainAsMechanism:
    """The chain as a mechanism for ``method`` (a derived formulation; the reduced methods read the Lagrange
    system), remembered for this chain object, its bars and ``damping``: from the structure's record when the
    cache folder holds it (no mechanism module loaded), else derived from the chain written as a mechanism and
    the record written for the next process."""
    key = (id(chain), method, float(damping))
    entry = _routes.get(key)
    bars = chain.bars
    # map(operator.is_) over the bars: the same identity test as a generator, without a Python frame per bar
    if entry is not None and entry[0] is chain and len(entry[1]) == len(bars) and all(map(_is, entry[1], bars)):
        return entry[2]
    route = None
    if USE_RECORDS:
        record = chain_record.load_record(method, chain.n, chain.pinned)
        if record is not None:
            try:
                route = recorded_route(chain, damping, record)
            except _RecordMiss:
                route = None
    if route is None:
        route = derived_route(chain, method, damping)
        if USE_RECORDS:
            chain_record.save_record(route.record)
    with _lock:
        if len(_routes) >= MAX_ROUTES:
            _routes.pop(next(iter(_routes)))
        _routes[key] = (chain, tuple(bars), route)
    return route


def recorded_route(chain: Chain, damping: float, record: ChainRecord) -> ChainAsMechanism:
    """The route of ``record``'s structure for this chain's numbers; :class:`_RecordMiss` when its generated
    system is not in the cache folder (deriving it needs the mechanism)."""
    def missing():
        raise _RecordMiss(record.compiled_key)

    compiled = load_generated(record.compiled_key, record.formulation, missing)
    if compiled.n != chain.n or record.unknowns_map.shape[0] != compiled.n_unknowns:
        raise _RecordMiss(record.compiled_key)  # (a record of another system: a MAC forged is out of reach)
    constant_force = chain_record.gravity_force(chain)
    return ChainAsMechanism(chain, damping, compiled, record, chain_record.parameter_vector(chain, damping),
                            chain_record.mass_diagonal(chain), constant_force,
                            _damping_matrix(record.damper_jacobian, chain.n, chain.pinned, damping),
                            chain_record.sketch_points(chain))


def _damping_matrix(along: np.ndarray, n: int, pinned: bool, damping: float) -> np.ndarray:
    """``-J_d^T diag(c) J_d``: the pins' dampers' generalised force per rate (pins O, J1 .. J(n-1) damped by the
    chain's damping, pin H by none)."""
    size = 3 * n
    coefficients = np.array([float(damping)] * n + [0.0] * pinned)
    if not np.any(coefficients):
        return np.zeros((size, size))
    return -(along.T * coefficients) @ along


def derived_route(chain: Chain, method: str, damping: float) -> ChainAsMechanism:
    """The route derived from the chain written as a mechanism (:func:`chain_mechanism`, :func:`prepared`) and
    its record."""
    from ..mechanism import engine  # noqa: PLC0415
    from ..mechanism.chains import chain_mechanism  # noqa: PLC0415
    from ..mechanism.prepared import prepared  # noqa: PLC0415
    from ..mechanism.topology import analyse  # noqa: PLC0415
    from ..mechanism.tree_reactions import LoopReactions, TreeReactions  # noqa: PLC0415

    mechanism = chain_mechanism(chain, np.zeros(chain.n), damping=damping)
    pieces = prepared(mechanism)
    dynamics = _dynamics_of(mechanism, pieces)
    if method == "dae":
        from ..mechanism.tree_dae import compiled_tree_dae  # noqa: PLC0415

        compiled = compiled_tree_dae(mechanism, pieces.structure_key, ABSOLUTE)
    else:
        compiled = engine.compiled_system(mechanism, method, pieces.structure_key, ABSOLUTE)
    topology = pieces.topology if pieces.topology is not None else analyse(mechanism)
    order = np.array([int(body.removeprefix("bar")) - 1 for body in topology.parent], dtype=np.int64)
    names = pieces.row_names
    joint_names = ["O", *(f"J{k}" for k in range(1, chain.n))]
    joint_rows = np.array([names.index(row) for joint in joint_names for row in names
                           if row.split(":")[0] == joint], dtype=np.int64)
    tip_rows = np.array([names.index(row) for row in names if row.split(":")[0] == "H"], dtype=np.int64)
    own_reactions = method == "dae"
    # what the observables plan reads of the reactions (an open chain's tree, a pinned chain's loop with the tree
    # formulation's own multipliers of its cut pin; the DAE: its multipliers)
    chosen = np.concatenate([joint_rows, tip_rows])
    multiplier_index = compiled.multiplier_index
    unknowns_map = np.zeros((compiled.n_unknowns, chosen.size))
    size = dynamics.mass_diagonal.size
    linear = np.zeros((size, chosen.size))
    if own_reactions:
        unknowns_map[multiplier_index[chosen], np.arange(chosen.size)] = 1.0
    else:
        closed_form = pieces.tree_reactions
        if isinstance(closed_form, LoopReactions):
            linear = closed_form.sums[:, :closed_form.unknowns_to_rows.shape[1]][:, chosen]
            unknowns_map[multiplier_index] = closed_form.unknowns_to_rows[:, chosen]
        elif isinstance(closed_form, TreeReactions) and not closed_form.motor_rows.size:
            linear = closed_form.linear[:, chosen]
        else:  # a chain is pins only, no motors: its tree always has a closed form
            raise AssertionError("a chain's mechanism without a closed form of its reactions")
    constraints = dynamics.constraints
    if constraints.torque.size:  # a chain is pins only, no motors
        raise AssertionError("a chain's mechanism with a motor's torque")
    pose = constraints.sketch_pose()
    along = constraints.damper_jacobian(pose)
    expected = [float(damping)] * chain.n + [0.0] * chain.pinned
    if constraints.damping.tolist() != expected or along.shape != (len(expected), size):
        raise AssertionError("a chain's mechanism whose dampers are not its pins O, J1 .. J(n-1)")
    damping_matrix = np.zeros((size, size))
    if np.any(constraints.damping):  # a pin's damper: its relative spin's gradient is constant
        damping_matrix = -(along.T * constraints.damping) @ along
    record = ChainRecord(method, chain.n, chain.pinned, compiled.path.stem.rsplit("-", 1)[0], compiled.formulation,
                         order, joint_rows, tip_rows, own_reactions, linear, unknowns_map,
                         np.ascontiguousarray(along))
    bodies = mechanism.bodies
    sketch = (np.array([body.points["P"] for body in bodies], dtype=float),
              np.array([body.points["D"] for body in bodies], dtype=float),
              np.array([body.com for body in bodies], dtype=float))
    if tuple(mechanism.ground["O"]) != (0.0, 0.0):
        raise AssertionError("a chain's mechanism whose pin O is not at the origin")
    return ChainAsMechanism(chain, damping, compiled, record, pieces.parameters_at(0.0), dynamics.mass_diagonal,
                            dynamics.gravity.copy(), damping_matrix, sketch, mechanism, pieces, dynamics)


def simulate_on_mechanism(chain: Chain, theta0: np.ndarray, omega0: np.ndarray, settings: Settings,
                          t_start: float) -> Trajectory:
    """:func:`physics.simulate` of a checked request (valid start, assembled, output size allowed) on the
    mechanism engine: the same Trajectory, fields and shapes, status and sentences."""
    if METHODS[settings.method].reduced:
        from .reduced_adapter import simulate_reduced_trajectory  # noqa: PLC0415  (scipy: a reduced run only)

        return simulate_reduced_trajectory(chain, theta0.copy(), omega0.copy(), settings, t_start,
                                           build=reduced_samples_trajectory)
    request = _requests.get((id(chain), id(settings)))
    if request is not None and request.answers(chain, settings, t_start):
        return request.trajectory(chain, settings, theta0, omega0)
    route = chain_route(chain, settings.method, settings.damping)
    params = route.parameters_at(t_start)  # engine.run_parameters without weights: the integration's layout
    layout = route.compiled.integration_layout
    alpha, beta, project = stabilization_gains(chain, settings)
    t_eval = sample_times(t_start, settings.t_end, settings.samples)  # the chain's sample times
    if ONE_BUFFER_RUN and layout is route.compiled.integration_layout:
        trajectory = _run_in_one_buffer(chain, settings, route, params, theta0, omega0, t_eval, alpha, beta,
                                        project, t_start)
        if trajectory is not None:
            return trajectory
    from ..mechanism import engine  # noqa: PLC0415  (scipy's back end, another integrator: the engine's own)

    result = engine.integrate(route.compiled, layout, params, theta0[route.order], omega0[route.order], t_eval,
                              settings, alpha=alpha, beta=beta, project=project)
    y_out = result.states
    filled = _finite_rows(y_out)
    status = result.status
    if status == Status.OK and filled < len(t_eval):
        status = int(Status.NOT_FINITE)
    detail = result.detail if settings.backend == SCIPY else _compiled_detail(settings, status)
    n = chain.n
    states = y_out[:filled]
    trajectory = chain_trajectory(chain, settings, route, params, t_eval[:filled], states[:, :n][:, route.inverse],
                                  states[:, n:][:, route.inverse], alpha, beta)
    trajectory.status = status
    trajectory.message = ("ok" if status == Status.OK and not detail
                          else Status.describe(status, result.t_reached, detail))
    trajectory.n_steps = int(result.n_steps)
    trajectory.n_rhs = int(result.n_rhs)
    trajectory.stats["t_reached"] = float(result.t_reached)
    return trajectory


# A compiled RK45/DOP853 run and its samples in one buffer (physics.codegen.mechanism_run); False: the
# integration by engine.integrate and the samples by mechanism_samples, the same functions and bits (the
# tests compare the two).
ONE_BUFFER_RUN = True
_ONE_BUFFER_KERNELS = ("integrate_rk45", "integrate_dop853")
# True: the one-buffer run integrates and computes the points and energies; every sample's solve (the reactions,
# the condition) waits for a reader (_SolvedWhenRead: the same functions, the same bits). False: the run solves
# every sample itself (the tests compare the two). A call made under one setting keeps it (clear _calls).
SOLVE_WHEN_READ = True
_NO_CONDITION = np.empty(0)


def _run_in_one_buffer(chain: Chain, settings: Settings, route: ChainAsMechanism, params: np.ndarray,
                       theta0: np.ndarray, omega0: np.ndarray, t_eval: np.ndarray, alpha: float, beta: float,
                       project: bool, t_start: float) -> Trajectory | None:
    """The run of :func:`simulate_on_mechanism` by :func:`~physics.codegen.mechanism_run.integrate_and_observe`
    (the IR driver engine.integrate would call, the system's specialised one where it has it, then the samples
    as :func:`chain_trajectory` reads them), or None for a run the IR drivers do not answer (other integrators,
    scipy's back end). What the call needs besides the request's numbers comes from :func:`_one_buffer_call`."""
    spec = INTEGRATORS[settings.integrator]
    if (settings.backend == SCIPY or not spec.adaptive or spec.kernel not in _ONE_BUFFER_KERNELS
            or not native_integrators.answers(route.compiled.integration_layout, alpha, beta, project,
                                              _NO_CONDITION)):
        return None
    asked = settings.trace
    key = (id(route), spec.name, t_eval.shape[0], params.shape[0], chain.pinned,
           None if asked is None else (asked.bar, asked.along, asked.across))
    call = _calls.get(key)
    if call is None or call.route is not route:
        call = _one_buffer_call(key, chain, settings, route, spec.name, t_eval.shape[0], params.shape[0])
    elif mechanism_run.ONE_CALL:  # remembered: the system's specialised functions are in place
        request = _Request(chain, settings, t_start, call, t_eval, params, alpha, beta, project)
        with _plans_lock:
            if len(_requests) >= MAX_ROUTES:
                _requests.pop(next(iter(_requests)))
            _requests[(id(chain), id(settings))] = request
        return request.trajectory(chain, settings, theta0, omega0)
    columns = call.columns
    y0 = np.concatenate((theta0, omega0))
    if not call.in_order:
        y0 = y0[columns[0]]
    status, n_steps, n_rhs, t_reached, t, states, arrays = call.observe(
        call.shape, call.driver, call.solve, y0, t_eval, params, settings.rtol, settings.atol, alpha, beta, project,
        settings.max_steps, chain.g)
    if status == Status.OK and len(t) < len(t_eval):
        status = int(Status.NOT_FINITE)
    detail = _compiled_detail(settings, status)
    solved = _SolvedWhenRead(call, arrays.buffer, arrays.rows, alpha, beta, chain.g) if call.shape.eager else None
    if not len(t):
        trajectory = _empty_trajectory(chain, settings, route, call.n)
    elif call.in_order:  # the tree's order is the chain's (an open chain): copies of the columns, no fancy index
        n = call.n
        trajectory = _trajectory_from(chain, settings, route, t, states[:, :n].copy(), states[:, n:].copy(), arrays,
                                      solved)
    else:
        trajectory = _trajectory_from(chain, settings, route, t, states[:, columns[1]], states[:, columns[2]], arrays,
                                      solved)
    trajectory.status = status
    trajectory.message = "ok" if status == Status.OK and not detail else Status.describe(status, t_reached, detail)
    trajectory.n_steps = n_steps
    trajectory.n_rhs = n_rhs
    trajectory.stats["t_reached"] = t_reached
    return trajectory


class _Request:
    """A request repeated (the same chain object with the same bars, the same Settings object, the same
    ``t_start``; only the start may change): its :class:`_OneBufferCall` and the run prepared
    (:class:`~physics.codegen.mechanism_run.PreparedRun`: sample times, parameters and the native call's numbers
    made once), so a run is a buffer, one native call and the Trajectory's views. A benchmark's repeated runs, a
    study's or a sweep's runs from many starts take it; the same request made anew takes the path above, and
    both give the same bits (tests/physics/test_route_call_cache.py). Holds the chain and the settings, so their
    ids are not reused while remembered."""

    __slots__ = ("chain", "bars", "settings", "t_start", "call", "prepared", "index", "states", "open_chain")

    def __init__(self, chain: Chain, settings: Settings, t_start: float, call: _OneBufferCall, t_eval: np.ndarray,
                 params: np.ndarray, alpha: float, beta: float, project: bool) -> None:
        self.chain, self.bars, self.settings, self.t_start, self.call = chain, tuple(chain.bars), settings, t_start, call
        self.prepared = mechanism_run.PreparedRun(call.shape, call.driver, call.solve, t_eval, params, settings.rtol,
                                                  settings.atol, alpha, beta, project, settings.max_steps, chain.g)
        at = call.shape.at
        # where theta's entries go in y0 (tree coordinate inverse[j] is bar j), None in the chain's own order
        self.index = None if call.in_order else at.y0 + call.route.inverse
        self.states = (at.y_out, at.x)
        # an open chain's run of every sample, read straight off the buffer (a pinned chain's or a short run's
        # Trajectory by _trajectory_from)
        self.open_chain = (_OpenChainRun(chain, call, settings.trace is not None)
                           if not chain.pinned and call.in_order and call.shape.runs else None)

    def answers(self, chain: Chain, settings: Settings, t_start: float) -> bool:
        """Whether a run of ``chain`` with ``settings`` from ``t_start`` is this request (its chain and settings
        objects, its bars, its start time: ``-0.0`` is not ``0.0`` here, a sample time's sign shows)."""
        bars = chain.bars
        return (chain is self.chain and settings is self.settings and t_start == self.t_start
                and math.copysign(1.0, t_start) == math.copysign(1.0, self.t_start) and len(bars) == len(self.bars)
                and all(map(_is, bars, self.bars)) and ONE_BUFFER_RUN and mechanism_run.ONE_CALL)

    def trajectory(self, chain: Chain, settings: Settings, theta0: np.ndarray, omega0: np.ndarray) -> Trajectory:
        """The run from ``(theta0, omega0)`` (checked by :func:`physics.simulate`): what
        :func:`_run_in_one_buffer` returns for it."""
        call, prepared = self.call, self.prepared
        status, n_steps, n_rhs, t_reached, rows, values = prepared.run(theta0, omega0, self.index)
        entry = call.shape
        at = entry.at
        if status == Status.OK and rows < prepared.samples:
            status = int(Status.NOT_FINITE)
        numbers = prepared.numbers  # (t0, t_end, rtol, atol, alpha, beta, project, max_steps, g)
        solved = (_SolvedWhenRead(call, values, rows, numbers[4], numbers[5], numbers[8]) if entry.eager is not None
                  else None)
        if not rows:
            trajectory = _empty_trajectory(chain, settings, call.route, call.n)
        elif rows == prepared.samples and self.open_chain is not None:
            trajectory = self.open_chain.trajectory(settings, values, solved)
        else:
            arrays = mechanism_run.run_observables(entry, values, rows)
            t = values[at.t_eval:at.t_eval + rows]
            n = call.n
            if call.in_order:  # the states split into x and v by the native call: the chain's own columns
                theta = values[at.x:at.x + rows * n].reshape(rows, n)
                omega = values[at.v:at.v + rows * n].reshape(rows, n)
            else:
                start, end = self.states
                states = values[start:end].reshape(prepared.samples, 2 * n)[:rows]
                columns = call.columns
                theta, omega = states[:, columns[1]], states[:, columns[2]]
            trajectory = _trajectory_from(chain, settings, call.route, t, theta, omega, arrays, solved)
        trajectory.status = status
        trajectory.message = "ok" if status == Status.OK else Status.describe(status, t_reached, "")
        trajectory.n_steps = n_steps
        trajectory.n_rhs = n_rhs
        trajectory.stats["t_reached"] = t_reached
        return trajectory


class _OpenChainRun:
    """An open chain's Trajectory of a run that filled every sample, its fields views of the run's buffer at
    offsets worked out once: what :func:`_trajectory_from` gives for it (an open chain: no tip reaction, no
    constraint, the kernel's condition estimate; tree order = the chain's order), with a dozen fewer numpy
    calls a run."""

    __slots__ = ("explicit", "own_reactions", "n", "samples", "t", "x", "v", "joints",
                 "trace", "energies", "reactions", "condition")

    def __init__(self, chain: Chain, call: _OneBufferCall, explicit: bool) -> None:
        entry = call.shape
        at, samples, n = entry.at, entry.samples, chain.n
        if entry.runs[0][1] != n + 1 or entry.runs[1][1] != 1 or entry.plan.reactions != 2 * n:
            raise AssertionError("an open chain's run without its joints, traced point and joint reactions")
        self.explicit, self.own_reactions, self.n, self.samples = explicit, call.route.own_reactions, n, samples
        self.t = (at.t_eval, at.t_eval + samples)
        self.x, self.v = (at.x, at.x + samples * n), (at.v, at.v + samples * n)
        self.joints = (at.runs[0], at.runs[0] + samples * 2 * (n + 1))
        self.trace = (at.runs[1], at.runs[1] + samples * 2)
        self.energies = (at.energies, at.energies + 3 * samples)
        self.reactions = (at.reactions, at.reactions + samples * 2 * n)
        self.condition = (at.condition, at.condition + samples)

    def trajectory(self, settings: Settings, values: np.ndarray, solved: _SolvedWhenRead | None) -> Trajectory:
        count, n = self.samples, self.n
        joints = values[self.joints[0]:self.joints[1]].reshape(count, n + 1, 2)
        kinetic, potential, energy = values[self.energies[0]:self.energies[1]].reshape(3, count)
        joint_view = values[self.reactions[0]:self.reactions[1]].reshape(count, n, 2)
        condition_view = values[self.condition[0]:self.condition[1]]
        joint_reactions = joint_view if solved is None else solved.view(joint_view)
        condition = condition_view if solved is None else solved.view(condition_view)
        return Trajectory.of_chain(
            settings.method, settings.integrator, values[self.t[0]:self.t[1]],
            values[self.trace[0]:self.trace[1]].reshape(count, 2), kinetic, potential, energy,
            condition, values[self.x[0]:self.x[1]].reshape(count, n),
            values[self.v[0]:self.v[1]].reshape(count, n), joints, joints[:, -1, :],
            joint_reactions if self.own_reactions else np.zeros((count, 0, 2)), np.zeros((count, 0)),
            np.zeros((count, 0)), np.zeros((count, 0)), joint_reactions, self.explicit)


# (id(chain), id(settings)) -> the request (it holds both, and checks the bars and t_start)
_requests: dict[tuple[int, int], _Request] = {}


class _OneBufferCall:
    """What :func:`_run_in_one_buffer` hands :func:`~physics.codegen.mechanism_run.observe` besides the request's
    numbers, for one route, integrator, number of samples and traced point: the driver and the samples' solve,
    the run's shape (offsets and addresses), the observables' plan and the state's columns (and whether they
    are the chain's own order). Kept
    (:data:`_calls`) once the system's specialised driver and solve are both in place: until then each call asks
    the system again, so a run takes them as soon as they are (and the system counts its calls as before). Holds
    the route, so its id is not reused while remembered."""

    __slots__ = ("route", "n", "driver", "solve", "shape", "columns", "in_order", "observe")

    def __init__(self, route: ChainAsMechanism, n: int, driver, solve, shape, columns, observe) -> None:
        self.route, self.n, self.driver, self.solve, self.shape = route, n, driver, solve, shape
        self.columns, self.observe = columns, observe
        # tree coordinate k is bar k: the state's columns are the chain's own (the same values without an index)
        self.in_order = bool(np.array_equal(route.order, np.arange(n)))


# (id(route), integrator, samples, parameters, pinned, traced point or None) -> its call
_calls: dict[tuple, _OneBufferCall] = {}


def _one_buffer_call(key: tuple, chain: Chain, settings: Settings, route: ChainAsMechanism, integrator: str,
                     samples: int, n_params: int) -> _OneBufferCall:
    """The :class:`_OneBufferCall` of ``key`` (:func:`_run_in_one_buffer`'s), worked out now and remembered when
    the system's specialised functions are both there."""
    from ..codegen.mechanism_run import observe, run_shape  # noqa: PLC0415

    compiled = route.compiled
    driver = compiled.specialised_driver(integrator)
    specialised = compiled.samples_solve()
    call = _OneBufferCall(
        route, chain.n, driver if driver is not None else native_integrators.generic_driver(integrator),
        specialised.solve if specialised is not None else generic_solve(), None, _state_columns(route, chain.n),
        observe)
    plan = _chain_plan(chain, settings, route)
    n = chain.n  # the joints O, D_1 .. D_n and the traced point copied out on their own (_chain_points' order)
    call.shape = run_shape(compiled, compiled.integration_layout, plan, integrator, samples, n_params, chain.pinned,
                           runs=((n, n + 1), (2 * n + 1, 1)),
                           eager=_eager_plan(chain, settings, route) if SOLVE_WHEN_READ else None)
    if driver is not None and specialised is not None:
        with _plans_lock:
            if len(_calls) >= MAX_ROUTES:
                _calls.pop(next(iter(_calls)))
            _calls[key] = call
    return call


_columns: dict[int, tuple[ChainAsMechanism, tuple[np.ndarray, np.ndarray, np.ndarray]]] = {}


def _state_columns(route: ChainAsMechanism, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(tree state, theta, omega)`` columns: the tree's state ``[x, v]`` from the chain's ``[theta, omega]``,
    and the chain's angles and rates from the tree's state (each one fancy index, kept per route)."""
    entry = _columns.get(id(route))
    if entry is not None and entry[0] is route:
        return entry[1]
    columns = (np.concatenate([route.order, route.order + n]), route.inverse.copy(), route.inverse + n)
    with _plans_lock:
        if len(_columns) >= MAX_ROUTES:
            _columns.pop(next(iter(_columns)))
        _columns[id(route)] = (route, columns)
    return columns


def _finite_rows(y_out: np.ndarray) -> int:
    """How many rows of ``y_out`` are finite throughout (the kernels fill NaN first)."""
    if math.isfinite(float(y_out.sum())):
        return len(y_out)
    return int(np.count_nonzero(np.all(np.isfinite(y_out), axis=1)))


def _compiled_detail(settings: Settings, status: int) -> str:
    """The chain's words for a fixed step whose Newton iteration failed (it names the command's option)."""
    if status == Status.INTEGRATOR_FAILED and INTEGRATORS[settings.integrator].fixed_step:
        return f"the {settings.integrator} integrator's Newton iteration did not converge; reduce the step (--step)"
    return ""


def reduced_samples_trajectory(chain: Chain, settings: Settings, t: np.ndarray, y: np.ndarray) -> Trajectory:
    """The Trajectory of a reduced run's samples ``y = [theta, omega]`` (T, 2 n), read by the mechanism's
    Lagrange system in absolute rotations, as every other method's samples are read by its own system."""
    route = chain_route(chain, "lagrange", settings.damping)
    params = route.parameters_at(float(t[0]) if len(t) else 0.0)
    n = chain.n
    return chain_trajectory(chain, settings, route, params, t, y[:, :n], y[:, n:], 0.0, 0.0)


def chain_trajectory(chain: Chain, settings: Settings, route: ChainAsMechanism, params: np.ndarray, t: np.ndarray,
                     theta: np.ndarray, omega: np.ndarray, alpha: float, beta: float) -> Trajectory:
    """Everything a chain's Trajectory reports at the sampled angles and rates ``(T, n)``: the mechanism's
    system solved at every sample (its accelerations, multipliers and condition), its reactions in the chain's
    order, and the positions, velocities and energies read off the bodies' poses (the chain's joints and traced
    point named here, :func:`_chain_points`)."""
    count, n = theta.shape[0], chain.n
    theta = np.ascontiguousarray(theta)
    omega = np.ascontiguousarray(omega)
    return _trajectory_of(chain, settings, route, params, t, theta, omega, theta[:, route.order],
                          omega[:, route.order], alpha, beta) if count else _empty_trajectory(chain, settings, route, n)


def _trajectory_of(chain: Chain, settings: Settings, route: ChainAsMechanism, params: np.ndarray, t: np.ndarray,
                   theta: np.ndarray, omega: np.ndarray, s: np.ndarray, sd: np.ndarray, alpha: float,
                   beta: float) -> Trajectory:
    """:func:`chain_trajectory` of at least one sample, ``s``, ``sd`` the states in the tree's order: the
    system's solve, its poses (and a pinned chain's matrices) in one buffer
    (:func:`~physics.codegen.mechanism_samples.mechanism_samples`), the rest batched products of them."""
    compiled = route.compiled
    specialised = compiled.samples_solve()
    plan = _chain_plan(chain, settings, route)
    arrays = mechanism_samples(compiled, t, s, sd, params, None if specialised is None else specialised.solve,
                               alpha=alpha, beta=beta, constraints=False, kinematics=plan.mode != 0,
                               matrices=chain.pinned, observables=plan, g=chain.g)
    return _trajectory_from(chain, settings, route, t, theta, omega, arrays)


def _trajectory_from(chain: Chain, settings: Settings, route: ChainAsMechanism, t: np.ndarray, theta: np.ndarray,
                     omega: np.ndarray, arrays, solved: _SolvedWhenRead | None = None) -> Trajectory:
    """The Trajectory of at least one sample from the samples' arrays (``full``, ``condition``, ``matrices``
    and the chain plan's ``points``, ``velocities``, ``energies`` and ``reactions``), the chain's names given
    to the plan's rows and points. ``solved``: the samples are solved when a reader first asks (the reactions
    and the condition given as OnRequest); None: they are solved."""
    count, n = theta.shape[0], chain.n
    rows = arrays.reactions  # pins O, J1 .. J(n-1), x then y each, then a pinned chain's H
    joint_view = rows[:, :2 * n].reshape(count, n, 2)
    joint_reactions = joint_view if solved is None else solved.view(joint_view)
    tip_reaction: np.ndarray | OnRequest
    condition: np.ndarray | OnRequest
    runs = getattr(arrays, "runs", ())
    if runs:  # the one-buffer run copied them out on their own (_one_buffer_call asks for these two runs)
        joints, trace_xy = runs[0], runs[1].reshape(count, 2)
    else:
        joints = np.ascontiguousarray(arrays.points[:, n:2 * n + 1, :])  # O, then each bar's distal point
        trace_xy = np.ascontiguousarray(arrays.points[:, 2 * n + 1, :])
    kinetic, potential, energy = arrays.energies
    reactions = joint_reactions if route.own_reactions else np.zeros((count, 0, 2))
    if chain.pinned:
        tip_reaction = rows[:, 2 * n:] if solved is None else solved.view(rows[:, 2 * n:])
        constraint_xy = joints[:, -1, :] - np.asarray(chain.pin)
        constraint_velocity = np.ascontiguousarray(arrays.velocities[:, 2 * n, :])
        matrices = arrays.matrices
        condition = _condition(matrices) if solved is None else solved.of(lambda: _condition(matrices))
    else:
        tip_reaction = np.zeros((count, 0))
        constraint_xy = np.zeros((count, 0))
        constraint_velocity = np.zeros((count, 0))
        condition = arrays.condition if solved is None else solved.view(arrays.condition)
    return Trajectory.of_chain(
        settings.method, settings.integrator, t, trace_xy, kinetic, potential, energy, condition, theta, omega,
        joints, joints[:, -1, :], reactions, tip_reaction, constraint_xy, constraint_velocity, joint_reactions,
        settings.trace is not None,
    )


def _condition(matrices: np.ndarray) -> np.ndarray:
    """A pinned chain's condition: every sample's matrix's 2-norm condition number."""
    with np.errstate(all="ignore"):
        return np.linalg.cond(matrices)


class _SolvedWhenRead:
    """A compiled run's samples, solved when a reader first asks for what the solve gives (the reactions, the
    joint reactions, a pinned chain's tip reaction, the condition): a run of an eager shape
    (:func:`~physics.codegen.mechanism_run.run_shape`) integrates and computes the points and energies only, and
    :func:`~physics.codegen.mechanism_run.solve_samples` then solves every sample in the run's buffer, by the
    same functions with the same arguments, so the same bits as a run that solved them itself. One solve
    serves every such field of the run (the first reader's, under a lock)."""

    __slots__ = ("call", "values", "rows", "alpha", "beta", "g", "solved")

    def __init__(self, call: _OneBufferCall, values: np.ndarray, rows: int, alpha: float, beta: float,
                 g: float) -> None:
        self.call, self.values, self.rows, self.alpha, self.beta, self.g = call, values, rows, alpha, beta, g
        self.solved = False

    def _solve(self) -> None:
        with _solve_lock:
            if not self.solved:
                solve_samples(self.call.shape, self.call.solve, self.values, self.rows, self.alpha, self.beta, self.g)
                self.solved = True

    def view(self, part: np.ndarray) -> OnRequest:
        """``part`` (a view of the run's buffer) once the samples are solved."""
        return self.of(lambda: part)

    def of(self, compute: Callable[[], np.ndarray]) -> OnRequest:
        """``compute()`` once the samples are solved."""
        def read() -> np.ndarray:
            self._solve()
            return compute()
        return OnRequest(read)


_solve_lock = threading.Lock()


def _empty_trajectory(chain: Chain, settings: Settings, route: ChainAsMechanism, n: int) -> Trajectory:
    """The Trajectory of no sample (a run that failed before its first), every field of its shape."""
    zero = np.zeros(0)
    pinned = 2 * int(chain.pinned)
    return Trajectory.of_chain(
        settings.method, settings.integrator, zero, np.zeros((0, 2)), zero, zero, zero, zero, np.zeros((0, n)),
        np.zeros((0, n)), np.zeros((0, n + 1, 2)), np.zeros((0, 2)), np.zeros((0, n * route.own_reactions, 2)),
        np.zeros((0, pinned)), np.zeros((0, pinned)), np.zeros((0, pinned)), np.zeros((0, n, 2)),
        settings.trace is not None,
    )


_plans_lock = threading.Lock()
# (id(route), trace bar, along, across), or (id(route), None) for the tip -> (the route, its plan); holding the
# route keeps its id from reuse (a route is one chain object with its bars: the tip is fixed with it)
_plans: dict[tuple, tuple[ChainAsMechanism, ObservablesPlan]] = {}


def _turns_in_pose(compiled: CompiledSystem, route: ChainAsMechanism) -> bool:
    """Whether the observables read each bar's cosine and sine from the run's kinematics: its angles are the
    bars' rotation coordinates, and (the DAE, whose reactions need no kinematics) the kinematics comes with the
    solve in one call (:attr:`~physics.codegen.cache.CompiledSystem.sample_function`), not as a call of its own."""
    if not np.array_equal(compiled.pose_angle_index, route.inverse):
        return False
    return not route.own_reactions or (compiled.has_sample and compiled.time_slot < 0)


def _chain_plan(chain: Chain, settings: Settings, route: ChainAsMechanism) -> ObservablesPlan:
    """What a chain's Trajectory reads of the mechanism's samples, as the generic observables' plan: the points
    of :func:`_chain_points`, the reaction rows of pins ``O``, ``J1 .. J(n-1)`` then ``H`` (a pinned chain), by
    the DAE's multipliers or Newton's law on the bodies in closed form (:mod:`physics.mechanism.tree_reactions`:
    an open chain's tree, a pinned chain's loop with the tree formulation's own multipliers of its cut pin)."""
    asked = settings.trace
    key = (id(route), None) if asked is None else (id(route), asked.bar, asked.along, asked.across)
    entry = _plans.get(key)
    if entry is not None and entry[0] is route:
        return entry[1]
    trace = trace_point(chain, settings, chain_arrays(chain))  # the settings' point, else the tip; checked
    compiled, record = route.compiled, route.record
    acceleration_index = compiled.theta_ddot_index if not route.own_reactions else np.zeros(chain.n, dtype=np.int64)
    plan = ObservablesPlan(route.inverse, acceleration_index, route.mass_diagonal, route.constant_force,
                           route.damping_matrix, record.linear, record.unknowns_map, _chain_points(chain, trace, route),
                           tree=not route.own_reactions, turns_in_pose=_turns_in_pose(compiled, route))
    with _plans_lock:
        if len(_plans) >= MAX_ROUTES:
            _plans.pop(next(iter(_plans)))
        _plans[key] = (route, plan)
    return plan


def _eager_plan(chain: Chain, settings: Settings, route: ChainAsMechanism) -> ObservablesPlan:
    """:func:`_chain_plan` without its reaction rows, what a compiled run computes of every sample by itself: the
    same points and energies, each bar's cosine and sine evaluated from its angle (the run calls neither the
    solve nor the kinematics; the reactions and the condition are :func:`~physics.codegen.mechanism_run.
    solve_samples`' work when a reader asks, :class:`_SolvedWhenRead`)."""
    asked = settings.trace
    key = (id(route), "eager") if asked is None else (id(route), "eager", asked.bar, asked.along, asked.across)
    entry = _plans.get(key)
    if entry is not None and entry[0] is route:
        return entry[1]
    full = _chain_plan(chain, settings, route)
    trace = trace_point(chain, settings, chain_arrays(chain))
    none = np.zeros((full.bodies * 3, 0))
    plan = ObservablesPlan(route.inverse, np.zeros(chain.n, dtype=np.int64), route.mass_diagonal, route.constant_force,
                           route.damping_matrix, none, np.zeros((full.unknowns, 0)), _chain_points(chain, trace, route),
                           tree=False, turns_in_pose=False)
    with _plans_lock:
        if len(_plans) >= MAX_ROUTES:
            _plans.pop(next(iter(_plans)))
        _plans[key] = (route, plan)
    return plan


def _chain_points(chain: Chain, trace, route: ChainAsMechanism) -> PathPoints:
    """The points a chain's Trajectory reports, on the mechanism's bodies, each reached from pin ``O`` along the
    bars (the chain's own way round a pinned chain's loop, whatever the mechanism's tree): the bars' centres of
    mass, pin ``O``, the bars' distal points ``D`` (joints ``1 .. n``, the last the tip), then the traced point
    (``along`` bar ``bar`` from its proximal point ``P`` and ``across`` to its counter-clockwise side; the
    sketch draws every bar hanging down, so along is ``-y`` and across ``+x`` there)."""
    proximal, distal, centres = route.sketch
    through = [(k, distal[k] - proximal[k]) for k in range(chain.n)]
    traced = proximal[trace.bar - 1] + np.array([float(trace.across), -float(trace.along)])
    paths = [through[:k] + [(k, centres[k] - proximal[k])] for k in range(chain.n)]
    paths += [through[:k] for k in range(chain.n + 1)]
    paths.append(through[:trace.bar - 1] + [(trace.bar - 1, traced - proximal[trace.bar - 1])])
    origin = np.zeros(2)  # pin O is the origin (checked where the route is derived)
    return PathPoints.along(chain.n, np.tile(origin, (len(paths), 1)), paths)
