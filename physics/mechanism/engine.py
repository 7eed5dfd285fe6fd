"""Any mechanism on the one compiled engine: generated code per *structure*, its numbers a parameter vector.

A mechanism's formulation (:mod:`physics.mechanism.symbolic`) is derived once per structure and method, written
as LLVM IR by :mod:`physics.codegen.emit` and kept in the authenticated cache folder exactly as a chain's is
(:func:`physics.codegen.cache.load_generated`); masses, inertias, points, motor speeds and torques, damping and
g reach it as the parameter vector of :mod:`physics.mechanism.parameters`, so editing any of them derives and
compiles nothing. Every integrator of :data:`physics.registry.INTEGRATORS` runs it as it runs a chain: the
once-compiled kernels of :mod:`physics.kernels` (RK45, DOP853 and ode45 with dense output, the fixed-step
midpoint rule, the variational integrator where the formulation has a Lagrangian; Baumgarte terms and projection
onto the constraints written once for every system) or scipy's Radau and LSODA on the same right-hand side, and
every sample's pose, velocities, accelerations and reactions come out of batched kernel calls.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..codegen import native_integrators
from ..codegen.cache import CompiledSystem, load_generated
from ..kernels.first_compile import call_announced
from .description import Mechanism
from .parameters import parameter_vector, structure, structure_key

if TYPE_CHECKING:
    from .prepared import Prepared
    from .tree_reactions import LoopReactions, TreeReactions


def compiled_system(mechanism: Mechanism, method: str, key_of_structure: str | None = None,
                    rotations: str = "relative") -> CompiledSystem:
    """The generated system of ``method`` for ``mechanism``'s structure: from memory, from the cache folder, or
    derived (sympy, only on a miss) and cached. ``key_of_structure``: :func:`structure_key` of ``mechanism``
    when the caller holds it (:mod:`physics.mechanism.prepared`). ``rotations``: what a tree formulation's pin
    coordinate is (:data:`~physics.mechanism.parameters.ROTATIONS`), a choice of the compiled system and
    so part of its key; the DAE's maximal coordinates have one meaning, so it ignores it."""
    from .tree_coordinates import check_rotations  # noqa: PLC0415

    check_rotations(rotations)
    rotations = "relative" if method == "dae" else rotations
    digest = structure_key(mechanism) if key_of_structure is None else key_of_structure
    key = _key(digest, method, rotations)

    def derive():
        from .symbolic import derive_structure  # noqa: PLC0415  (sympy only on a cache miss)

        shape = structure(mechanism)
        return derive_structure(shape, method, rotations), (f"a mechanism of {shape.bodies} bodies and "
                                                            f"{len(shape.joints)} joints, structure {digest}"
                                                            f"{', absolute rotations' * (rotations == 'absolute')}")

    return load_generated(key, method, derive)


def is_compiled(mechanism: Mechanism, method: str, rotations: str = "relative") -> bool:
    """True when ``method``'s generated system for this structure is loaded or cached (no sympy needed)."""
    from ..codegen.cache import is_generated_key  # noqa: PLC0415

    return is_generated_key(_cache_key(mechanism, method, rotations))


def _cache_key(mechanism: Mechanism, method: str, rotations: str = "relative") -> str:
    """The generated system's name in the cache: its method, its structure and (for a tree formulation) what
    its pins' coordinates are, never its numbers."""
    return _key(structure_key(mechanism), method, "relative" if method == "dae" else rotations)


def _key(digest: str, method: str, rotations: str = "relative") -> str:
    """The relative rotations' key is the one every cached mechanism has had; absolute ones add a word, so the
    two never share generated code."""
    kind = "" if rotations == "relative" else f"{rotations}-"
    return f"{method.replace('_', '')}-mechanism-{kind}{digest}"


# eq=False, repr=False: its arrays compare elementwise and print whole; generating __eq__ and __repr__ cost
# every process about 0.5 ms a class (benchmarks/small_cuts.py)
@dataclass(frozen=True, eq=False, repr=False)
class Integration:
    """What the integrator returns: states ``(T, 2 n)`` at the sample times (NaN past a failure), the status,
    the counts, where it stopped, how many samples it filled and, for a failure, the solver's own words."""

    states: np.ndarray
    status: int
    n_steps: int  # accepted steps
    n_rhs: int  # right-hand sides evaluated
    t_reached: float
    filled: int
    detail: str = ""


def run_parameters(mechanism: Mechanism, compiled: CompiledSystem, t_start: float, weights: np.ndarray | None,
                   integrating: bool = True, base: np.ndarray | None = None):
    """The parameter vector of a run, and the layout to pass with it: when ``weights`` (2 n: positions, then
    velocities) are given, they are appended to the vector and the layout says where. ``integrating``: the
    layout with the fused right-hand side the integrators call (its module compiled on first use); a driven
    run's position analysis does not need it. ``base``: the run's own copy of :func:`parameter_vector` at
    ``t_start`` when the caller holds it (the integrators write the time slot: never a shared array)."""
    params = parameter_vector(mechanism, t=t_start) if base is None else base
    layout = compiled.integration_layout if integrating else compiled.layout
    if weights is not None:  # the system's own weighted layout: its specialised driver can take it
        layout = compiled.weighted_layout(params.size, integrating)
        params = np.concatenate([params, weights])
    return np.ascontiguousarray(params), layout


