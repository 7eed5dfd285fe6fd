"""Any mechanism on the one compiled engine: generated code per *structure*, its numbers a parameter vector.

A mechanism's formulation (:mod:`physics.mechanism.symbolic`) is derived once per structure and method, written
as LLVM IR by :mod:`physics.codegen.emit` and kept in the authenticated cache folder exactly as a chain's is
(:func:`physics.codegen.cache.load_generated`); masses, inertias, points, motor speeds and torques, damping and
g reach it as the parameter vector of :mod:`physics.mechanism.parameters`, so editing any of them derives and
compiles nothing. The once-compiled kernels of :mod:`physics.kernels` integrate it (DOP853 or RK45 with dense
output, Baumgarte terms and projection onto the constraints written once for every system), and every sample's
pose, velocities, accelerations and reactions come out of batched kernel calls.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..codegen.cache import CompiledSystem, load_generated
from ..kernels.abi import LAYOUT_WEIGHTS
from .model import Mechanism
from .parameters import parameter_vector, structure, structure_key

ENGINE_METHODS = ("dae", "lagrange", "newton_euler")


def compiled_system(mechanism: Mechanism, method: str) -> CompiledSystem:
    """The generated system of ``method`` for ``mechanism``'s structure: from memory, from the cache folder, or
    derived (sympy, only on a miss) and cached."""
    shape = structure(mechanism)
    key = _cache_key(mechanism, method)

    def derive():
        from .symbolic import derive_structure  # noqa: PLC0415  (sympy only on a cache miss)

        return derive_structure(shape, method), (f"a mechanism of {shape.bodies} bodies and "
                                                 f"{len(shape.joints)} joints, structure {structure_key(mechanism)}")

    return load_generated(key, method, derive)


def is_compiled(mechanism: Mechanism, method: str) -> bool:
    """True when ``method``'s generated system for this structure is loaded or cached (no sympy needed)."""
    from ..codegen.cache import is_generated_key  # noqa: PLC0415

    return is_generated_key(_cache_key(mechanism, method))


def _cache_key(mechanism: Mechanism, method: str) -> str:
    """The generated system's name in the cache: its method and its structure, never its numbers."""
    return f"{method.replace('_', '')}-mechanism-{structure_key(mechanism)}"


@dataclass(frozen=True)
class Integration:
    """What the kernels return: states ``(T, 2 n)`` at the sample times (NaN past a failure), the kernel's
    condition estimate, the status and the counts."""

    states: np.ndarray
    condition: np.ndarray
    status: int
    steps: int
    evaluations: int
    t_reached: float
    filled: int


def run_parameters(mechanism: Mechanism, compiled: CompiledSystem, t_start: float, weights: np.ndarray | None):
    """The parameter vector of a run, and the layout to pass with it: when ``weights`` (2 n: positions, then
    velocities) are given, they are appended to the vector and the layout says where."""
    params = parameter_vector(mechanism, t=t_start)
    layout = compiled.layout
    if weights is not None:
        layout = layout.copy()
        layout[LAYOUT_WEIGHTS] = params.size
        params = np.concatenate([params, weights])
    return np.ascontiguousarray(params), layout


def integrate(compiled: CompiledSystem, layout: np.ndarray, params: np.ndarray, x0: np.ndarray, v0: np.ndarray,
              times: np.ndarray, *, integrator: str, rtol: float, atol: float, alpha: float, beta: float,
              project: bool, max_steps: int = 5_000_000) -> Integration:
    """Integrate from ``times[0]`` to ``times[-1]`` with samples at ``times``."""
    from ..kernels import explicit_rk  # noqa: PLC0415  (numba's cached machine code, loaded on first use)

    kernel = {"DOP853": explicit_rk.integrate_dop853, "RK45": explicit_rk.integrate_rk45}[integrator]
    y0 = np.ascontiguousarray(np.concatenate([x0, v0]), dtype=float)
    t_eval = np.ascontiguousarray(times, dtype=float)
    y_out = np.empty((t_eval.size, y0.size))
    cond_out = np.empty(t_eval.size)
    status, steps, evaluations, t_reached, filled = kernel(
        compiled.assemble_function, layout, y0, float(t_eval[0]), float(t_eval[-1]), t_eval, params, rtol, atol,
        alpha, beta, project, max_steps, y_out, cond_out)
    return Integration(y_out, cond_out, int(status), int(steps), int(evaluations), float(t_reached), int(filled))


@dataclass(frozen=True)
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
    body's pose: the identity for the DAE, the generated kinematics for tree coordinates."""
    full, condition = compiled.solve_full_batch(x, v, params)
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


