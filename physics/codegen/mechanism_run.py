"""A mechanism's compiled RK45/DOP853 run and every sample's observables in one buffer: the IR driver's
integration, then over the rows it filled the solve, the kinematics (a tree formulation's), the plain matrices
(when asked for) and :mod:`physics.codegen.mechanism_observables_ir`'s points, energies and reaction rows.

It is :func:`physics.codegen.native_integrators.integrate` followed by
:func:`physics.codegen.mechanism_samples.mechanism_samples` (without the held constraints), the same functions
called with the same arguments (the same bits), minus what the two did to hand arrays between them: every
input is copied into one array made here, whose parts' offsets are worked out once per shape of run, and each
output is a view of it. The chain's run on the mechanism engine (:mod:`physics.simulate.mechanism_route`)
spends most of a short run's time in the Python around its native calls (issue 24).
"""

from __future__ import annotations

import ctypes
import math
import threading
from typing import Any

import numpy as np

from ..kernels.checks import check_arguments
from ..kernels.layout import LAYOUT_CONSTRAINTS, LAYOUT_COORDINATES, LAYOUT_TIME, LAYOUT_UNKNOWNS
from .ir_shapes import integrator_scratch_length, samples_scratch_length, solve_pose_scratch_length
from .mechanism_observables import ObservablesPlan, observables_function, scratch_length, specialised_observables
from .native_integrators import layout_address
from .native_samples import pose_counterpart

_NO_CONDITION = np.empty(0)