# The kernel module that holds each compiled integrator (IntegratorSpec.kernel), imported on first use: numba's
# cached machine code of an integrator nobody asked for is never loaded.
KERNEL_MODULES = {"integrate_rk45": "explicit_rk", "integrate_dop853": "explicit_rk", "integrate_ode45": "ode45",
                  "integrate_midpoint": "midpoint", "integrate_variational": "variational"}


def integrate(compiled: CompiledSystem, layout: np.ndarray, params: np.ndarray, x0: np.ndarray, v0: np.ndarray,
              times: np.ndarray, settings, *, alpha: float, beta: float, project: bool) -> Integration:
    """Integrate from ``times[0]`` to ``times[-1]`` with samples at ``times`` by ``settings.integrator`` on
    ``settings.backend``, exactly as a chain's run does (physics/simulate/run.py): a compiled kernel with dense
    output called with the run's own ``layout`` (it carries the DAE's projection weights), or scipy's solver
    stepped by hand on the same right-hand side. A failure is a status, never an exception."""
    import importlib  # noqa: PLC0415

    from ..registry import INTEGRATORS, SCIPY  # noqa: PLC0415

    spec = INTEGRATORS[settings.integrator]
    y0 = np.ascontiguousarray(np.concatenate([x0, v0]), dtype=float)
    t_eval = np.ascontiguousarray(times, dtype=float)
    if settings.backend == SCIPY:
        from ..simulate.scipy_backend import integrate_scipy  # noqa: PLC0415  (scipy only for this back end)

        y_out, _, status, steps, evaluations, t_reached, detail = integrate_scipy(
            compiled, y0, t_eval, params, settings, alpha, beta, project, layout=layout)
        filled = int(np.count_nonzero(np.all(np.isfinite(y_out), axis=1)))
        return Integration(y_out, int(status), int(steps), int(evaluations), float(t_reached), filled, detail)
    assert spec.kernel is not None, spec.name  # Settings sends only compiled-capable integrators here
    y_out = np.empty((t_eval.size, y0.size))
    cond_out = np.empty(0)  # no condition per sample from the kernel (the run reports its own: _conditions)
    t0, t1 = float(t_eval[0]), float(t_eval[-1])
    if spec.adaptive and spec.kernel in ("integrate_rk45", "integrate_dop853"):
        # the drivers generated as LLVM IR first (the kernel's bits without numba's compilation, stabilised or
        # not); the kernel for a run they hand back (physics/codegen/native_integrators.py)
        # with the system's own layout (a tree formulation's, or a maximal one's with its projection weights,
        # CompiledSystem.weighted_layout), the driver specialised for the system once it is compiled (physics.codegen.specialised_ir: the same bits, seed case
        # C's integration in about 0.2 ms instead of 0.5), as the system's own integrate_rk45 takes it for a chain
        driver = (compiled.specialised_driver(spec.name, layout, t1 - t0)  # CompiledSystem's rule, not copied
                  if compiled.is_own_integration_layout(layout)
                  and native_integrators.answers(layout, alpha, beta, project, cond_out) else None)
        answer = native_integrators.integrate(spec.name, compiled.assemble_function, layout, y0, t0, t1, t_eval,
                                              params, settings.rtol, settings.atol, alpha, beta, project,
                                              settings.max_steps, y_out, cond_out, driver)
        if answer is not None:
            status, steps, evaluations, t_reached, filled = answer
            compiled.count_integration(spec.name, layout, evaluations, t_reached - t0)
            return Integration(y_out, int(status), int(steps), int(evaluations), float(t_reached), int(filled), "")
    # the numba kernel (numba is imported here, not for a run the IR drivers answered); its first compilation in
    # an installation takes seconds, said first in one line (physics.kernels.first_compile)
    kernel = getattr(importlib.import_module(f"..kernels.{KERNEL_MODULES[spec.kernel]}", __package__), spec.kernel)
    if spec.needs_lagrangian:  # it holds the loops itself (RATTLE): no stabilisation gains
        arguments: tuple = (compiled.assemble_function, compiled.mass_and_force_function, layout, y0, t0, t1,
                            settings.step, t_eval, params, y_out, cond_out)
    elif spec.fixed_step:
        arguments = (compiled.assemble_function, layout, y0, t0, t1, settings.step, t_eval, params, alpha, beta,
                     project, y_out, cond_out)
    else:
        arguments = (compiled.assemble_function, layout, y0, t0, t1, t_eval, params, settings.rtol, settings.atol,
                     alpha, beta, project, settings.max_steps, y_out, cond_out)
    # RK45 and DOP853 are plain functions choosing the compiled driver's variant, which say the line themselves
    result = kernel(*arguments) if KERNEL_MODULES[spec.kernel] == "explicit_rk" else call_announced(
        kernel, arguments, spec.name)
    status, steps, evaluations, t_reached, filled = result
    detail = ""
    if int(status) != 0 and spec.fixed_step:
        detail = (f"the {spec.name} integrator's Newton iteration did not converge; reduce the step (step = "
                  f"{settings.step:g})")
    return Integration(y_out, int(status), int(steps), int(evaluations), float(t_reached), int(filled), detail)


