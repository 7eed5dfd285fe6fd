"""A mechanism run's samples' native calls in one buffer: the formulation's solve at every sample, its held
constraints and (tree coordinates) its kinematics, each the function :class:`~physics.codegen.cache.
CompiledSystem` calls one at a time (:meth:`~physics.codegen.cache.CompiledSystem.solve_samples`,
:meth:`~physics.codegen.cache.CompiledSystem.constraint_states`, :meth:`~physics.codegen.cache.CompiledSystem.
kinematics_states`), called with the same arguments, so the same bits.

Why: each of those calls checks and looks up the address of every array it hands over (about 2.5 us an
address, seven a call), so the three cost about 0.1 ms for seed case C's 200 samples before any sample is
computed, a fifth of the chain engine's whole run (issue 24: the chain run as a mechanism must not be slower).
Here the inputs are copied into one array (a copy of a few kB costs far less than an address), every output is a
view of it, and one address is looked up per call. The solve is the system's specialised one where
:meth:`~physics.codegen.cache.CompiledSystem.samples_solve` gives it (its bits are the generic one's:
``tests/physics/test_specialised_ir.py``). A system without held constraints (an open tree in tree
coordinates) has no constraint call at all: its rows are empty, as the call would leave them.
"""

from __future__ import annotations

import numpy as np

from ..kernels.layout import LAYOUT_CONSTRAINTS, LAYOUT_COORDINATES, LAYOUT_UNKNOWNS
from .ir_shapes import samples_scratch_length
from .mechanism_observables import observables_function, scratch_length
from .native_integrators import layout_address


class MechanismSamples:
    """The arrays of one call of :func:`mechanism_samples`, views of one buffer: ``full (T, k)`` and
    ``condition (T,)`` of the solve, ``jacobian (T, r, n)``, ``phi (T, r)`` and ``phi_dot (T, r)`` of the held
    constraints, and for tree coordinates ``pose_jacobian (T, 3 B, n)``, ``pose (T, 3 B)`` and ``bias (T, 3 B)``
    of the kinematics (``(T, 0, n)`` and ``(T, 0)`` without)."""

    __slots__ = ("full", "condition", "jacobian", "phi", "phi_dot", "pose_jacobian", "pose", "bias", "matrices",
                 "points", "velocities", "energies", "reactions")
    full: np.ndarray
    condition: np.ndarray
    jacobian: np.ndarray
    phi: np.ndarray
    phi_dot: np.ndarray
    pose_jacobian: np.ndarray
    pose: np.ndarray
    bias: np.ndarray
    matrices: np.ndarray  # (T, k, k): the solved matrices without Baumgarte terms when asked for, else (0, k, k)
    # with an ObservablesPlan (physics.codegen.mechanism_observables): its points and their velocities (T, P, 2),
    # energies (3, T) (kinetic, potential, total) and reaction rows (T, R)
    points: np.ndarray
    velocities: np.ndarray
    energies: np.ndarray
    reactions: np.ndarray


_generic: list = []  # [solve_states, native_states, assemble_states], once per process


def _functions():
    """The generic ctypes functions ``solve_states`` and ``native_states`` (compiled or loaded once)."""
    if not _generic:
        from .native_samples import _function as samples_function  # noqa: PLC0415
        from .native_states import _function as states_function  # noqa: PLC0415

        _generic[:] = [samples_function("solve_states"), states_function("native_states"),
                       samples_function("assemble_states")]
    return _generic[0], _generic[1]


def generic_solve():
    """The generic ctypes function ``solve_states`` (compiled or loaded once)."""
    return _functions()[0]