def run(mechanism: Mechanism, method: str, q: np.ndarray, qdot: np.ndarray, times: np.ndarray, *,
        stabilization: str, rtol: float, atol: float, driven: bool, integrator: str = "DOP853"):
    """A run of ``mechanism`` by ``method`` from the assembled state ``(q, qdot)`` at ``times[0]``, as a
    :class:`~physics.mechanism.run.MechanismRun`. ``driven``: the motors fix every body, so each sample is
    position analysis from the one before and only the formulation's solve is asked for (inverse dynamics).
    A failure midway raises LinkageError naming where and why (a singular pose names its joints)."""
    from ..errors import LinkageError  # noqa: PLC0415
    from ..model import BAUMGARTE_ALPHA, BAUMGARTE_BETA  # noqa: PLC0415
    from ..status import Status  # noqa: PLC0415
    from .assembly import sketch_size  # noqa: PLC0415
    from .dae import MechanismDAE  # noqa: PLC0415
    from .run import MechanismRun  # noqa: PLC0415
    from .singularity import NEAR_SINGULAR_CONDITION, singular_message  # noqa: PLC0415

    dae = MechanismDAE(mechanism)  # numbers only: masses, gravity, the constraint rows' names
    constraints = dae.constraints
    compiled = compiled_system(mechanism, method)
    tree = method != "dae"
    if tree:
        from .tree_coordinates import tree_state  # noqa: PLC0415

        to_state = tree_state
        weights = None
    else:
        def to_state(_mechanism, q_, qdot_):
            return q_, qdot_

        scale = sketch_size(mechanism)
        positions = np.tile([1.0, 1.0, 1.0 / scale**2], len(mechanism.bodies))  # as assembly weighs steps
        weights = np.concatenate([positions, 1.0 / dae.mass_diagonal])  # velocities: nearest in kinetic energy
    params, layout = run_parameters(mechanism, compiled, float(times[0]), weights)
    steps = evaluations = 0
    if driven:
        x, v = _position_analysis(mechanism, compiled, layout, params, times, *to_state(mechanism, q, qdot),
                                  fallback=lambda x_, v_, t: _assembled_state(mechanism, to_state,
                                                                              _pose(compiled, params, x_, v_), t))
    else:
        x0, v0 = to_state(mechanism, q, qdot)
        gains = (BAUMGARTE_ALPHA, BAUMGARTE_BETA) if stabilization == "baumgarte" else (0.0, 0.0)
        result = integrate(compiled, layout, params, x0, v0, times, integrator=integrator, rtol=rtol, atol=atol,
                           alpha=gains[0], beta=gains[1], project=stabilization == "projection")
        steps, evaluations = result.steps, result.evaluations
        if result.status != 0 or result.filled < times.size:
            n = compiled.n
            last = result.states[result.filled - 1] if result.filled else np.concatenate([x0, v0])
            last_q = samples(compiled, params, np.array([result.t_reached]), last[None, :n], last[None, n:]).q[0]
            condition = _condition(constraints, last_q)
            reason = Status.describe(result.status, result.t_reached) if result.status != 0 else "stopped early"
            if np.all(np.isfinite(last_q)) and (result.status == int(Status.SINGULAR)
                                                or condition > NEAR_SINGULAR_CONDITION):
                raise LinkageError(f"{mechanism.name}: {singular_message(constraints, last_q, result.t_reached)}; "
                                   f"{reason}")
            raise LinkageError(f"{mechanism.name}: {reason}")
        n = compiled.n
        x, v = result.states[:, :n], result.states[:, n:]
    solved = samples(compiled, params, times, x, v)
    if not np.all(solved.kernel_condition < 1e12) or not np.all(np.isfinite(solved.qddot)):
        bad = int(np.argmax(~(solved.kernel_condition < 1e12) | ~np.all(np.isfinite(solved.qddot), axis=1)))
        if not np.all(np.isfinite(solved.q[bad])):
            raise LinkageError(f"{mechanism.name}: {Status.describe(int(Status.NOT_FINITE), float(times[bad]))}")
        raise LinkageError(f"{mechanism.name}: {singular_message(constraints, solved.q[bad], float(times[bad]))}")
    reactions = solved.multipliers if not tree else body_reactions(dae, solved)
    kinetic = 0.5 * np.sum(dae.mass_diagonal * solved.qdot**2, axis=1)
    potential = -np.sum(dae.gravity[1::3] * solved.q[:, 1::3], axis=1)
    return MechanismRun(
        t=np.asarray(times, dtype=float), q=solved.q, qdot=solved.qdot, reactions=reactions, kinetic=kinetic,
        potential=potential, residual=solved.residual, trace_xy=_trace(mechanism, constraints, solved.q),
        row_names=tuple(f"{row.joint}: {row.meaning}" for row in constraints.rows), method=method,
        stabilization=stabilization, integrated=not driven, steps=steps, evaluations=evaluations,
        condition=_conditions(constraints, solved, tree),
    )