# eq=False, repr=False: its arrays compare elementwise and print whole; generating __eq__ and __repr__ cost
# every process about 0.5 ms a class (benchmarks/small_cuts.py)
@dataclass(frozen=True, eq=False, repr=False)
class Samples:
    """Every sample in maximal coordinates, from one formulation's own solution: ``q, qdot, qddot (T, 3 B)``,
    and its multipliers ``(T, r)`` in the order of its constraint rows."""

    q: np.ndarray
    qdot: np.ndarray
    qddot: np.ndarray
    multipliers: np.ndarray
    residual: np.ndarray
    kernel_condition: np.ndarray
    constraint_jacobian: np.ndarray  # (T, r, n): the held constraints' Jacobian in the formulation's coordinates


def samples(compiled: CompiledSystem, params: np.ndarray, times: np.ndarray, x: np.ndarray, v: np.ndarray
            ) -> Samples:
    """Solve the formulation's system at every sample (no Baumgarte terms) and map its coordinates to every
    body's pose: the identity for the DAE, the generated kinematics for tree coordinates. The native calls in one
    buffer (:data:`ONE_BUFFER_SAMPLES`: the same functions and bits, a tenth of a millisecond less a run)."""
    if ONE_BUFFER_SAMPLES:
        return _samples_in_one_buffer(compiled, params, times, x, v)
    # the samples' pass generated as IR (the kernel's bits, nothing for numba to compile)
    full, condition = compiled.solve_samples(np.ascontiguousarray(x), np.ascontiguousarray(v), params)
    acceleration = full[:, compiled.theta_ddot_index]
    multipliers = full[:, compiled.multiplier_index]
    jacobian_rows, phi, _ = compiled.constraint_states(times, x, v, params)
    residual = np.max(np.abs(phi), axis=1, initial=0.0)
    if compiled.pose_size == 0:
        return Samples(x, v, acceleration, multipliers, residual, condition, jacobian_rows)
    jacobian, pose, bias = compiled.kinematics_states(x, v, params)
    qdot = np.einsum("kij,kj->ki", jacobian, v)
    qddot = np.einsum("kij,kj->ki", jacobian, acceleration) + bias
    return Samples(pose, qdot, qddot, multipliers, residual, condition, jacobian_rows)


# The samples' native calls in one buffer (physics.codegen.mechanism_samples); False: one CompiledSystem call
# each, for the tests that compare the two bit for bit.
ONE_BUFFER_SAMPLES = True


def _samples_in_one_buffer(compiled: CompiledSystem, params: np.ndarray, times: np.ndarray, x: np.ndarray,
                           v: np.ndarray) -> Samples:
    """:func:`samples` by :func:`physics.codegen.mechanism_samples.mechanism_samples`: the system's specialised
    samples' solve where it has one (:meth:`CompiledSystem.samples_solve`), the same arithmetic after it."""
    from ..codegen.mechanism_samples import mechanism_samples  # noqa: PLC0415

    specialised = compiled.samples_solve()
    arrays = mechanism_samples(compiled, np.asarray(times, dtype=float), x, v, params,
                               None if specialised is None else specialised.solve)
    acceleration = arrays.full[:, compiled.theta_ddot_index]
    multipliers = arrays.full[:, compiled.multiplier_index]
    residual = np.max(np.abs(arrays.phi), axis=1, initial=0.0)
    if compiled.pose_size == 0:
        return Samples(x, v, acceleration, multipliers, residual, arrays.condition, arrays.jacobian)
    qdot = np.einsum("kij,kj->ki", arrays.pose_jacobian, v)
    qddot = np.einsum("kij,kj->ki", arrays.pose_jacobian, acceleration) + arrays.bias
    return Samples(arrays.pose, qdot, qddot, multipliers, residual, arrays.condition, arrays.jacobian)


def tree_dynamics(mechanism: Mechanism, pieces):
    """The bodies' numbers for a run in tree coordinates: the prepared DAE's, or, for a body without mass or
    inertia (a chain's point-mass bar: I = 0), the same numbers kept without the maximal DAE's refusal (they are
    read for Newton's law on each body, never inverted: physics.simulate.mechanism_route does the same)."""
    if pieces.dae_or_none is not None:
        return pieces.dae_or_none
    from .numeric_dae import MechanismDAE  # noqa: PLC0415

    return MechanismDAE(mechanism, pieces.constraints, massless_allowed=True)


