"""From sampled states to a Trajectory: positions, energies, reactions and condition in one vectorised pass.

Shared by every way of integrating (compiled kernels, scipy's solvers, the reduced model), so a trajectory
reports the same quantities, computed the same way, whichever produced its states.
"""

from __future__ import annotations

import numpy as np

from ..errors import LinkageError
from .prepared import chain_arrays
from .trajectory import Trajectory


def system_condition(compiled, theta, omega, params) -> np.ndarray:
    """2-norm condition number of the formulation's matrix A at each sampled state (T,)."""
    A, _ = compiled.matrices(theta, omega, params)
    with np.errstate(all="ignore"):
        return np.linalg.cond(A)


def build_trajectory(chain, settings, compiled, params, t, y, cond=None, alpha=0.0, beta=0.0) -> Trajectory:
    """Everything a trajectory reports, computed from the sampled states in one vectorised pass.

    The generated system is solved once per sample here (one batched call): it gives the reactions and the
    condition estimate together, so the integrator need not evaluate either at the samples. The joint reactions
    follow from the accelerations by Newton's law per bar (:mod:`physics.reactions`, in a compiled pass).
    """
    from ..kernels.observables import (  # noqa: PLC0415  (numba: when a run reaches its samples, not at import)
        chain_joint_reactions,
        chain_observables,
    )

    n = chain.n
    theta, omega = np.ascontiguousarray(y[:, :n]), np.ascontiguousarray(y[:, n:])
    bars = chain_arrays(chain)
    L, d, m, I = bars.L, bars.d, bars.m, bars.I
    samples = len(t)
    trace = settings.trace or bars.tip
    if trace.bar > n:
        raise LinkageError(f"trace bar = {trace.bar}: allowed range 1 <= bar <= {n}")
    joints = np.empty((samples, n + 1, 2))
    trace_xy = np.empty((samples, 2))
    kinetic = np.empty(samples)
    potential = np.empty(samples)
    tip_velocity = np.empty((samples, 2))
    chain_observables(theta, omega, L, d, m, I, bars.g, trace.bar - 1, float(trace.along),
                      float(trace.across), joints, trace_xy, kinetic, potential, tip_velocity)
    energy = kinetic + potential

    reaction_index = compiled.reaction_index
    tip_reaction_index = compiled.tip_reaction_index
    reactions = np.zeros((samples, len(reaction_index), 2))
    joint_reactions = np.zeros((samples, n, 2))
    tip_reaction = np.zeros((samples, len(tip_reaction_index)))
    constraint_xy = np.zeros((samples, 2 if chain.pinned else 0))
    constraint_velocity = np.zeros((samples, 2 if chain.pinned else 0))
    if samples:
        x, batch_cond = compiled.solve_full_batch(theta, omega, params, alpha, beta)
        if cond is None or len(cond) != samples:
            cond = batch_cond
        if reaction_index.size:
            reactions = x[:, reaction_index]
        if tip_reaction_index.size:
            tip_reaction = x[:, tip_reaction_index]
        pin_force = np.ascontiguousarray(tip_reaction) if chain.pinned else np.zeros((0, 2))
        chain_joint_reactions(theta, omega, np.ascontiguousarray(x[:, compiled.theta_ddot_index]), L, d, m, bars.g,
                              pin_force, joint_reactions)
    else:
        cond = np.zeros(0)
    if chain.pinned:
        constraint_xy = joints[:, -1, :] - np.asarray(chain.pin)
        constraint_velocity = tip_velocity
        if samples:
            # Near a singular position the pivot ratio understates the trouble: report the true 2-norm
            # condition number of the system actually solved.
            cond = system_condition(compiled, theta, omega, params)
    return Trajectory(
        method=settings.method,
        integrator=settings.integrator,
        t=t,
        theta=theta,
        omega=omega,
        joints=joints,
        tip_xy=joints[:, -1, :],
        trace_xy=trace_xy,
        kinetic=kinetic,
        potential=potential,
        energy=energy,
        reactions=reactions,
        joint_reactions=joint_reactions,
        tip_reaction=tip_reaction,
        constraint_xy=constraint_xy,
        constraint_velocity=constraint_velocity,
        condition=cond,
        trace_is_explicit=settings.trace is not None,
    )