def _position_analysis(mechanism, compiled, layout, params, times, x0, v0, fallback):
    """Every sample of a mechanism its motors fully determine, by position and velocity analysis on the
    formulation's own constraints: from the last sample moved on by its velocity, Gauss-Newton onto
    ``phi(x, t) = 0`` and the velocity that keeps it there (the kernels' projection, a few microseconds per
    sample). Where Newton has not closed the loops, the sample is assembled again in Python (``fallback``)."""
    from ..kernels.constants import PROJECTION_TOLERANCE  # noqa: PLC0415
    from ..kernels.projection import project_states  # noqa: PLC0415

    xs, vs = [np.array(x0, dtype=float)], [np.array(v0, dtype=float)]
    scale = max(1.0, float(np.max(np.abs(x0))))
    for t_previous, t in zip(times[:-1], times[1:]):
        theta = (xs[-1] + vs[-1] * (t - t_previous))[None, :]
        omega = vs[-1].copy()[None, :]
        left = project_states(compiled.assemble_function, layout, np.array([float(t)]), theta, omega, params)
        if not left < 100.0 * PROJECTION_TOLERANCE * scale or not np.all(np.isfinite(theta)):
            theta[0], omega[0] = fallback(xs[-1], vs[-1], float(t))
        xs.append(theta[0])
        vs.append(omega[0])
    return np.array(xs), np.array(vs)


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


def instant(mechanism: Mechanism, method: str, q: np.ndarray, qdot: np.ndarray, t: float = 0.0):
    """``(qddot, reactions)`` of ``method`` at one assembled state: its own solve, and for a tree formulation
    every body's accelerations from its own and the reactions by Newton's second law on them."""
    from .dae import MechanismDAE  # noqa: PLC0415

    compiled = compiled_system(mechanism, method)
    params = parameter_vector(mechanism, t=t)
    if method == "dae":
        x, v = np.asarray(q, dtype=float), np.asarray(qdot, dtype=float)
    else:
        from .tree_coordinates import tree_state  # noqa: PLC0415

        x, v = tree_state(mechanism, np.asarray(q, dtype=float), np.asarray(qdot, dtype=float))
    solved = samples(compiled, params, np.array([float(t)]), x[None, :], v[None, :])
    reactions = solved.multipliers if method == "dae" else body_reactions(MechanismDAE(mechanism), solved)
    return solved.qddot[0], reactions[0]


def _conditions(constraints, solved: Samples, tree: bool) -> np.ndarray:
    """Every sample's condition of the constraint Jacobian ``Phi_q`` (physics/mechanism/singularity.py): for the
    DAE from the Jacobians its samples already hold (one batched SVD), for tree coordinates per sample."""
    if tree:
        return np.array([_condition(constraints, pose) for pose in solved.q])
    jacobian = solved.constraint_jacobian
    if jacobian.shape[1] == 0:
        return np.ones(jacobian.shape[0])
    if not np.all(np.isfinite(jacobian)):
        return np.array([_condition(constraints, pose) for pose in solved.q])
    singular = np.linalg.svd(jacobian, compute_uv=False)
    if jacobian.shape[1] > jacobian.shape[2]:
        return np.full(jacobian.shape[0], np.inf)
    smallest = singular[:, -1]
    with np.errstate(divide="ignore"):
        return np.where(smallest > 0, singular[:, 0] / np.where(smallest > 0, smallest, 1.0), np.inf)


def _condition(constraints, q: np.ndarray) -> float:
    """The constraint Jacobian's condition at ``q``; infinite for a pose that is not finite (a run that blew up)."""
    from .singularity import jacobian_condition  # noqa: PLC0415

    if not np.all(np.isfinite(q)):
        return float("inf")
    return jacobian_condition(constraints, q)


def body_reactions(dae, solved: Samples) -> np.ndarray:
    """A tree formulation's reactions of every joint row, from its own accelerations by Newton's second law on
    every body: ``Phi_q^T lambda = M qddot - Q`` (consistent, so solved exactly in the least-squares sense)."""
    out = []
    for q, qdot, qddot in zip(solved.q, solved.qdot, solved.qddot):
        jacobian = dae.constraints.jacobian(q)
        imbalance = dae.mass_diagonal * qddot - dae.applied(qdot, q)
        out.append(np.linalg.lstsq(jacobian.T, imbalance, rcond=None)[0])
    return np.array(out).reshape(len(solved.q), -1)


def _trace(mechanism: Mechanism, constraints, q: np.ndarray) -> np.ndarray:
    """The traced point at every sample (NaN when the mechanism traces none)."""
    if mechanism.trace is None:
        return np.full((q.shape[0], 2), np.nan)
    body, _, point = mechanism.trace.partition(".")
    names = [b.name for b in mechanism.bodies]
    if body not in names:
        return np.full((q.shape[0], 2), np.nan)
    k = names.index(body)
    return np.array([constraints.body_point(pose, k, mechanism.body(body).points[point]) for pose in q])