def run(mechanism: Mechanism, q: np.ndarray, qdot: np.ndarray, times: np.ndarray, settings, *, driven: bool,
        pieces: Prepared | None = None, coordinates: str = "maximal", rotations: str = "relative",
        condition: str = "jacobian"):
    """A run of ``mechanism`` by ``settings`` (a :class:`physics.model.Settings`: method, integrator, back end,
    tolerances, step, step budget, stabilisation and its gains) from the assembled state ``(q, qdot)`` at
    ``times[0]``, as a :class:`physics.Trajectory`. ``driven``: the motors fix every body, so
    each sample is position analysis from the one before and only the formulation's solve is asked for (inverse
    dynamics); the integrator is not used. A failure midway comes back as the run's ``status`` and ``message``
    (a singular pose names its joints) with every sample up to it; a start that cannot be evaluated at all
    raises LinkageError, as bad input does. The run's ``condition`` and a tree formulation's ``reaction_rows`` are
    computed when first read (:func:`_on_request`). ``pieces``: the mechanism's prepared pieces
    (:mod:`physics.mechanism.prepared`) when the caller holds them. ``coordinates="tree"`` (method ``dae``
    only): the DAE integrated in the tree coordinates (:mod:`physics.mechanism.tree_dae`), its multipliers
    the run's reactions. ``rotations``: what a pin's tree coordinate is, for a run in tree coordinates
    (:data:`~physics.mechanism.parameters.ROTATIONS`: the system compiled and the state integrated; the
    samples, reactions and energies are the maximal coordinates' either way). ``condition``: ``"jacobian"``, the
    run's ``condition`` is the maximal ``Phi_q``'s at each sample (computed when read); ``"solve"``, the condition
    estimate of the formulation's own solve at each sample, which the samples' solve gives (a chain's run's
    meaning, :func:`physics.mechanism.simulate.simulate_mechanism`)."""
    from ..simulate.trajectory import Trajectory  # noqa: PLC0415
    from ..status import Status  # noqa: PLC0415
    from .prepared import prepared  # noqa: PLC0415
    from .run_table import traced_path  # noqa: PLC0415

    method, stabilization = settings.method, settings.stabilization
    pieces = prepared(mechanism) if pieces is None else pieces
    # numbers only: masses, gravity, the constraint rows' names; a run in tree coordinates never inverts the
    # bodies' masses (its tree matrix stays regular when a chain's bar has no mass or inertia, as the chain's)
    dae = tree_dynamics(mechanism, pieces) if (method != "dae" or coordinates == "tree") else pieces.dae
    constraints = dae.constraints
    if coordinates == "tree":  # the DAE's system in the tree formulations' state (physics/mechanism/tree_dae.py)
        from .tree_dae import compiled_tree_dae  # noqa: PLC0415

        compiled = compiled_tree_dae(mechanism, pieces.structure_key, rotations)
    else:
        compiled = compiled_system(mechanism, method, pieces.structure_key, rotations)
    tree = method != "dae" or coordinates == "tree"
    if tree:
        from .tree_coordinates import tree_state  # noqa: PLC0415

        def to_state(_mechanism, q_, qdot_) -> tuple[np.ndarray, np.ndarray]:
            return tree_state(_mechanism, q_, qdot_, pieces, rotations)

        weights = None
    else:
        def to_state(_mechanism, q_, qdot_) -> tuple[np.ndarray, np.ndarray]:
            return q_, qdot_

        # positions as assembly weighs steps, velocities nearest in kinetic energy
        weights = pieces.projection_weights
    params, layout = run_parameters(mechanism, compiled, float(times[0]), weights, integrating=not driven,
                                    base=pieces.parameters_at(float(times[0])))
    steps = evaluations = 0
    status, message = int(Status.OK), "ok"
    if driven:
        x, v, failure = _position_analysis(
            mechanism, compiled, layout, params, times, *to_state(mechanism, q, qdot),
            fallback=lambda x_, v_, t: _assembled_state(mechanism, to_state, _pose(compiled, params, x_, v_), t))
        if failure is not None:
            status, message = int(Status.SINGULAR), f"{mechanism.name}: {failure}"
            times = times[:x.shape[0]]
    else:
        x0, v0 = to_state(mechanism, q, qdot)
        gains = (settings.baumgarte_alpha, settings.baumgarte_beta) if stabilization == "baumgarte" else (0.0, 0.0)
        result = integrate(compiled, layout, params, x0, v0, times, settings, alpha=gains[0], beta=gains[1],
                           project=stabilization == "projection")
        steps, evaluations = result.n_steps, result.n_rhs
        filled = _finite_prefix(result.states, result.filled)
        if result.status != 0 or filled < times.size:
            code = result.status if result.status != 0 else int(Status.NOT_FINITE)
            last = result.states[filled - 1] if filled else np.concatenate([x0, v0])
            n = compiled.n
            message = _failure(mechanism, compiled, params, constraints, code, result.t_reached, last[:n], last[n:],
                               result.detail)
            if filled == 0:
                _refuse(message)
            status = code
            times = times[:filled]
        n = compiled.n
        x, v = result.states[:times.size, :n], result.states[:times.size, n:]
    solved = samples(compiled, params, times, x, v)
    bad = None if _all_good(solved) else ~(solved.kernel_condition < 1e12) | ~np.all(np.isfinite(solved.qddot), axis=1)
    if bad is not None and np.any(bad):
        first = int(np.argmax(bad))
        if not np.all(np.isfinite(solved.q[first])):
            reason = f"{mechanism.name}: {Status.describe(int(Status.NOT_FINITE), float(times[first]))}"
            code = int(Status.NOT_FINITE)
        else:
            from .singularity import singular_message  # noqa: PLC0415

            reason = f"{mechanism.name}: {singular_message(constraints, solved.q[first], float(times[first]))}"
            code = int(Status.SINGULAR)
        if first == 0:
            _refuse(reason)
        status, message = code, reason
        times, solved = times[:first], _first(solved, first)
    own_reactions = not tree or coordinates == "tree"  # the DAE's multipliers: every joint's rows
    reactions, conditions = _on_request(dae, compiled, params, times, solved, tree, own_reactions,
                                        pieces.tree_reactions if tree and not own_reactions else None)
    if condition == "solve":  # the solve's own estimate (the kernels' rule: a chain's run reports the same)
        conditions = solved.kernel_condition
    kinetic = 0.5 * np.sum(dae.mass_diagonal * solved.qdot**2, axis=1)
    potential = -np.sum(dae.gravity[1::3] * solved.q[:, 1::3], axis=1)
    points = pieces.body_points
    return Trajectory(
        t=np.asarray(times, dtype=float), q=solved.q, qdot=solved.qdot, coordinate_names=pieces.coordinate_names,
        reaction_rows=reactions, kinetic=kinetic, potential=potential, energy=kinetic + potential,
        residual=solved.residual, trace_xy=traced_path(points, mechanism.trace, solved.q), body_points=points,
        row_names=pieces.row_names, method=method, coordinates="tree" if tree else "maximal",
        stabilization=stabilization, integrated=not driven, n_steps=steps, n_rhs=evaluations,
        condition=conditions,
        integrator=POSITION_ANALYSIS if driven else settings.integrator, status=status, message=message,
    )


