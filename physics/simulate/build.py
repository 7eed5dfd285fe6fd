"""From sampled states to a Trajectory: positions, energies, reactions and condition in one vectorised pass.

Shared by every way of integrating (compiled kernels, scipy's solvers, the reduced model), so a trajectory
reports the same quantities, computed the same way, whichever produced its states.
"""

from __future__ import annotations

import numpy as np

from ..codegen.native_samples import trajectory_samples
from ..errors import LinkageError
from .prepared import chain_arrays
from .trajectory import Trajectory


def system_condition(compiled, theta, omega, params) -> np.ndarray:
    """2-norm condition number of the formulation's matrix A at each sampled state (T,)."""
    A, _ = compiled.sample_matrices(theta, omega, params)
    with np.errstate(all="ignore"):
        return np.linalg.cond(A)


def build_trajectory(chain, settings, compiled, params, t, y, cond=None, alpha=0.0, beta=0.0) -> Trajectory:
    """Everything a trajectory reports, computed from the sampled states in one vectorised pass.

    The generated system is solved once per sample here (one batched call): it gives the reactions and the
    condition estimate together, so the integrator need not evaluate either at the samples. The joint reactions
    follow from the accelerations by Newton's law per bar (:mod:`physics.reactions`, in a compiled pass). The
    passes are generated LLVM IR (:mod:`physics.codegen.native_samples`, the numba kernels' bits): a first run
    compiles them in a fraction of a second, where numba took seconds. Their arrays share one buffer
    (:func:`~physics.codegen.native_samples.trajectory_samples`: one call, no per-array conversion), and a
    system run again in the process takes its specialised samples' pass
    (:meth:`~physics.codegen.cache.CompiledSystem.samples_solve`).
    """
    bars = chain_arrays(chain)
    trace = trace_point(chain, settings, bars)
    tip_reaction_index = compiled.tip_reaction_index
    arrays = trajectory_samples(compiled.assemble_function, compiled.layout, y, params, alpha, beta, bars.bars,
                                bars.g, trace.bar - 1, float(trace.along), float(trace.across),
                                compiled.theta_ddot_index, tip_reaction_index if chain.pinned else (),
                                compiled.samples_solve() if len(t) else None)
    return trajectory_from_samples(chain, settings, compiled, params, t, arrays, cond)


def trace_point(chain, settings, bars):
    """The point a run traces (the settings', else the tip), its bar checked against the chain."""
    trace = settings.trace or bars.tip
    if trace.bar > chain.n:
        raise LinkageError(f"trace bar = {trace.bar}: allowed range 1 <= bar <= {chain.n}")
    return trace


def trajectory_from_samples(chain, settings, compiled, params, t, arrays, cond=None) -> Trajectory:
    """The Trajectory of sample times ``t`` and the samples' pass ``arrays``
    (:class:`~physics.codegen.native_samples.SampleArrays`, for as many rows as ``t``): views of them where a
    field is one of them, a pinned chain's constraint drift and condition numbers computed here."""
    samples = len(t)
    reaction_index = compiled.reaction_index
    theta, omega, joints = arrays.theta, arrays.omega, arrays.joints
    reactions = arrays.x[:, reaction_index] if reaction_index.size else np.zeros((samples, 0, 2))
    if cond is None or len(cond) != samples:
        cond = arrays.cond
    if chain.pinned:
        tip_reaction_index = compiled.tip_reaction_index
        tip_reaction = (arrays.x[:, tip_reaction_index] if tip_reaction_index.size
                        else np.zeros((samples, len(tip_reaction_index))))
        constraint_xy = joints[:, -1, :] - np.asarray(chain.pin)
        constraint_velocity = arrays.tip_velocity
        if samples:
            # Near a singular position the pivot ratio understates the trouble: report the true 2-norm
            # condition number of the system actually solved.
            cond = system_condition(compiled, theta, omega, params)
    else:
        tip_reaction = np.zeros((samples, 0))  # an open chain's system has no pin force among its unknowns
        constraint_xy = np.zeros((samples, 0))
        constraint_velocity = np.zeros((samples, 0))
    return Trajectory.of_chain(
        settings.method, settings.integrator, t, arrays.trace_xy, arrays.kinetic, arrays.potential,
        arrays.energy,  # kinetic + potential, added in the same pass
        cond, theta, omega, joints, joints[:, -1, :], reactions, tip_reaction, constraint_xy, constraint_velocity,
        arrays.joint_reactions, settings.trace is not None,
    )
