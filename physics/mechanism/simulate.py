"""Motion of any mechanism: one of its three formulations integrated by any integrator of the registry, its
closures held by projection, Baumgarte terms or nothing; or the reduced model in one joint coordinate.

A run is described by the chain's own :class:`physics.model.Settings` (method, integrator, back end,
tolerances, fixed step, step budget, stabilisation and its gains), checked against the one registry
(:mod:`physics.registry`: ``MECHANISM_METHODS``, ``INTEGRATORS``, ``STABILIZATIONS``), with the tighter spans a
mechanism's run allows (:data:`ALLOWED`). The compiled engine (:mod:`physics.mechanism.engine`: the
formulation generated once per structure, its numbers a parameter vector) integrates the chosen formulation's
state: the DAE's ``(q, qdot)`` or a tree formulation's ``(s, sd)``, by a compiled kernel with dense output (RK45,
DOP853, ode45, midpoint, variational) or scipy's Radau and LSODA on the same right-hand side. With projection
(the default, as for the chains) the state is moved back onto the constraints after every accepted step, so the
residual stays at rounding level over any run. Every sample reports the pose and velocities in maximal
coordinates and the chosen formulation's own reactions of every joint. A run stopped midway comes back with its
``status`` and ``message`` and the samples up to the stop, as a chain's Trajectory does. A mechanism its motors
fully determine (mobility 0, like the Jansen leg) needs no integration at all: each sample is position analysis
from the one before (the kernels' projection onto the formulation's own constraints), its velocities follow from
the constraints, and the chosen formulation gives the accelerations, the reactions and the motor torque; the
integrator asked for is then not used (the run's ``integrator`` says "position analysis").
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..errors import LinkageError
from ..model import Settings
from ..registry import (
    DEFAULT_BACKEND,
    MECHANISM_METHODS,
    METHODS,
    REDUCED_INTEGRATOR,
)
from ..simulate.chain_prepared import sample_times
from ..simulate.trajectory import Trajectory
from . import engine
from .assembly import assembled_with_jacobian
from .description import Mechanism
from .numeric_dae import MechanismDAE
from .prepared import prepared
from .run_settings import ALLOWED, run_options
from .run_table import state_vector
from .tree_coordinates import check_rotations
from .tree_dae import check_coordinates

__all__ = ["ALLOWED", "CONDITIONS", "RUN_METHODS", "project_velocity", "run_mechanism", "run_options",
           "simulate_mechanism"]

# The methods of a mechanism's run: the registry's (the formulations, and the reduced model in one joint
# coordinate for mobility 1: physics/mechanism/reduced.py)
RUN_METHODS = MECHANISM_METHODS
# What a run's ``condition`` measures (simulate_mechanism's ``condition``): the maximal Phi_q's condition, or the
# condition estimate of the formulation's own solve (a chain's run's meaning)
CONDITIONS = ("jacobian", "solve")


def project_velocity(dae: MechanismDAE, q: np.ndarray, qdot: np.ndarray, velocity_rhs: np.ndarray | None = None,
                     jacobian: np.ndarray | None = None) -> np.ndarray:
    """The velocity nearest ``qdot`` in kinetic energy that satisfies ``Phi_q qdot = nu`` (``velocity_rhs``:
    ``nu``, ``jacobian``: ``Phi_q`` at ``q``, when the caller holds them; computed here otherwise). A velocity
    that already satisfies it exactly comes back as a copy, without the least-squares solve (about 0.1 ms)."""
    jacobian = dae.constraints.jacobian(q) if jacobian is None else jacobian
    # a massless body's coordinates (a run in tree coordinates may have one) are weighted as of unit mass
    inverse_mass = 1.0 / np.where(dae.mass_diagonal > 0.0, dae.mass_diagonal, 1.0)
    nu = dae.constraints.velocity_rhs() if velocity_rhs is None else velocity_rhs
    gap = jacobian @ qdot - nu
    if not gap.any():  # already on the constraints (a start at rest without speed motors): lstsq would give 0
        return np.array(qdot, dtype=float)
    weighted = jacobian * inverse_mass
    correction, *_ = np.linalg.lstsq(weighted @ jacobian.T, gap, rcond=None)
    return qdot - inverse_mass * (jacobian.T @ correction)


def simulate_mechanism(
    mechanism: Mechanism,
    t_end: float,
    samples: int,
    *,
    q0: np.ndarray | None = None,
    qdot0: np.ndarray | None = None,
    t_start: float = 0.0,
    method: str = "dae",
    stabilization: str = "projection",
    rtol: float = 1e-10,
    atol: float = 1e-10,
    integrate: bool | None = None,
    integrator: str = "DOP853",
    step: float | None = None,
    max_steps: int | None = None,
    backend: str = DEFAULT_BACKEND,
    settings: Settings | None = None,
    coordinates: str = "maximal",
    rotations: str = "relative",
    condition: str = "jacobian",
    continuing: bool = False,
) -> Trajectory:
    """Run for ``t_end`` seconds from ``t_start`` (a motor's angle follows absolute time), from the pose
    assembled nearest ``q0`` (default: the sketch) with velocities ``qdot0`` (default: rest) projected onto the
    constraints, sampled at ``linspace(t_start, t_start + t_end, samples)``. ``method`` chooses the formulation
    whose accelerations are integrated and whose reactions are reported; ``stabilization`` how the closures
    are held; ``integrator`` (any of physics.registry.INTEGRATORS that can run the method), ``step`` (the fixed
    step of midpoint and variational), ``max_steps`` and ``backend`` as for a chain's run, or all of them at
    once as a chain's ``settings`` (:func:`run_options`). ``integrate``: None chooses (kinematics alone when the
    motors fix every body); True forces integration. To continue a run, pass its last ``t``, ``q`` and ``qdot``
    as ``t_start``, ``q0``, ``qdot0``. A run stopped midway returns the samples up to the stop with its
    ``status`` and ``message``; bad input, and a start that cannot be evaluated, raise LinkageError.
    ``coordinates="tree"`` (method ``dae`` only) integrates the DAE in the spanning tree's joint coordinates, as
    the seed's DAE integrates a chain's joint angles (:mod:`physics.mechanism.tree_dae`). ``rotations``
    (a run in tree coordinates only: lagrange, newton_euler, or dae with ``coordinates="tree"``): a pin's tree
    coordinate is the child's rotation relative to its parent (``"relative"``, the default) or the child's own
    rotation from the sketch (``"absolute"``: a chain sketched hanging straight down then integrates exactly the
    chain engine's angles). A choice of the run, not of the mechanism's file: it changes the state integrated and
    the code compiled (:data:`physics.mechanism.parameters.ROTATIONS`), never the machine. ``condition``
    (:data:`CONDITIONS`): what the run's ``condition`` measures at each sample: ``"jacobian"`` (the default) the
    condition of the maximal coordinates' ``Phi_q``, how near the pose is to a singular one (a batched SVD when
    first read); ``"solve"`` the condition estimate of the formulation's own solve at the sample, with its held
    constraints' ratio where it has any, as a chain's run reports it (:func:`physics.simulate`): the run has it
    already, so reading it costs nothing (an open tree of pins, a chain among them, has no singular pose:
    its ``Phi_q`` has full row rank by structure). ``continuing``: ``q0, qdot0`` are a run's own last sample
    (a chunk of a longer run, as the app computes them): without projection as the stabilisation they are
    integrated as they are, so a run's drift off its constraints goes on growing across chunks, as in one run
    (``stabilization="none"`` shows the drift it teaches); with projection they are projected as always."""
    options = run_options(t_end=t_end, samples=samples, t_start=t_start, method=method,
                          stabilization=stabilization, rtol=rtol, atol=atol, integrator=integrator, step=step,
                          max_steps=max_steps, backend=backend, settings=settings)
    return run_mechanism(mechanism, options, q0=q0, qdot0=qdot0, t_start=float(t_start), integrate=integrate,
                         coordinates=coordinates, rotations=rotations, condition=condition, continuing=continuing)


def run_mechanism(mechanism: Mechanism, settings: Settings, *, q0: np.ndarray | None = None,
                  qdot0: np.ndarray | None = None, t_start: float = 0.0,
                  integrate: bool | None = None, coordinates: str = "maximal",
                  rotations: str = "relative", condition: str = "jacobian",
                  continuing: bool = False) -> Trajectory:
    """:func:`simulate_mechanism` for checked ``settings`` (from :func:`run_options`): ``settings.t_end`` seconds
    at ``settings.samples`` times from ``t_start``."""
    check_coordinates(coordinates, settings.method)
    check_rotations(rotations)
    if condition not in CONDITIONS:
        raise LinkageError(f"condition = {condition!r}: allowed values {', '.join(CONDITIONS)}")
    reduced = METHODS[settings.method].reduced
    if condition != "jacobian" and reduced:
        raise LinkageError(f"condition = {condition!r}: does not apply to method {settings.method!r} (its samples "
                           "come from position analysis, not a solve of the formulation); leave it out")
    if rotations != "relative" and (reduced or (settings.method == "dae" and coordinates == "maximal")):
        raise LinkageError(f"rotations = {rotations!r}: applies to a run in tree coordinates only (method "
                           f"lagrange or newton_euler, or dae with coordinates 'tree'; got method "
                           f"{settings.method!r}); leave it out")
    q0, qdot0 = (state_vector(value, name, 3 * len(mechanism.bodies)) for value, name in ((q0, "q0"),
                                                                                          (qdot0, "qdot0")))
    times = sample_times(t_start, settings.t_end, settings.samples, from_zero=True)
    if METHODS[settings.method].reduced:
        return _reduced(mechanism, settings, t_start, q0, qdot0, integrate)
    pieces = prepared(mechanism)
    tree_run = settings.method != "dae" or coordinates == "tree"
    # refuses a body without mass before anything else, as building the DAE did, unless the run is in tree
    # coordinates, whose matrix stays regular for a chain's point-mass bar (engine.tree_dynamics)
    dae = engine.tree_dynamics(mechanism, pieces) if tree_run else pieces.dae
    assembled, jacobian = assembled_with_jacobian(mechanism, pieces, q0, t_start)
    q = assembled.q
    driven = assembled.mobility == 0 and not integrate
    qdot = project_velocity(dae, q, np.zeros_like(q) if qdot0 is None else np.asarray(qdot0, dtype=float),
                            pieces.velocity_rhs, jacobian)
    if continuing and settings.stabilization != "projection" and not driven and q0 is not None \
            and qdot0 is not None:  # a run's own last sample, its drift kept (see simulate_mechanism)
        q, qdot = np.array(q0, dtype=float), np.array(qdot0, dtype=float)
    return engine.run(mechanism, q, qdot, times, settings, driven=driven, pieces=pieces, coordinates=coordinates,
                      rotations=rotations, condition=condition)


def _reduced(mechanism: Mechanism, settings: Settings, t_start: float, q0, qdot0,
             integrate: bool | None) -> Trajectory:
    """The reduced model's run (mobility 1), its closures held by position analysis at every evaluation: no
    stabilisation applies, and a mechanism its motors fix has no free coordinate to reduce to."""
    if settings.stabilization != "projection":
        raise LinkageError(f"stabilization = {settings.stabilization!r}: does not apply to method 'reduced' (its "
                           f"positions come from position analysis, so the loops close exactly); leave it out")
    if integrate is False:
        raise LinkageError("integrate = False: does not apply to method 'reduced' (it always integrates)")
    from .reduced import fixed_coordinate, simulate_reduced  # noqa: PLC0415  (its numba kernel: imported by a reduced run only)

    switching = METHODS[settings.method].switches_branch
    reduced = simulate_reduced(mechanism, settings.t_end, settings.samples, q0=q0, qdot0=qdot0,
                               t_start=t_start, rtol=settings.rtol, atol=settings.atol, stop_as_status=True,
                               coordinate=None if switching else fixed_coordinate(mechanism), switching=switching)
    return replace(reduced.run, method=settings.method, coordinates="reduced", stabilization="position analysis",
                   integrated=True, integrator=REDUCED_INTEGRATOR)