def _finite_prefix(states: np.ndarray, filled: int) -> int:
    """How many of the first ``filled`` rows of ``states`` are finite before the first that is not: all of them
    when their sum is finite (one pass, no (T, 2 n) mask: the rule of a chain's run), else counted row by row."""
    if math.isfinite(float(states[:filled].sum())):
        return filled
    finite = np.all(np.isfinite(states[:filled]), axis=1)
    return filled if finite.all() else int(np.argmin(finite))


def _all_good(solved: Samples) -> bool:
    """True when every sample's solve is well conditioned (kernel condition below 1e12, NaN not) and its
    accelerations finite: the test a run's samples pass, without the masks (a NaN or an infinity makes the
    maximum or the sum fail it, and the masks then find the first bad sample)."""
    condition = solved.kernel_condition
    return bool(float(condition.max(initial=0.0)) < 1e12) and math.isfinite(float(solved.qddot.sum()))


POSITION_ANALYSIS = "position analysis"  # a driven run's integrator: none, every sample closes the loops anew


# The DAE's Jacobians at the samples are kept for its condition up to this size (an app's chunk, a short run: a
# read then costs no second evaluation); a longer run's are evaluated again when its condition is read.
KEPT_JACOBIAN_BYTES = 4 << 20


def _on_request(dae, compiled, params, times, solved: Samples, tree: bool, own_reactions: bool,
                closed_form: TreeReactions | LoopReactions | None = None):
    """``(reaction_rows, condition)`` of a run, each computed when first read (:class:`OnRequest`): a tree
    formulation's reactions by Newton's second law (:func:`body_reactions`) and every sample's condition of
    ``Phi_q`` (:func:`_conditions`), from the samples the run keeps, so their bits are the ones the run computed
    before it left them to its reader. The computations keep the poses, velocities and accelerations, and the
    Jacobians only up to :data:`KEPT_JACOBIAN_BYTES` (``(T, r, n)`` floats a long run's reader may never ask for):
    the DAE's condition of a longer run evaluates the generated constraint rows again at the same times, states
    and parameters (the same bits); a tree formulation evaluates the
    maximal ``Phi_q`` when the first of its two fields is read and lets it go when the second is.
    ``own_reactions``: the run's multipliers are its reactions (the DAE, maximal or in tree coordinates).
    ``closed_form``: the mechanism's :class:`~physics.mechanism.tree_reactions.TreeReactions` (an open tree of
    pins) or :class:`~physics.mechanism.tree_reactions.LoopReactions` (pins closing loops, given the run's
    multipliers): its reactions need no Jacobian."""
    from ..simulate.trajectory import OnRequest  # noqa: PLC0415

    constraints = dae.constraints
    empty = np.zeros(0)
    kept = Samples(solved.q, solved.qdot, solved.qddot, empty, empty, empty, empty)
    if tree:
        memo: list = []

        def jacobians():
            if not memo:
                memo.append(_maximal_jacobians(constraints, kept.q))
            return memo[0]

        held = _loop_multipliers(closed_form, solved)  # a loop's cut joints' and motors' (a small array)
        reactions = solved.multipliers if own_reactions else OnRequest(lambda: body_reactions(
            dae, kept, None if closed_form is not None else jacobians(), closed_form=closed_form,
            multipliers=held))
        return reactions, OnRequest(lambda: _conditions(constraints, kept, True, jacobians()))
    held = solved.constraint_jacobian if solved.constraint_jacobian.nbytes <= KEPT_JACOBIAN_BYTES else None
    params = params.copy()  # the run's own, as its samples were solved with it

    def dae_conditions():
        jacobian = compiled.constraint_states(times, kept.q, kept.qdot, params)[0] if held is None else held
        return _conditions(constraints, Samples(kept.q, kept.qdot, kept.qddot, empty, empty, empty, jacobian),
                           False)

    return solved.multipliers, OnRequest(dae_conditions)