def mechanism_samples(compiled, times: np.ndarray, x: np.ndarray, v: np.ndarray, params: np.ndarray,
                      solve=None, *, alpha: float = 0.0, beta: float = 0.0, constraints: bool = True,
                      kinematics: bool = True, matrices: bool = False, observables=None,
                      g: float = 0.0) -> MechanismSamples:
    """Every sample's solve, held constraints and kinematics of ``compiled`` (a mechanism's
    :class:`~physics.codegen.cache.CompiledSystem`) at the states ``x``, ``v`` (T, n), times ``times`` (T,) and
    parameters ``params``, as its ``solve_samples``, ``constraint_states`` and ``kinematics_states`` give them
    (the solve with the Baumgarte gains ``alpha``, ``beta``, none by default). ``solve``: a ctypes function of
    ``solve_states``' signature (the system's specialised one), default the generic one. ``constraints=False``:
    the held constraints are not evaluated (their arrays are left unset: a caller that reads only the solve
    and the poses, the chain's run on the mechanism engine); ``kinematics=False`` likewise the kinematics (a
    reader of the solve alone: the poses are zeros). ``matrices``: also every sample's matrix ``A``
    as :meth:`~physics.codegen.cache.CompiledSystem.sample_matrices` gives it (a pinned chain's condition
    number is that matrix's). ``observables``: an :class:`~physics.codegen.mechanism_observables.ObservablesPlan`
    whose points, energies (under gravity ``g``) and reaction rows are computed from the solve and the poses in
    the same buffer (:mod:`physics.codegen.mechanism_observables_ir`); it needs ``kinematics`` for a tree
    formulation's reactions."""
    solve_generic, states = _functions()
    solve = solve_generic if solve is None else solve
    layout = compiled.layout
    n, k, r = int(layout[LAYOUT_COORDINATES]), int(layout[LAYOUT_UNKNOWNS]), int(layout[LAYOUT_CONSTRAINTS])
    rows = int(x.shape[0])
    if x.shape != (rows, n) or v.shape != (rows, n) or np.shape(times) != (rows,):
        raise ValueError(f"expected states ({rows}, {n}) and times ({rows},)")
    size = compiled.pose_size if kinematics else 0
    pose_width = compiled.pose_vector_size if kinematics else 0  # [pose, bias, cos, sin] of every body
    p = params.shape[0]
    # [x, v, times, zeros (the kinematics' times), params (the solve's), params (the constraints' copy: the
    # time slot is written), params (the kinematics' copy), scratch, full, condition, J, phi|phi_dot, dpose,
    # pose|bias]
    at_x = 0
    at_v = at_x + rows * n
    at_t = at_v + rows * n
    at_zero = at_t + rows
    at_params = at_zero + rows
    at_params_c = at_params + p
    at_params_k = at_params_c + p
    at_scratch = at_params_k + p
    at_full = at_scratch + samples_scratch_length(n, k, r)
    at_cond = at_full + rows * k
    at_jac = at_cond + rows
    at_vec = at_jac + rows * r * n
    at_pjac = at_vec + rows * 2 * r
    at_pvec = at_pjac + rows * size * n
    at_matrices = at_pvec + rows * pose_width
    at_rhs = at_matrices + rows * k * k * matrices
    at_points = at_rhs + rows * k * matrices
    plan = observables
    if plan is not None and (plan.n != n or plan.unknowns != k or (plan.mode and not size)):
        raise ValueError("the observables' plan does not fit this system (or needs its kinematics)")
    count, reactions = (plan.count, plan.reactions) if plan is not None else (0, 0)
    at_velocities = at_points + rows * 2 * count
    at_energies = at_velocities + rows * 2 * count
    at_reactions = at_energies + rows * 3 * (plan is not None)
    at_observe = at_reactions + rows * reactions
    length = at_observe + (scratch_length(plan.bodies) if plan is not None else 0)
    values = np.empty(length)
    values[at_x:at_v] = x.reshape(-1)
    values[at_v:at_t] = v.reshape(-1)
    values[at_t:at_zero] = times
    values[at_zero:at_params] = 0.0
    values[at_params:at_params_c] = params
    values[at_params_c:at_params_k] = params
    values[at_params_k:at_scratch] = params
    base = values.ctypes.data
    address = layout_address(layout)
    solve(int(compiled.assemble_function), address, rows, base + 8 * at_x, base + 8 * at_v, base + 8 * at_params,
          float(alpha), float(beta), base + 8 * at_full, base + 8 * at_cond, base + 8 * at_scratch)
    out = MechanismSamples()
    out.full = values[at_full:at_cond].reshape(rows, k)
    out.condition = values[at_cond:at_jac]
    out.jacobian, out.phi, out.phi_dot = _states_into(
        values, states, int(compiled._native("constraints")) if r and constraints else None, address,
        (rows, r, n), (at_t, at_x, at_v, at_params_c), at_jac, 2 * r)
    out.pose_jacobian, out.pose, out.bias = _states_into(
        values, states, int(compiled._native("kinematics")) if size and kinematics else None, address,
        (rows, size, n), (at_zero, at_x, at_v, at_params_k), at_pjac, pose_width)
    out.matrices = values[at_matrices:at_rhs].reshape(rows * matrices, k, k)
    if matrices and rows:
        _assemble_function()(int(compiled.assemble_function), address, rows, base + 8 * at_x, base + 8 * at_v,
                             base + 8 * at_params, base + 8 * at_matrices, base + 8 * at_rhs)
    if plan is not None:
        shape, indices, constants = plan.addresses
        observables_function()(shape, indices, constants, rows, plan.mode, float(g), base + 8 * at_x,
                               base + 8 * at_v, n, base + 8 * at_full, base + 8 * at_pjac, base + 8 * at_pvec,
                               base + 8 * at_observe, base + 8 * at_points, base + 8 * at_velocities,
                               base + 8 * at_energies, base + 8 * at_reactions)
        out.points = values[at_points:at_velocities].reshape(rows, count, 2)
        out.velocities = values[at_velocities:at_energies].reshape(rows, count, 2)
        out.energies = values[at_energies:at_reactions].reshape(3, rows)
        out.reactions = values[at_reactions:at_observe].reshape(rows, reactions)
    return out


def _states_into(values: np.ndarray, states, native: int | None, address: int, shape: tuple[int, int, int],
                 inputs: tuple[int, int, int, int], at_jacobian: int,
                 vector_width: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One ``native_states`` call (the held constraints' or the kinematics') into ``values``: its Jacobian
    ``(T, w, n)`` at ``at_jacobian``, then its vector ``(T, vector_width)`` (``shape``: ``(T, w, n)``), whose
    first ``2 w`` entries are the value and the rate (the kinematics' adds each body's cosine and sine), from the
    times, ``x``, ``v`` and parameters at the offsets ``inputs``; the views ``(jacobian, value, rate)``, left
    unset when ``native`` is None (not asked for, or no rows)."""
    rows, width, n = shape
    at_vector = at_jacobian + rows * width * n
    jacobian = values[at_jacobian:at_vector].reshape(rows, width, n)
    vector = values[at_vector:at_vector + rows * vector_width].reshape(rows, vector_width)
    if native is not None:
        base = values.ctypes.data
        at_t, at_x, at_v, at_params = inputs
        states(native, address, rows, base + 8 * at_t, base + 8 * at_x, base + 8 * at_v, base + 8 * at_params,
               width * n, vector_width, base + 8 * at_jacobian, base + 8 * at_vector)
    return jacobian, vector[:, :width], vector[:, width:2 * width]


def _assemble_function():
    """The generic ctypes function ``assemble_states`` (compiled or loaded once)."""
    _functions()
    return _generic[2]