def pose_width(size: int) -> int:
    """The generated kinematics' vector for a pose of ``size`` (3 B) entries: the pose, the bias, each body's
    cosine and sine (:attr:`physics.codegen.cache.CompiledSystem.pose_vector_size`)."""
    return 2 * size + 2 * (size // 3)


class _Offsets:
    """Where each part of a run's buffer starts (in doubles) for one shape of run: ``[counts (3 int64),
    t_reached, y0, t_eval, params (the driver's copy), params (the solve's copy), params (the kinematics' copy:
    its time slot is written), the driver's scratch, y_out, x, v, zeros (the kinematics' times), the solve's
    scratch, full, condition, d pose, pose|bias, matrices, right-hand sides, points, velocities, energies,
    reactions, the observables' scratch]``; the per-sample parts sized for every sample."""

    def __init__(self, method: str, n: int, k: int, r: int, r_solve: int, samples: int, n_params: int, size: int,
                 matrices: bool, count: int, reactions: int, bodies: int, runs: tuple = (),
                 pose_in_solve: bool = False) -> None:
        self.y0 = 4
        self.t_eval = self.y0 + 2 * n
        self.params = self.t_eval + samples
        self.solve_params = self.params + n_params
        self.kinematics_params = self.solve_params + n_params
        # the inputs end here: [counts, t_reached, y0, t_eval, params x 3] (PreparedRun copies them as one block)
        self.driver_scratch = self.kinematics_params + n_params
        self.y_out = self.driver_scratch + integrator_scratch_length(method, 2 * n, r, k)
        self.x = self.y_out + samples * 2 * n
        self.v = self.x + samples * n
        self.zeros = self.v + samples * n
        self.solve_scratch = self.zeros + samples
        self.full = self.solve_scratch + (solve_pose_scratch_length(n, k, r_solve, size) if pose_in_solve
                                          else samples_scratch_length(n, k, r_solve))
        self.condition = self.full + samples * k
        self.pose_jacobian = self.condition + samples
        self.pose_vector = self.pose_jacobian + samples * size * n
        self.matrices = self.pose_vector + samples * pose_width(size)
        self.rhs = self.matrices + samples * k * k * matrices
        self.points = self.rhs + samples * k * matrices
        self.velocities = self.points + samples * 2 * count
        self.energies = self.velocities + samples * 2 * count
        self.reactions = self.energies + 3 * samples
        self.scratch = self.reactions + samples * reactions
        self.rows = self.scratch + scratch_length(bodies)  # the rows finite throughout, written by the one call
        self.runs = []  # each run of points copied on its own (rows, count, 2), one after the other
        end = self.rows + 1
        for _, run_count in runs:
            self.runs.append(end)
            end += samples * 2 * run_count
        self.length = end


class _Run:
    """What a run of one system, plan and shape reads besides its inputs, worked out on its first call: the
    sizes, the buffer's offsets, the functions' and arrays' addresses (each look-up costs a microsecond or two a
    call). Holds the system, its layout and the plan, so their ids are not reused while it is remembered."""

    def __init__(self, compiled, integration_layout: np.ndarray, plan: ObservablesPlan, method: str, samples: int,
                 n_params: int, matrices: bool, runs: tuple = (), eager: ObservablesPlan | None = None) -> None:
        from .mechanism_samples import _assemble_function, _functions  # noqa: PLC0415

        layout = compiled.layout
        self.compiled, self.integration_layout, self.plan = compiled, integration_layout, plan
        # the plan the run's one call reads (its points and energies, no reaction row: the solve of the samples
        # left to solve_samples, when a reader asks), or None: the run solves every sample itself
        self.eager = eager
        if eager is not None and (eager.n != plan.n or eager.unknowns != plan.unknowns or eager.reactions
                                  or eager.count != plan.count or eager.bodies != plan.bodies
                                  or eager.mode not in (0, 3)):
            raise ValueError("expected an eager plan with the run's points and no reaction row")
        self.n, self.k = int(layout[LAYOUT_COORDINATES]), int(layout[LAYOUT_UNKNOWNS])
        self.constraints = int(integration_layout[LAYOUT_CONSTRAINTS])
        self.size = compiled.pose_size if plan.mode else 0  # the kinematics: a tree's reactions, or the turns
        if samples == 0 or plan.n != self.n or plan.unknowns != self.k or (plan.mode and not self.size):
            raise ValueError("expected at least one sample time and a plan that fits the system")
        self.samples, self.n_params, self.matrices = samples, n_params, int(bool(matrices))
        # check_arguments of this shape, once (observe checks what a call may change: the arrays' sizes)
        check_arguments(integration_layout, np.zeros(2 * self.n), 0.0, 0.0, np.zeros(samples), np.zeros(n_params),
                        np.zeros((samples, 2 * self.n)), _NO_CONDITION)
        if len(runs) > MAX_RUNS or not all(0 <= first and 1 <= count and first + count <= plan.count
                                           for first, count in runs):
            raise ValueError(f"expected at most {MAX_RUNS} runs of the plan's points")
        self.runs = tuple((int(first), int(count)) for first, count in runs)
        # a sample's solve and kinematics in one generated call (each angle's sine and cosine evaluated once)
        # where the system has it and nothing reads the time (the kinematics' copy of params keeps t = 0): once
        # its module is compiled, with the specialised samples' pass (plan_address looks)
        self.pose_in_solve = bool(self.size and int(layout[LAYOUT_TIME]) < 0 and compiled.has_sample)
        self.at = _Offsets(method, self.n, self.k, self.constraints, int(layout[LAYOUT_CONSTRAINTS]), samples,
                           n_params, self.size, matrices, plan.count, plan.reactions, plan.bodies, self.runs,
                           pose_in_solve=self.pose_in_solve)
        self.assemble = int(compiled.assemble_function)
        self.address = layout_address(layout)
        self.integration_address = layout_address(integration_layout)
        self.kinematics = int(compiled._native("kinematics")) if self.size else 0
        self.kinematics_call = _functions()[1]
        self.assemble_call = _assemble_function()
        self.observables_call = observables_function()
        # the observables specialised for each plan's structure, once there (the one call's and the native
        # solve_samples'; the calls from Python keep the generic function, so the tests comparing the two hold
        # the one to the other)
        self._observables_specialised: dict[int, tuple | None] = {}  # id(plan) -> its function, once there
        # the kinematics in the one call: the eager plan's reading of the turns (mode 3), else every solve's
        self.eager_size = (self.size if eager.mode else 0) if eager is not None else self.size
        self._plans: dict[tuple[int, int, int, int, bool], tuple] = {}

    def plan_address(self, driver, solve) -> int:
        """The address of :mod:`physics.codegen.mechanism_run_ir`'s plan for this shape with ``driver`` and
        ``solve`` (made once per pair of functions: the system's generic ones until its specialised ones are in
        place; the entry holds the functions and the array) and the observables' function: the one specialised
        for the plan's structure once :func:`~physics.codegen.mechanism_observables.specialised_observables`
        has it, the generic one until then. An eager shape's plan reads the eager plan and solves nothing."""
        return self._plan_address(driver, solve, self.eager)

    def solve_plan_address(self, solve) -> int:
        """The plan of ``mechanism_solve_samples`` for an eager shape (:func:`solve_samples`): the plan this
        shape's run would have had with ``solve``, had it solved its samples itself (no driver)."""
        return self._plan_address(None, solve, None)

    def _plan_address(self, driver, solve, eager: ObservablesPlan | None) -> int:
        read = self.plan if eager is None else eager
        observables = self._observables_specialised.get(id(read))
        if observables is None:
            observables = self._observables_specialised[id(read)] = specialised_observables(read)
        observables_call = self.observables_call if observables is None else observables[0]
        sample = self.compiled.compiled_sample_function if self.pose_in_solve and eager is None else 0
        key = (id(driver), id(solve), id(observables_call), sample, eager is None)
        kept = self._plans.get(key)
        if kept is not None and kept[0] is driver and kept[1] is solve and kept[2] is observables_call:
            return kept[4]
        at = self.at
        solve_pose = pose_counterpart(solve, self.compiled.specialised_samples()) if sample else None
        addresses = {"driver": _function_address(driver) if driver is not None else 0,
                     "solve": _function_address(solve),
                     "solve_pose": _function_address(solve_pose) if solve_pose is not None else 0,
                     "sample": sample if solve_pose is not None else 0,
                     "states": _function_address(self.kinematics_call),
                     "assemble_states": _function_address(self.assemble_call),
                     "observables": _function_address(observables_call), "assemble": self.assemble,
                     "integration_layout": self.integration_address, "layout": self.address,
                     "kinematics": self.kinematics, "samples": self.samples, "n": self.n,
                     "size": self.size if eager is None else self.eager_size, "tree": read.mode,
                     "matrices": self.matrices if eager is None else 0, "matrices_at": at.matrices,
                     "solve_samples": int(eager is None)}
        shape, indices, constants = read.addresses
        addresses.update(shape=shape, indices=indices, constants=constants, count=read.count)
        for number in range(MAX_RUNS):  # a run not asked for copies nothing (count 0)
            first, count = self.runs[number] if number < len(self.runs) else (0, 0)
            addresses.update({f"run_first_{number}": first, f"run_count_{number}": count,
                              f"run_at_{number}": at.runs[number] if number < len(self.runs) else 0})
        plan = np.array([addresses[name] if name in addresses else getattr(at, name) for name in PLAN_SLOTS],
                        dtype=np.int64)
        entry = (driver, solve, observables_call, plan, plan.ctypes.data)
        with _lock:
            if len(self._plans) >= 4:
                self._plans.clear()
            self._plans[key] = entry
        return entry[4]


def _function_address(function) -> int:
    """The machine-code address of a ctypes function."""
    return int(ctypes.cast(function, ctypes.c_void_p).value or 0)


_one_call: list = []  # [mechanism_run, mechanism_solve_samples (ctypes functions), the engine of both]


def _run_function():
    """The ctypes function of :mod:`physics.codegen.mechanism_run_ir`'s run, compiled once per installation at
    O2 as the observables' function is (its loops over the rows and points: about 18 us a run of seed case C
    faster than at the drivers' level; no floating-point arithmetic of its own, so the same bits) or loaded from
    the machine-code cache."""
    if not _one_call:
        _compile_one_call()
    return _one_call[0]


def _solve_function():
    """The ctypes function of the module's ``mechanism_solve_samples`` (:func:`solve_samples`)."""
    if not _one_call:
        _compile_one_call()
    return _one_call[1]


def _compile_one_call() -> None:
    from . import native  # noqa: PLC0415  (the O2 pipeline and target machine of the specialised code)
    from .machine_code import compile_module, llvm_binding, sources_digest  # noqa: PLC0415
    from .native_integrators import _lock as compile_lock  # noqa: PLC0415
    from .native_integrators import ir_builder  # noqa: PLC0415

    p, i, d = ctypes.c_void_p, ctypes.c_int64, ctypes.c_double
    run_signature = ctypes.CFUNCTYPE(i, p, p, d, d, d, d, d, d, i, i, d)
    solve_signature = ctypes.CFUNCTYPE(None, p, p, i, d, d, d, p)
    with compile_lock, native._lock:
        if not _one_call:
            llvm_binding()
            engine = compile_module(ir_builder("mechanism_run_ir", "run_ir"), "driver-O2", native._optimize,
                                    native._target_machine, key=f"mechanism_run\n{sources_digest()}")
            _one_call.extend([run_signature(engine.get_function_address("mechanism_run")),
                              solve_signature(engine.get_function_address("mechanism_solve_samples")), engine])


# True: the driver and the samples' calls in one native call (mechanism_run_ir); False: each from Python, the
# same functions and bits (the tests compare the two)
ONE_CALL = True


# the slots of mechanism_run_ir's plan, in order (here, not there: a warm process never imports the IR builders)
PLAN_SLOTS = (
    "driver", "solve", "solve_pose", "sample", "states", "assemble_states", "observables", "assemble",
    "integration_layout", "layout",
    "kinematics", "shape", "indices", "constants", "samples", "n", "size", "tree", "matrices",
    "y0", "t_eval", "params", "driver_scratch", "y_out", "x", "v", "zeros", "solve_params", "kinematics_params",
    "solve_scratch", "full", "condition", "pose_jacobian", "pose_vector", "matrices_at", "rhs", "points",
    "velocities", "energies", "reactions", "scratch", "rows", "count",
    "run_first_0", "run_count_0", "run_at_0", "run_first_1", "run_count_1", "run_at_1", "solve_samples",
)
MAX_RUNS = 2  # runs of points a run copies out on their own (the chain's joints and its traced point)
_lock = threading.Lock()
_runs: dict[tuple, _Run] = {}
MAX_SHAPES = 64


class RunObservables:
    """The samples' arrays of :func:`integrate_and_observe`, views of its buffer for the ``T`` rows filled:
    ``full (T, k)`` and ``condition (T,)`` of the solve, ``matrices (T, k, k)`` (``(0, k, k)`` unless asked
    for), ``points`` and ``velocities (T, P, 2)``, ``energies (3, T)`` (kinetic, potential, total) and
    ``reactions (T, R)`` of the plan, and ``runs``: each run of points asked for, ``(T, count, 2)`` on its own
    (C-contiguous, no copy needed)."""

    __slots__ = ("full", "condition", "matrices", "points", "velocities", "energies", "reactions", "runs", "buffer",
                 "rows")
    full: np.ndarray
    condition: np.ndarray
    matrices: np.ndarray
    points: np.ndarray
    velocities: np.ndarray
    energies: np.ndarray
    reactions: np.ndarray
    runs: tuple
    buffer: np.ndarray  # the run's buffer (solve_samples' ``values``) and its rows filled
    rows: int


def run_shape(compiled, integration_layout: np.ndarray, plan: ObservablesPlan, method: str, samples: int,
              n_params: int, matrices: bool, runs: tuple = (), eager: ObservablesPlan | None = None) -> _Run:
    """The worked-out shape of a run of ``compiled`` (:class:`_Run`) for :func:`observe`: remembered per system,
    layout, plan and shape, so a caller that runs the same request again may keep it instead of asking again.
    ``runs``: ``(first, count)`` of up to :data:`MAX_RUNS` runs of the plan's points to copy out on their own.
    ``eager``: the plan the run itself reads, ``plan``'s points without its reaction rows (mode 0 or 3); the
    samples' solve, ``plan``'s reactions and ``matrices`` are then :func:`solve_samples`' work, for whoever reads
    them (None: the run does all of it)."""
    runs = tuple((int(first), int(count)) for first, count in runs)
    key = (id(compiled), id(integration_layout), id(plan), method, samples, n_params, bool(matrices), runs, id(eager))
    entry = _runs.get(key)
    if entry is None or entry.compiled is not compiled or entry.integration_layout is not integration_layout \
            or entry.plan is not plan or entry.eager is not eager:
        entry = _Run(compiled, integration_layout, plan, method, samples, n_params, bool(matrices), runs, eager)
        with _lock:
            if len(_runs) >= MAX_SHAPES:
                _runs.clear()
            _runs[key] = entry
    return entry


def integrate_and_observe(driver, solve, compiled, integration_layout: np.ndarray, y0: np.ndarray,
                          t_eval: np.ndarray, params: np.ndarray, rtol, atol, alpha, beta, project, max_steps,
                          method: str, plan: ObservablesPlan, g: float, matrices: bool):
    """``(status, n_steps, n_rhs, t_reached, t, y, observables)`` of a run of ``compiled`` from ``y0`` over
    ``t_eval``: the driver's counts (as :func:`~physics.codegen.native_integrators.integrate` returns them),
    the sample times and states of the rows finite throughout (all unless the run failed) and their
    :class:`RunObservables`.

    ``driver``: a ctypes function of the drivers' signature for ``method`` ("RK45" or "DOP853"; the system's
    specialised one or the generic one) with ``integration_layout`` (the system's own, no projection weights);
    ``solve`` one of ``solve_states``' signature (specialised or generic) with the system's ``layout``; the
    solve has the Baumgarte gains ``alpha``, ``beta`` as the run's right-hand side. ``plan``: what the
    observables are (its ``tree``: the kinematics is evaluated for Newton's law on the bodies); ``matrices``:
    also each sample's plain matrix (a condition number's). ``y0``, ``t_eval`` and ``params`` C-contiguous
    float64 (only read)."""
    entry = run_shape(compiled, integration_layout, plan, method, t_eval.shape[0], params.shape[0], matrices)
    return observe(entry, driver, solve, y0, t_eval, params, rtol, atol, alpha, beta, project, max_steps, g)


_address_of = ctypes.addressof
# a fresh (writable) array's address in a fifth of the time ``.ctypes.data`` takes (typed Any: numpy's stubs do
# not declare the buffer protocol ctypes reads)
_bytes_of: Any = ctypes.c_char.from_buffer
_counts = ctypes.c_int64 * 2


def observe(entry: _Run, driver, solve, y0: np.ndarray, t_eval: np.ndarray, params: np.ndarray, rtol, atol, alpha,
            beta, project, max_steps, g: float):
    """:func:`integrate_and_observe` of a shape :func:`run_shape` gave for these arguments' system, layout, plan,
    method, sizes (``t_eval``'s, ``params``') and ``matrices`` (the arguments' shapes are checked again)."""
    n, samples, at = entry.n, entry.samples, entry.at
    values = np.empty(at.length)
    y_out = values[at.y_out:at.x].reshape(samples, 2 * n)
    # check_arguments' tests (:class:`_Run` made them for the shape): the sizes this shape was made for, forward
    t0, t_end = float(t_eval[0]), float(t_eval[-1])
    if t_eval.shape[0] != samples or params.shape[0] != entry.n_params or y0.shape[0] != 2 * n or not t_end >= t0:
        check_arguments(entry.integration_layout, y0, t0, t_end, t_eval, params, y_out, _NO_CONDITION)
        raise ValueError("t_eval's or params' length is not the one of this run's shape")
    values[:4] = 0.0  # the driver's three int64 counts (zero: the same bits as 0.0) and t_reached
    values[at.y0:at.t_eval] = y0
    values[at.t_eval:at.params] = t_eval
    values[at.params:at.driver_scratch].reshape(3, entry.n_params)[:] = params  # the driver's, solve's, kinematics'
    y_out.fill(np.nan)
    base = _address_of(_bytes_of(values))
    if ONE_CALL:
        status = _run_function()(entry.plan_address(driver, solve), base, t0, t_end, float(rtol), float(atol),
                                 float(alpha), float(beta), int(bool(project) and entry.constraints != 0),
                                 int(max_steps), float(g))
        rows = int(values[at.rows])
        states = y_out[:rows]
    else:
        status, rows, states = _observe_from_python(entry, driver, solve, values, base, y_out, t0, t_end, rtol, atol,
                                                    alpha, beta, project, max_steps, g)
    out = run_observables(entry, values, rows)
    n_steps, n_rhs = _counts.from_address(base)[:]  # the driver's counts (int64), read while values lives
    return int(status), n_steps, n_rhs, values.item(3), values[at.t_eval:at.t_eval + rows], states, out


class PreparedRun:
    """A run of one shape (:func:`run_shape`) whose sample times, parameters, tolerances, gains, step limit and
    gravity are fixed, only its start changing from call to call (a request repeated, as a benchmark's, a
    study's or a sweep's runs from other starts): the buffer's inputs but ``y0`` made once (:attr:`head`, copied
    as one block), the native call's numbers converted once. :meth:`run` is :func:`observe`'s one native call,
    the same arguments (so the same bits) with less Python around it."""

    __slots__ = ("entry", "driver", "solve", "head", "numbers", "samples")

    def __init__(self, entry: _Run, driver, solve, t_eval: np.ndarray, params: np.ndarray, rtol, atol, alpha, beta,
                 project, max_steps, g: float) -> None:
        at = entry.at
        t0, t_end = float(t_eval[0]), float(t_eval[-1])
        if t_eval.shape[0] != entry.samples or params.shape[0] != entry.n_params or not t_end >= t0:
            raise ValueError("t_eval's or params' length is not the one of this run's shape")
        self.entry, self.driver, self.solve, self.samples = entry, driver, solve, entry.samples
        head = np.zeros(at.driver_scratch)  # counts and t_reached zero (the same bits as int64 0), y0 written later
        head[at.t_eval:at.params] = t_eval
        head[at.params:at.driver_scratch].reshape(3, entry.n_params)[:] = params
        self.head = head
        self.numbers = (t0, t_end, float(rtol), float(atol), float(alpha), float(beta),
                        int(bool(project) and entry.constraints != 0), int(max_steps), float(g))

    def run(self, theta: np.ndarray, omega: np.ndarray, index: np.ndarray | None):
        """``(status, n_steps, n_rhs, t_reached, rows, values)``: the run from the state ``y0 = [theta, omega]``
        in the system's coordinates (``index``: where each of ``theta``'s entries goes among ``y0``'s first
        half, None for in order), its buffer ``values`` and the rows filled (read them with
        :func:`run_observables`, or at the :class:`_Offsets`)."""
        entry = self.entry
        at = entry.at
        values = np.empty(at.length)
        values[:at.driver_scratch] = self.head
        if index is None:
            values[at.y0:at.y0 + entry.n] = theta
            values[at.y0 + entry.n:at.t_eval] = omega
        else:
            values[index] = theta
            values[index + entry.n] = omega
        values[at.y_out:at.x].fill(np.nan)
        base = _address_of(_bytes_of(values))
        status = _run_function()(entry.plan_address(self.driver, self.solve), base, *self.numbers)
        n_steps, n_rhs = _counts.from_address(base)[:]
        return int(status), n_steps, n_rhs, values.item(3), int(values.item(at.rows)), values


def run_observables(entry: _Run, values: np.ndarray, rows: int) -> RunObservables:
    """The :class:`RunObservables` of a run's buffer ``values`` of shape ``entry`` whose first ``rows`` rows were
    filled: views, no copy."""
    at, k, matrices = entry.at, entry.k, entry.matrices
    plan = entry.plan
    count, reactions = plan.count, plan.reactions
    out = RunObservables()
    out.full = values[at.full:at.full + rows * k].reshape(rows, k)
    out.condition = values[at.condition:at.condition + rows]
    out.matrices = values[at.matrices:at.matrices + rows * k * k * matrices].reshape(rows * matrices, k, k)
    out.points = values[at.points:at.points + rows * 2 * count].reshape(rows, count, 2)
    out.velocities = values[at.velocities:at.velocities + rows * 2 * count].reshape(rows, count, 2)
    out.energies = values[at.energies:at.energies + 3 * rows].reshape(3, rows)
    out.reactions = values[at.reactions:at.reactions + rows * reactions].reshape(rows, reactions)
    out.runs = tuple(values[start:start + rows * 2 * run_count].reshape(rows, run_count, 2)
                     for start, (_, run_count) in zip(at.runs, entry.runs))
    out.buffer, out.rows = values, rows
    return out


def _samples_pass(entry: _Run, solve, plan: ObservablesPlan, base: int, rows: int, alpha, beta, g: float,
                  points: int, velocities: int, energies: int) -> None:
    """The samples' calls of a run's buffer at ``base`` whose ``rows`` rows of ``x``, ``v`` and zero times are
    written: ``solve`` (None: no solve, nor the matrices), the kinematics (when ``plan`` reads it) and ``plan``'s
    observables, its points, velocities and energies written at the given addresses."""
    at = entry.at
    address = entry.address
    if solve is not None:
        solve(entry.assemble, address, rows, base + 8 * at.x, base + 8 * at.v, base + 8 * at.solve_params,
              float(alpha), float(beta), base + 8 * at.full, base + 8 * at.condition, base + 8 * at.solve_scratch)
    size = entry.size if plan.mode else 0
    n = entry.n
    if size and rows:
        entry.kinematics_call(entry.kinematics, address, rows, base + 8 * at.zeros, base + 8 * at.x, base + 8 * at.v,
                              base + 8 * at.kinematics_params, size * n, pose_width(size), base + 8 * at.pose_jacobian,
                              base + 8 * at.pose_vector)
    if solve is not None and entry.matrices and rows:
        entry.assemble_call(entry.assemble, address, rows, base + 8 * at.x, base + 8 * at.v,
                            base + 8 * at.solve_params, base + 8 * at.matrices, base + 8 * at.rhs)
    shape, indices, constants = plan.addresses
    entry.observables_call(shape, indices, constants, rows, plan.mode, float(g), base + 8 * at.x, base + 8 * at.v,
                           n, base + 8 * at.full, base + 8 * at.pose_jacobian, base + 8 * at.pose_vector,
                           base + 8 * at.scratch, points, velocities, energies, base + 8 * at.reactions)


def solve_samples(entry: _Run, solve, values: np.ndarray, rows: int, alpha, beta, g: float) -> None:
    """What a run of an ``eager`` shape (:func:`run_shape`) left to its reader, done in its buffer ``values``
    (the first ``rows`` rows filled): every sample's solve by ``solve`` (the run's), its kinematics and matrices
    when the shape has them, and the full plan's reaction rows; :func:`run_observables`' ``full``,
    ``condition``, ``matrices`` and ``reactions`` read them afterwards. The same functions with the same
    arguments as a run that solves its samples itself (so the same bits); the points, velocities and energies
    the run already wrote are left as they are (the full plan's go to a scratch array)."""
    if entry.eager is None:
        raise ValueError("this run's shape solves its samples itself")
    if not rows:
        return
    count = entry.plan.count
    spare = np.empty(4 * rows * count + 3 * rows)
    spare_base = spare.ctypes.data
    if ONE_CALL:  # one native call, the fused solve and kinematics where the system has them
        _solve_function()(entry.solve_plan_address(solve), values.ctypes.data, int(rows), float(alpha), float(beta),
                          float(g), spare_base)
    else:
        _samples_pass(entry, solve, entry.plan, values.ctypes.data, rows, alpha, beta, g, spare_base,
                      spare_base + 8 * 2 * rows * count, spare_base + 8 * 4 * rows * count)


def _observe_from_python(entry: _Run, driver, solve, values: np.ndarray, base: int, y_out: np.ndarray, t0: float,
                         t_end: float, rtol, atol, alpha, beta, project, max_steps, g: float):
    """What the one call does, a native call at a time from Python: ``(status, rows, states)``."""
    n, samples, at = entry.n, entry.samples, entry.at
    status = driver(entry.assemble, entry.integration_address, base + 8 * at.y0, t0, t_end,
                    base + 8 * at.t_eval, samples, base + 8 * at.params, float(rtol), float(atol), float(alpha),
                    float(beta), int(bool(project) and entry.constraints != 0),  # the kernel's _projecting
                    int(max_steps), base + 8 * at.y_out, base + 8 * at.driver_scratch, base, base + 24)
    if math.isfinite(float(y_out.sum())):  # physics.simulate.run's rule: the rows finite throughout
        rows = samples
    else:
        rows = int(np.count_nonzero(np.all(np.isfinite(y_out), axis=1)))
    states = y_out[:rows]
    # x then v (T, n) each, one after the other in the buffer: both from the states [x, v] in one copy
    values[at.x:at.zeros].reshape(2, samples, n)[:, :rows] = states.reshape(rows, 2, n).transpose(1, 0, 2)
    values[at.zeros:at.zeros + rows] = 0.0
    eager = entry.eager  # (an eager run: its plan's points and energies alone, the solve left to solve_samples)
    _samples_pass(entry, solve if eager is None else None, entry.plan if eager is None else eager, base, rows, alpha,
                  beta, g, base + 8 * at.points, base + 8 * at.velocities, base + 8 * at.energies)
    plan = entry.plan
    points = values[at.points:at.points + rows * 2 * plan.count].reshape(rows, plan.count, 2)
    for start, (first, run_count) in zip(at.runs, entry.runs):
        values[start:start + rows * 2 * run_count].reshape(rows, run_count, 2)[:] = points[:, first:first + run_count]
    return int(status), rows, states