def _failure(mechanism, compiled, params, constraints, code: int, t_reached: float, x, v, detail: str) -> str:
    """The sentence of a run stopped at ``t_reached`` from the state ``(x, v)`` it last held: a singular pose
    names the joints whose constraints became dependent, anything else the status's own sentence."""
    from ..status import Status  # noqa: PLC0415
    from .singularity import NEAR_SINGULAR_CONDITION, singular_message  # noqa: PLC0415

    last_q = _pose(compiled, params, np.asarray(x, dtype=float), np.asarray(v, dtype=float))
    reason = Status.describe(code, t_reached, detail)
    condition = _condition(constraints, last_q)
    if np.all(np.isfinite(last_q)) and (code == int(Status.SINGULAR) or condition > NEAR_SINGULAR_CONDITION):
        return f"{mechanism.name}: {singular_message(constraints, last_q, t_reached)}; {reason}"
    return f"{mechanism.name}: {reason}"


def _refuse(message: str):
    """A start that cannot be evaluated is refused like bad input: no sample of the run exists."""
    from ..errors import LinkageError  # noqa: PLC0415

    raise LinkageError(message)


def _first(solved: Samples, count: int) -> Samples:
    """The first ``count`` samples."""
    return Samples(*(getattr(solved, name)[:count] for name in Samples.__dataclass_fields__))


# Position analysis row by row through project_states (one native call per sample, as before the one-call
# sequence): False keeps that loop, for the tests that compare the two bit for bit.
ONE_CALL = True


def _position_analysis(mechanism, compiled, layout, params, times, x0, v0, fallback):
    """Every sample of a mechanism its motors fully determine, by position and velocity analysis on the
    formulation's own constraints: from the last sample moved on by its velocity, Gauss-Newton onto
    ``phi(x, t) = 0`` and the velocity that keeps it there (the kernels' projection generated as IR,
    :mod:`physics.codegen.native_states`), every sample in one native call (:data:`ONE_CALL`, a few microseconds
    per sample and no numba) that stops where Newton has not closed the loops: that sample is assembled again in
    Python (``fallback``) and the call goes on from the next. Returns ``(x, v, None)``, or the samples up to
    where no pose closes the loops and the reason."""
    from ..errors import LinkageError  # noqa: PLC0415
    from ..kernels.constants import PROJECTION_TOLERANCE  # noqa: PLC0415

    times = np.ascontiguousarray(times, dtype=float)
    xs, vs = np.empty((times.size, np.size(x0))), np.empty((times.size, np.size(v0)))
    xs[0], vs[0] = x0, v0
    scale = max(1.0, float(np.max(np.abs(x0))))
    tolerance = 100.0 * PROJECTION_TOLERANCE * scale
    if not ONE_CALL:
        return _row_by_row(layout, params, times, xs, vs, tolerance, fallback)
    from ..codegen.native_states import driven_sequence  # noqa: PLC0415

    k = 1
    while True:
        k = driven_sequence(layout, times, xs, vs, params, k, tolerance)
        if k >= times.size:
            return xs, vs, None
        try:  # Newton did not close row k: assembled from row k - 1 (the native call's attempt replaced)
            xs[k], vs[k] = fallback(xs[k - 1], vs[k - 1], float(times[k]))
        except LinkageError as error:  # the motors drive it where its loops cannot close: the run ends here
            return xs[:k], vs[:k], f"at t = {float(times[k]):.6g} s: {error}"
        k += 1


def _row_by_row(layout, params, times, xs, vs, tolerance, fallback):
    """:func:`_position_analysis` as it was before the one-call sequence: a :func:`project_states` call per
    sample, the prediction and the test in Python (the reference the sequence is held to, bit for bit)."""
    from ..codegen.native_states import project_states  # noqa: PLC0415
    from ..errors import LinkageError  # noqa: PLC0415

    theta, omega = np.empty((1, xs.shape[1])), np.empty((1, vs.shape[1]))  # the kernel's row, filled anew each time
    for k in range(1, times.size):  # each sample starts from the one before: a loop, the kernel does the work
        np.multiply(vs[k - 1], times[k] - times[k - 1], out=theta[0])
        np.add(xs[k - 1], theta[0], out=theta[0])  # the last sample moved on by its velocity
        omega[0] = vs[k - 1]
        left = project_states(layout, times[k : k + 1], theta, omega, params)
        if not left < tolerance or not np.isfinite(theta).all():
            try:
                theta[0], omega[0] = fallback(xs[k - 1], vs[k - 1], float(times[k]))
            except LinkageError as error:  # the motors drive it where its loops cannot close: the run ends here
                return xs[:k], vs[:k], f"at t = {float(times[k]):.6g} s: {error}"
        xs[k], vs[k] = theta[0], omega[0]
    return xs, vs, None


