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

import math
from dataclasses import replace

import numpy as np
from pydantic import ValidationError

from ..errors import LinkageError
from ..model import (
    MECHANISM_MAX_SAMPLES,
    MECHANISM_MAX_T_END,
    MECHANISM_MAX_TOLERANCE,
    MIN_ATOL,
    MIN_RTOL,
    Settings,
)
from ..registry import (
    BACKENDS,
    DEFAULT_BACKEND,
    INTEGRATOR_NAMES,
    MECHANISM_METHODS,
    REDUCED_INTEGRATOR,
    STABILIZATIONS,
    integrators_for,
)
from ..simulate.trajectory import Trajectory
from . import engine
from .assembly import assemble
from .dae import MechanismDAE
from .model import Mechanism
from .reduced import simulate_reduced
from .run import state_vector

__all__ = ["ALLOWED", "RUN_METHODS", "project_velocity", "run_mechanism", "run_options",
           "simulate_mechanism"]

# The methods of a mechanism's run: the registry's (the formulations, and the reduced model in one joint
# coordinate for mobility 1: physics/mechanism/reduced.py)
RUN_METHODS = MECHANISM_METHODS


def project_velocity(dae: MechanismDAE, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
    """The velocity nearest ``qdot`` in kinetic energy that satisfies ``Phi_q qdot = nu``."""
    jacobian = dae.constraints.jacobian(q)
    inverse_mass = 1.0 / dae.mass_diagonal
    gap = jacobian @ qdot - dae.constraints.velocity_rhs()
    weighted = jacobian * inverse_mass
    correction, *_ = np.linalg.lstsq(weighted @ jacobian.T, gap, rcond=None)
    return qdot - inverse_mass * (jacobian.T @ correction)


def _ten(power_of_ten: float) -> str:
    """``1e4``, ``1e-2``: a limit as the refusals have always written it."""
    return f"1e{round(math.log10(power_of_ten))}"


# What each option of a mechanism's run allows, in the one line that refuses it. The names come from the
# registry; the spans of t_end, samples and the tolerances are a mechanism run's own (physics.model's
# MECHANISM_MAX_*, tighter than a chain's: a general mechanism's samples are heavier), checked before the one
# Settings checks its own.
ALLOWED = {
    "t_end": f"allowed range 0 < t_end <= {_ten(MECHANISM_MAX_T_END)} (the run's duration from t_start, s)",
    "samples": f"allowed range 2 <= samples <= {MECHANISM_MAX_SAMPLES}",
    "t_start": "allowed range -1e6 <= t_start <= 1e6 (s)",
    "method": f"allowed values {', '.join(MECHANISM_METHODS)}",
    "stabilization": f"allowed values {', '.join(STABILIZATIONS)}",
    "rtol": f"allowed range {MIN_RTOL:g} <= rtol <= {_ten(MECHANISM_MAX_TOLERANCE)}",
    "atol": f"allowed range {MIN_ATOL:g} <= atol <= {_ten(MECHANISM_MAX_TOLERANCE)}",
    "integrator": f"allowed values {', '.join(INTEGRATOR_NAMES)}",
    "backend": f"allowed values {', '.join(BACKENDS)}",
    "step": "allowed range 0 < step <= 1 (s, the fixed step of midpoint and variational)",
    "max_steps": "allowed range 1 <= max_steps <= 1e9 (integration steps before a run is stopped)",
    "baumgarte_alpha": "allowed range 0 <= baumgarte_alpha <= 1e4",
    "baumgarte_beta": "allowed range 0 <= baumgarte_beta <= 1e4",
}
_SPANS = {"t_end": (0.0, MECHANISM_MAX_T_END, True), "t_start": (-1e6, 1e6, False),
          "rtol": (MIN_RTOL, MECHANISM_MAX_TOLERANCE, False), "atol": (MIN_ATOL, MECHANISM_MAX_TOLERANCE, False)}
_NAMES = {"method": MECHANISM_METHODS, "stabilization": STABILIZATIONS, "integrator": INTEGRATOR_NAMES,
          "backend": BACKENDS}


def _refuse(field: str, value) -> LinkageError:
    return LinkageError(f"{field} = {value!r}: {ALLOWED[field]}")


def _number(field: str, value) -> float:
    """A real number inside the mechanism's span for ``field``, or the one line naming it."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise _refuse(field, value)
    number = float(value)
    low, high, open_low = _SPANS[field]
    if not (math.isfinite(number) and (low < number if open_low else low <= number) and number <= high):
        raise LinkageError(f"{field} = {value}: {ALLOWED[field]}")
    return number


def run_options(*, t_end, samples, t_start=0.0, method="dae", stabilization="projection", rtol=1e-10, atol=1e-10,
                integrator="DOP853", step=None, max_steps=None, backend=DEFAULT_BACKEND,
                settings: Settings | None = None, baumgarte_alpha=None, baumgarte_beta=None) -> Settings:
    """The :class:`physics.model.Settings` of a mechanism's run, every option checked: LinkageError
    ``"field = value: allowed ..."`` (one line) for the first bad one, or the registry's sentence for a
    combination that cannot run (``integrator = variational: needs method = lagrange (got dae)``). With
    ``settings`` its method, integrator, back end, tolerances, step, budget, stabilisation and gains are the run's
    (the keywords are then not read); ``t_end`` and ``samples`` are always the arguments'. The Baumgarte gains
    (``baumgarte_alpha``, ``baumgarte_beta``: None keeps Settings' defaults) are checked by Settings too."""
    if settings is not None:
        method, stabilization, integrator, backend = (settings.method, settings.stabilization, settings.integrator,
                                                      settings.backend)
        rtol, atol, step, max_steps = settings.rtol, settings.atol, settings.step, settings.max_steps
        if settings.damping != 0.0:
            raise LinkageError(f"damping = {settings.damping:g}: does not apply to a mechanism (a chain's joint "
                               "damping); give each joint its damping in the description, or --set JOINT.damping=C")
        if settings.trace is not None:
            raise LinkageError("trace: a chain's bar point does not apply to a mechanism (it traces the point its "
                               "description names, trace = \"body.point\")")
    values = {"t_end": _number("t_end", t_end), "t_start": _number("t_start", t_start),
              "rtol": _number("rtol", rtol), "atol": _number("atol", atol)}
    if (isinstance(samples, bool) or not isinstance(samples, (int, np.integer))
            or not 2 <= samples <= MECHANISM_MAX_SAMPLES):
        raise _refuse("samples", samples)
    for field, value in (("method", method), ("stabilization", stabilization), ("integrator", integrator),
                         ("backend", backend)):
        if not isinstance(value, str) or value not in _NAMES[field]:
            raise _refuse(field, value)
    if method == "reduced" and integrator not in integrators_for("reduced"):
        raise LinkageError(f"integrator = {integrator}: method 'reduced' integrates with {REDUCED_INTEGRATOR} only "
                           "(scipy's, on its own switching right-hand side); leave integrator out")
    fields = dict(method=method, integrator=integrator, backend=backend, rtol=values["rtol"], atol=values["atol"],
                  t_end=values["t_end"], samples=int(samples), stabilization=stabilization)
    if settings is not None:
        baumgarte_alpha, baumgarte_beta = settings.baumgarte_alpha, settings.baumgarte_beta
    for field, gain in (("baumgarte_alpha", baumgarte_alpha), ("baumgarte_beta", baumgarte_beta)):
        if gain is not None:
            fields[field] = gain
    if step is not None:
        fields["step"] = step
    if max_steps is not None:
        fields["max_steps"] = max_steps
    try:
        return Settings(**fields)
    except ValidationError as error:
        first = error.errors()[0]
        field = str(first["loc"][0]) if first["loc"] else ""
        if field in ALLOWED:
            raise _refuse(field, fields[field]) from None
        raise LinkageError(str(first["msg"]).removeprefix("Value error, ")) from None


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
    ``status`` and ``message``; bad input, and a start that cannot be evaluated, raise LinkageError."""
    options = run_options(t_end=t_end, samples=samples, t_start=t_start, method=method,
                          stabilization=stabilization, rtol=rtol, atol=atol, integrator=integrator, step=step,
                          max_steps=max_steps, backend=backend, settings=settings)
    return run_mechanism(mechanism, options, q0=q0, qdot0=qdot0, t_start=float(t_start), integrate=integrate)


def run_mechanism(mechanism: Mechanism, settings: Settings, *, q0: np.ndarray | None = None,
                  qdot0: np.ndarray | None = None, t_start: float = 0.0,
                  integrate: bool | None = None) -> Trajectory:
    """:func:`simulate_mechanism` for checked ``settings`` (from :func:`run_options`): ``settings.t_end`` seconds
    at ``settings.samples`` times from ``t_start``."""
    q0, qdot0 = (state_vector(value, name, 3 * len(mechanism.bodies)) for value, name in ((q0, "q0"),
                                                                                          (qdot0, "qdot0")))
    times = t_start + np.linspace(0.0, settings.t_end, settings.samples)
    if settings.method == "reduced":
        return _reduced(mechanism, settings, t_start, q0, qdot0, integrate)
    dae = MechanismDAE(mechanism)
    assembled = assemble(mechanism, q0, t_start)
    q = assembled.q
    driven = assembled.mobility == 0 and not integrate
    qdot = project_velocity(dae, q, np.zeros_like(q) if qdot0 is None else np.asarray(qdot0, dtype=float))
    return engine.run(mechanism, q, qdot, times, settings, driven=driven)


def _reduced(mechanism: Mechanism, settings: Settings, t_start: float, q0, qdot0,
             integrate: bool | None) -> Trajectory:
    """The reduced model's run (mobility 1), its closures held by position analysis at every evaluation: no
    stabilisation applies, and a mechanism its motors fix has no free coordinate to reduce to."""
    if settings.stabilization != "projection":
        raise LinkageError(f"stabilization = {settings.stabilization!r}: does not apply to method 'reduced' (its "
                           f"positions come from position analysis, so the loops close exactly); leave it out")
    if integrate is False:
        raise LinkageError("integrate = False: does not apply to method 'reduced' (it always integrates)")
    reduced = simulate_reduced(mechanism, settings.t_end, settings.samples, q0=q0, qdot0=qdot0,
                               t_start=t_start, rtol=settings.rtol, atol=settings.atol, stop_as_status=True)
    return replace(reduced.run, method="reduced", stabilization="position analysis", integrated=True,
                   integrator=REDUCED_INTEGRATOR)