def _pose(compiled, params, x, v) -> np.ndarray:
    """Every body's pose (x, y, phi) of the formulation's coordinates ``x``."""
    if compiled.pose_size == 0:
        return np.asarray(x, dtype=float)
    return compiled.kinematics_states(x[None, :], v[None, :], params)[1][0]


def _assembled_state(mechanism, to_state, previous_q, t):
    """A driven sample assembled in Python from the previous pose (the fallback of position analysis)."""
    from .assembly import assemble, kinematics  # noqa: PLC0415

    q = assemble(mechanism, previous_q, t).q
    return to_state(mechanism, q, kinematics(mechanism, q)[0])


def instant(mechanism: Mechanism, method: str, q: np.ndarray, qdot: np.ndarray, t: float = 0.0,
            rotations: str = "relative"):
    """``(qddot, reactions)`` of ``method`` at one assembled state: its own solve, and for a tree formulation
    (its pins' coordinates by ``rotations``) every body's accelerations from its own and the reactions by
    Newton's second law on them."""
    from .prepared import prepared  # noqa: PLC0415

    pieces = prepared(mechanism)
    compiled = compiled_system(mechanism, method, pieces.structure_key, rotations)
    params = pieces.parameters_at(t)
    if method == "dae":
        x, v = np.asarray(q, dtype=float), np.asarray(qdot, dtype=float)
    else:
        from .tree_coordinates import tree_state  # noqa: PLC0415

        x, v = tree_state(mechanism, np.asarray(q, dtype=float), np.asarray(qdot, dtype=float), pieces, rotations)
    solved = samples(compiled, params, np.array([float(t)]), x[None, :], v[None, :])
    reactions = (solved.multipliers if method == "dae"
                 else body_reactions(pieces.dae, solved, closed_form=pieces.tree_reactions,
                                     multipliers=_loop_multipliers(pieces.tree_reactions, solved)))
    return solved.qddot[0], reactions[0]


def _loop_multipliers(closed_form, solved: Samples) -> np.ndarray | None:
    """A tree formulation's own multipliers (its cut joints' and speed motors' rows) for a loop's closed form
    (:class:`~physics.mechanism.tree_reactions.LoopReactions`), None for anything else."""
    from .tree_reactions import LoopReactions  # noqa: PLC0415

    return solved.multipliers if isinstance(closed_form, LoopReactions) else None


def _maximal_jacobians(constraints, q: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """``(finite, jacobians)``: which poses of ``q (T, 3 B)`` are finite, and the maximal coordinates' ``Phi_q``
    at those (one batched evaluation, None when there is none): a tree formulation's run needs it twice, for
    its conditions and its reactions."""
    finite = np.all(np.isfinite(q), axis=1)
    return finite, (constraints.jacobian(q[finite]) if np.any(finite) else None)


def _conditions(constraints, solved: Samples, tree: bool,
                jacobians: tuple[np.ndarray, np.ndarray | None] | None = None) -> np.ndarray:
    """Every sample's condition of the constraint Jacobian ``Phi_q`` (physics/mechanism/singularity.py), one
    batched SVD: for the DAE of the Jacobians its samples already hold, for tree coordinates of the maximal
    coordinates' ``Phi_q`` at every sample's pose (``jacobians``: :func:`_maximal_jacobians` of the samples, when
    the caller holds it); infinite where a pose is not finite."""
    if tree:
        finite, jacobian_at = _maximal_jacobians(constraints, solved.q) if jacobians is None else jacobians
        out = np.full(len(solved.q), np.inf)
        if jacobian_at is not None:
            out[finite] = _singular_value_ratio(jacobian_at)
        return out
    jacobian = solved.constraint_jacobian
    if jacobian.shape[1] == 0:
        return np.ones(jacobian.shape[0])
    if not np.all(np.isfinite(jacobian)):
        return np.array([_condition(constraints, pose) for pose in solved.q])
    return _singular_value_ratio(jacobian)


def _singular_value_ratio(jacobian: np.ndarray) -> np.ndarray:
    """Largest over smallest singular value of each (rows, columns) matrix of ``jacobian`` (T, rows, columns),
    as :func:`~physics.mechanism.singularity.jacobian_condition` gives it for one: 1 without rows, infinite
    with more rows than columns or a zero singular value."""
    if jacobian.shape[1] == 0:
        return np.ones(jacobian.shape[0])
    if jacobian.shape[1] > jacobian.shape[2]:
        return np.full(jacobian.shape[0], np.inf)
    singular = np.linalg.svd(jacobian, compute_uv=False)
    smallest = singular[:, -1]
    with np.errstate(divide="ignore"):
        return np.where(smallest > 0, singular[:, 0] / np.where(smallest > 0, smallest, 1.0), np.inf)


def _condition(constraints, q: np.ndarray) -> float:
    """The constraint Jacobian's condition at ``q``; infinite for a pose that is not finite (a run that blew up)."""
    from .singularity import jacobian_condition  # noqa: PLC0415

    if not np.all(np.isfinite(q)):
        return float("inf")
    return jacobian_condition(constraints, q)


# A sample whose Phi_q^T is this near losing rank (smallest over largest |R_ii| of its QR factor) is solved by
# np.linalg.lstsq on its own (its minimum-norm answer), not by the batched triangular solve.
_QR_RANK_RATIO = 1e-10


def body_reactions(dae, solved: Samples, jacobians: tuple[np.ndarray, np.ndarray | None] | None = None, *,
                   closed_form: TreeReactions | LoopReactions | None = None,
                   multipliers: np.ndarray | None = None) -> np.ndarray:
    """A tree formulation's reactions of every joint row, from its own accelerations by Newton's second law on
    every body: ``Phi_q^T lambda = M qddot - Q`` (consistent, so solved exactly in the least-squares sense).
    Every sample at once: ``Phi_q`` and ``Q`` by batched evaluations (``jacobians``: :func:`_maximal_jacobians`
    of the samples' poses, when the caller holds it), then one batched QR of ``Phi_q^T`` and a triangular solve;
    a sample near losing rank, or not finite, by ``lstsq`` on its own as before. ``closed_form``: the
    mechanism's :class:`~physics.mechanism.tree_reactions.TreeReactions` when it is an open tree of pins, its
    :class:`~physics.mechanism.tree_reactions.LoopReactions` when its pins close loops
    (:attr:`~physics.mechanism.prepared.Prepared.tree_reactions`): the same system solved from the leaves to the
    root (a loop's cut pins and motors from a small system first), no Jacobian and no QR, except for a loop's
    sample near a dead centre (its NaN rows: the QR as before). It assumes the accelerations consistent with the
    joints, as a run's are; without it an inconsistent ``qddot`` gets the least-squares answer. ``multipliers``
    (a loop's closed form only): the tree formulation's own multipliers at the samples, its cut joints' and
    speed motors' reactions, so only the tree pins' rows are computed."""
    count = len(solved.q)
    rows = len(dae.constraints.rows)
    if count == 0 or rows == 0:
        return np.zeros((count, rows))
    held = {} if multipliers is None else {"multipliers": multipliers}
    answer = None
    if closed_form is not None and math.isfinite(float(solved.q.sum() + solved.qdot.sum() + solved.qddot.sum())):
        # every sample finite (a finite sum says so without the masks), as a run's are: no copies
        answer = closed_form.solve(dae.mass_diagonal, dae.applied(solved.qdot, solved.q), solved.q, solved.qddot,
                                   **held)
        if not np.isnan(answer).any():  # an open tree's always; a loop's unless near a dead centre
            return answer
    finite = np.all(np.isfinite(solved.q) & np.isfinite(solved.qdot) & np.isfinite(solved.qddot), axis=1)
    out = np.empty((count, rows))
    alone = ~finite
    if closed_form is not None:
        if finite.all():  # a run's samples are: no copies
            out = answer if answer is not None else closed_form.solve(
                dae.mass_diagonal, dae.applied(solved.qdot, solved.q), solved.q, solved.qddot, **held)
            if not np.isnan(out).any():  # an open tree's always; a loop's unless near a dead centre
                return out
        elif np.any(finite):
            q, qdot, qddot = solved.q[finite], solved.qdot[finite], solved.qddot[finite]
            held = {} if multipliers is None else {"multipliers": multipliers[finite]}
            out[finite] = closed_form.solve(dae.mass_diagonal, dae.applied(qdot, q), q, qddot, **held)
        # a loop's sample near a dead centre comes back NaN (tree_reactions.LoopReactions): the QR answers it
        finite &= np.isnan(out).any(axis=1)
    if np.any(finite) and rows <= dae.constraints.size:
        q, qdot, qddot = solved.q[finite], solved.qdot[finite], solved.qddot[finite]
        if jacobians is None or jacobians[1] is None:
            jacobian = dae.constraints.jacobian(q)
        else:  # the poses' Jacobians, of the samples whose velocities and accelerations are finite too
            jacobian = jacobians[1][finite[jacobians[0]]]
        transposed = np.swapaxes(jacobian, 1, 2)  # (T, 3 B, rows)
        imbalance = dae.mass_diagonal * qddot - dae.applied(qdot, q)
        orthogonal, triangle = np.linalg.qr(transposed)
        diagonal = np.abs(np.diagonal(triangle, axis1=1, axis2=2))
        full_rank = diagonal.min(axis=1) > _QR_RANK_RATIO * diagonal.max(axis=1)
        projected = np.einsum("tnr,tn->tr", orthogonal[full_rank], imbalance[full_rank])
        where = np.flatnonzero(finite)
        out[where[full_rank]] = np.linalg.solve(triangle[full_rank], projected[..., None])[..., 0]
        alone[where[~full_rank]] = True
    elif closed_form is not None:
        alone |= finite  # the closed form's NaN rows
    else:
        alone[:] = True
    for k in np.flatnonzero(alone):
        jacobian = dae.constraints.jacobian(solved.q[k])
        imbalance_k = dae.mass_diagonal * solved.qddot[k] - dae.applied(solved.qdot[k], solved.q[k])
        out[k] = np.linalg.lstsq(jacobian.T, imbalance_k, rcond=None)[0]
    return out

