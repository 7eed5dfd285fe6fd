"""Reduced model of a four-bar: one degree of freedom integrated in one independent angle.

A pinned 3-bar chain has three angles and two loop equations ``tip(theta) = pin``, so one angle ``q``
(the *independent* coordinate) fixes the others, the *dependent* pair, by closed-form assembly. Its
velocities follow from the velocity constraint ``J omega = 0``: ``omega = s q_dot`` with ``s`` the null
vector of ``J`` normalised to ``s_i = 1``. Projecting the open chain's equations ``M theta_ddot = f + J^T R``
onto ``s`` removes the tip reaction R (``s^T J^T = 0``) and leaves one scalar equation

    (s^T M s) q_ddot = s^T (f - M gamma),        gamma = s_dot q_dot,

where ``gamma`` is the part of ``theta_ddot`` not proportional to ``q_ddot``: from ``J theta_ddot + J_dot omega = 0``
with ``theta_ddot_i = q_ddot``, ``gamma_i = 0`` and ``gamma_dep = -J_dep^{-1} (J_dot omega)``.

An angle stops being a valid coordinate where its two dependent bars become collinear (``J_dep`` loses
rank: a dead centre); the seed four-bar reaches such a position for every angle in turn. Generalized
coordinate partitioning keeps going: integrate in the angle whose dependent pair is best conditioned,
stop (an event of the integrator) when it degrades, re-pick, restart. With ``switching=False`` the
coordinate stays fixed and the run stops at the first dead centre with ``status < 0`` and a message.
See docs/closed-loops.md.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.integrate import solve_ivp

from .assembly import (
    elbow_of,
    loop_jacobian,
    loop_residual,
    solve_two_bars,
    wrap_near,
)
from .errors import LinkageError
from .kinematics import lever_arms, potential_energy
from .status import Status

# Conditioning of a choice of independent angle i: the reciprocal 2-norm condition number of the dependent
# Jacobian with its columns scaled to unit length (the bar lengths removed, so a long bar is not penalised),
# which is tan(phi / 2) for phi in [0, pi/2] the acute angle between the lines of the two dependent bars:
# 1 when they are perpendicular, 0 when collinear (a dead centre).

# Re-pick the independent angle when its conditioning falls below this (phi ~ 23 degrees): early enough that
# the dependent velocities s stay below ~ 3 L_max / L_min times q_dot and the closed-form branch is
# unambiguous, late enough that switches stay rare (about one per dead centre passed).
SWITCH_RCOND = 0.2

# ... or, near a whole-loop singularity where no angle reaches SWITCH_RCOND, when it falls below this
# fraction of the best available, so the choice still follows the best-conditioned angle.
SWITCH_FRACTION = 0.5

# A fixed coordinate counts as lost at this conditioning (phi ~ 1.1 degrees): the integrator's steps shrink
# towards the dead centre and the dependent speeds grow as 1/phi, so stopping here reports the failure
# instead of returning a solution that bounced back on the wrong branch.
DEAD_CENTRE_RCOND = 1e-2

# A start state may miss the loop by this much (times the linkage size, at least 1) and still be accepted,
# as physics.simulate does (its ASSEMBLY_TOLERANCE); the start is then re-closed exactly.
START_CLOSURE_TOL = 1e-8

# Safety net against chattering between coordinates (never reached on the seed: ~40 switches / 100 s).
MAX_SWITCHES = 100_000

MassAndForcing = Callable[[np.ndarray, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


# --------------------------------------------------------------------------------------------------
# Open-chain dynamics in closed form (the default model; the app may pass its compiled one instead)


def _split(params: np.ndarray, n: int):
    params = np.asarray(params, dtype=float)
    return params[:n], params[n : 2 * n], params[2 * n : 3 * n], params[3 * n : 4 * n], float(params[4 * n])


@functools.lru_cache(maxsize=64)
def _coefficients(params_bytes: bytes, n: int):
    """``(c, w, I, g)`` of :func:`open_chain_mass_and_forcing`, computed once per parameter set."""
    L, d, m, I, g = _split(np.frombuffer(params_bytes, dtype=float), n)
    lever = lever_arms(L, d)
    return lever.T @ (m[:, None] * lever), m @ lever, np.diag(I), g


def open_chain_mass_and_forcing(theta, omega, params) -> tuple[np.ndarray, np.ndarray]:
    """``(M, f)`` with ``M theta_ddot = f`` for the free (open) chain, derived by hand from T - V.

    Centre of mass k sits at ``sum_i lever[k, i] e_i``; with ``c_ij = sum_k m_k lever[k, i] lever[k, j]`` and
    ``w_i = sum_k m_k lever[k, i]``:

        M_ij = c_ij cos(theta_i - theta_j) + I_i delta_ij
        f_i  = -sum_j c_ij sin(theta_i - theta_j) omega_j^2 - g w_i sin theta_i

    ``params`` is the layout of docs/architecture.md (entries past ``g`` are ignored).
    """
    theta = np.asarray(theta, dtype=float)
    omega = np.asarray(omega, dtype=float)
    n = theta.size
    coupling, weight, I, g = _coefficients(np.asarray(params, dtype=float)[: 4 * n + 1].tobytes(), n)
    diff = theta[:, None] - theta[None, :]
    M = coupling * np.cos(diff) + I
    f = -(coupling * np.sin(diff)) @ (omega * omega) - g * weight * np.sin(theta)
    return M, f


# --------------------------------------------------------------------------------------------------
# Coordinate partitioning


def dependent_pair(independent: int) -> tuple[int, int]:
    """The two dependent angle indices (0-based, increasing) when ``independent`` is the coordinate."""
    first, second = (k for k in range(3) if k != independent)
    return first, second


def _pair_rcond(theta_a: float, theta_b: float) -> float:
    # unit columns (cos, sin) at angle phi: singular values sqrt(1 +- |cos phi|) -> ratio tan(phi/2)
    c = abs(math.cos(theta_b - theta_a))
    return math.sqrt(max(0.0, 1.0 - c) / (1.0 + c))


def partition_conditioning(theta) -> np.ndarray:
    """Conditioning (see :data:`SWITCH_RCOND`) of each choice of independent angle, shape ``(3,)``."""
    theta = np.asarray(theta, dtype=float)
    return np.array([_pair_rcond(*(theta[k] for k in dependent_pair(i))) for i in range(3)])


def best_independent(theta) -> int:
    """The independent angle whose dependent pair is best conditioned."""
    return int(np.argmax(partition_conditioning(theta)))


class _Partition:
    """One choice of independent angle and branch: configuration, velocities and the reduced equation."""

    def __init__(self, L, pin, params, independent, elbow, mass_and_forcing):
        self.L = L
        self.pin = pin
        self.params = params
        self.independent = independent
        self.pair = dependent_pair(independent)
        self.elbow = elbow
        self.mass_and_forcing = mass_and_forcing

    def configuration(self, q: float, reference: np.ndarray | None = None) -> np.ndarray:
        """All three angles from the independent one; dependent ones unwrapped near ``reference``."""
        i, (a, b), L = self.independent, self.pair, self.L
        wx = self.pin[0] - L[i] * math.sin(q)
        wy = self.pin[1] + L[i] * math.cos(q)
        solved = solve_two_bars(wx, wy, L[a], L[b], self.elbow)
        if solved is None:
            raise _OutOfRange(q)
        theta = np.empty(3)
        theta[i] = q
        theta[a], theta[b] = solved
        if reference is not None:
            theta[a] = wrap_near(theta[a], reference[a])
            theta[b] = wrap_near(theta[b], reference[b])
        return theta

    def solve_dependent(self, theta: np.ndarray, rx: float, ry: float) -> tuple[float, float]:
        """Solve ``J_dep x = (rx, ry)`` by Cramer's rule (2 x 2, never near singular inside a segment)."""
        a, b = self.pair
        La, Lb = self.L[a], self.L[b]
        ca, sa, cb, sb = math.cos(theta[a]), math.sin(theta[a]), math.cos(theta[b]), math.sin(theta[b])
        det = La * Lb * math.sin(theta[b] - theta[a])  # = det [[La ca, Lb cb], [La sa, Lb sb]]
        return (rx * Lb * sb - ry * Lb * cb) / det, (La * ca * ry - La * sa * rx) / det

    def null_vector(self, theta: np.ndarray) -> np.ndarray:
        """``s`` with ``J s = 0`` and ``s_i = 1``."""
        i, (a, b) = self.independent, self.pair
        s = np.empty(3)
        s[i] = 1.0
        s[a], s[b] = self.solve_dependent(theta, -self.L[i] * math.cos(theta[i]), -self.L[i] * math.sin(theta[i]))
        return s

    def conditioning(self, theta: np.ndarray) -> float:
        a, b = self.pair
        return _pair_rcond(theta[a], theta[b])

    def state(self, q: float, q_dot: float, reference=None) -> tuple[np.ndarray, np.ndarray]:
        theta = self.configuration(q, reference)
        return theta, self.null_vector(theta) * q_dot

    def rhs(self, t, y):
        q, q_dot = y
        theta = self.configuration(q)
        s = self.null_vector(theta)
        omega = s * q_dot
        # J_dot omega = d/dt (sum L_k (cos, sin) theta_k) . omega = sum L_k (-sin, cos) omega_k^2
        w2 = self.L * omega * omega
        gamma = np.zeros(3)
        a, b = self.pair
        gamma[a], gamma[b] = self.solve_dependent(theta, np.dot(w2, np.sin(theta)), -np.dot(w2, np.cos(theta)))
        M, f = self.mass_and_forcing(theta, omega, self.params)
        q_ddot = s @ (f - M @ gamma) / (s @ M @ s)
        return np.array([q_dot, q_ddot])


class _OutOfRange(Exception):
    """The independent angle left the range over which the loop closes (only past a missed dead centre)."""


# --------------------------------------------------------------------------------------------------
# Simulation


@dataclass
class ReducedTrajectory:
    """Result of :func:`simulate_reduced`; time along axis 0.

    ``independent_index`` (T,) is the 0-based angle integrated at each sample, ``switch_times`` when it
    changed. ``constraint_xy`` / ``constraint_velocity`` (T, 2) are the tip's position minus the pin and its
    velocity. ``status`` (physics.status.Status): OK, reached ``t_end``; SINGULAR, the fixed coordinate met a
    dead centre or every angle lost validity at once (the whole loop singular); INTEGRATOR_FAILED, the integrator
    failed or switched too often. ``message`` says which and when.
    """

    t: np.ndarray
    theta: np.ndarray
    omega: np.ndarray
    independent_index: np.ndarray
    n_switches: int
    switch_times: np.ndarray
    kinetic: np.ndarray
    potential: np.ndarray
    energy: np.ndarray
    constraint_xy: np.ndarray
    constraint_velocity: np.ndarray
    status: int
    message: str
    nfev: int = 0
    conditioning: np.ndarray = field(default_factory=lambda: np.zeros(0))


def _check_inputs(L, d, m, I, pin, theta0, omega0):
    arrays = {}
    for name, value in (("L", L), ("d", d), ("m", m), ("I", I), ("theta0", theta0), ("omega0", omega0)):
        arr = np.asarray(value, dtype=float).reshape(-1)
        if arr.shape != (3,):
            raise LinkageError(
                f"{name}: the reduced model is for a four-bar (3 bars), expected 3 entries, got {arr.size}"
            )
        if not np.all(np.isfinite(arr)):
            raise LinkageError(f"{name} = {arr.tolist()}: entries must be finite numbers")
        arrays[name] = arr
    pin = np.asarray(pin, dtype=float).reshape(-1)
    if pin.shape != (2,) or not np.all(np.isfinite(pin)):
        raise LinkageError(f"pin = {pin.tolist()}: expected two finite numbers (pin_x, pin_y)")
    return arrays, pin


def simulate_reduced(
    L,
    d,
    m,
    I,
    g,
    pin,
    theta0,
    t_end,
    t_eval=None,
    rtol=1e-10,
    atol=1e-10,
    switching=True,
    mass_and_forcing: MassAndForcing | None = None,
    *,
    omega0=None,
    independent_index: int | None = None,
    damping: float = 0.0,
    t_offset: float = 0.0,
) -> ReducedTrajectory:
    """Integrate a four-bar in one independent angle with scipy's DOP853, switching coordinates as needed.

    Main arguments
    --------------
    L, d, m, I : (3,) bar parameters; g : gravity; pin : (2,) ground point of the tip.
    theta0 : (3,) start angles; they must close the loop (use :func:`physics.assembly.assemble`).
    t_end : horizon (s); t_eval : (T,) output times in [0, t_end], or None for every accepted step.

    Other arguments
    ---------------
    rtol, atol : DOP853 tolerances on ``(q, q_dot)``.
    switching : True -> generalized coordinate partitioning (re-pick below ``SWITCH_RCOND``);
        False -> keep ``independent_index`` (default 0, i.e. theta1) and stop at its first dead centre.
    mass_and_forcing : ``(theta, omega, params) -> (M, f)`` of the open chain, ``M theta_ddot = f``;
        default :func:`open_chain_mass_and_forcing`. ``params`` is ``[L, d, m, I, g, pin_x, pin_y, damping]``
        (docs/architecture.md); any generalized force in ``f`` (joint damping, say) is projected correctly.
    omega0 : (3,) start velocities, projected onto ``J omega = 0`` (default: rest).
    t_offset : added to every time quoted in ``message`` (a run continuing an earlier one at ``t_offset``).
    independent_index : 0-based angle to start with (and keep, without switching); default: the best
        conditioned one with switching, theta1 without.
    damping : written into ``params`` for a ``mass_and_forcing`` that models joint damping; the default
        (undamped) model refuses a non-zero value rather than ignore it.

    Returns
    -------
    ReducedTrajectory. A run that fails midway does not raise: ``status < 0`` and ``message`` say why, and the
    arrays hold the samples computed up to then.

    Raises
    ------
    LinkageError for bad input: wrong shapes, a start that does not close the loop, a bad index.
    """
    arrays, pin = _check_inputs(L, d, m, I, pin, theta0, np.zeros(3) if omega0 is None else omega0)
    L, d, m, I = arrays["L"], arrays["d"], arrays["m"], arrays["I"]
    theta0, omega0 = arrays["theta0"], arrays["omega0"]
    g = float(g)
    if not (math.isfinite(t_end) and t_end > 0.0):
        raise LinkageError(f"t_end = {t_end}: must be a positive finite number of seconds")
    if independent_index is not None and independent_index not in (0, 1, 2):
        raise LinkageError(f"independent_index = {independent_index}: allowed 0, 1 or 2 (theta1, theta2, theta3)")
    gap = float(np.hypot(*loop_residual(L, theta0, pin)))
    if not gap <= START_CLOSURE_TOL * max(1.0, float(np.sum(L)) + float(np.hypot(*pin))):
        raise LinkageError(
            f"theta0 = {theta0.tolist()} does not close the loop: the tip misses the pin by {gap:.3g}; "
            f"assemble the start first (physics.assembly.assemble)"
        )
    if t_eval is not None:
        t_eval = np.asarray(t_eval, dtype=float).reshape(-1)
        if t_eval.size and (t_eval[0] < 0.0 or t_eval[-1] > t_end or np.any(np.diff(t_eval) <= 0.0)):
            raise LinkageError("t_eval: must be increasing and within [0, t_end]")
    if damping != 0.0 and mass_and_forcing is None:
        raise LinkageError(
            f"damping = {damping}: the default reduced model is undamped; pass a mass_and_forcing that models "
            f"joint damping, or damping = 0"
        )
    mass_and_forcing = mass_and_forcing or open_chain_mass_and_forcing
    params = np.concatenate([L, d, m, I, [g], pin, [float(damping)]])

    if independent_index is None:
        independent_index = best_independent(theta0) if switching else 0
    theta = theta0.copy()
    elbow = elbow_of(*theta[list(dependent_pair(independent_index))])
    partition = _Partition(L, pin, params, independent_index, elbow, mass_and_forcing)
    theta = partition.configuration(theta[independent_index], theta0)  # exact closure from the start
    omega = partition.null_vector(theta) * _independent_speed(L, theta, omega0, independent_index)

    out = _Samples()
    switch_times: list[float] = []
    status, message, nfev, t0 = Status.OK, "reached t_end", 0, 0.0
    first = True
    while True:
        i = partition.independent
        if partition.conditioning(theta) < DEAD_CENTRE_RCOND:
            status, message = _dead_centre_failure(partition, theta, t0 + t_offset, switching)
            out.add(partition, t0, theta, omega)
            break
        events = [_dead_centre_event(partition)]
        if switching:
            events.append(_switch_event(partition))
        try:
            sol = solve_ivp(
                partition.rhs, (t0, t_end), [theta[i], omega[i]], method="DOP853", rtol=rtol, atol=atol,
                events=events, dense_output=True,
            )
        except (_OutOfRange, ZeroDivisionError) as error:  # a dead centre slipped between two steps
            status = Status.SINGULAR if not switching else Status.INTEGRATOR_FAILED
            message = (
                f"the reduced model lost theta{i + 1} as a coordinate after t = {t0 + t_offset:.6g} s "
                f"({type(error).__name__}); a dead centre was passed between two steps; tighten rtol"
            )
            break
        nfev += sol.nfev
        _collect(out, partition, sol, theta, t_eval, include_start=first)
        first = False
        if sol.status == -1:
            status, message = Status.INTEGRATOR_FAILED, f"integrator failed at t = {sol.t[-1] + t_offset:.6g} s: {sol.message}"
            break
        if sol.status == 0:
            break
        t_event = float(sol.t[-1])
        theta, omega = out.end_theta.copy(), out.end_omega.copy()
        if sol.t_events[0].size:  # conditioning below DEAD_CENTRE_RCOND
            status, message = _dead_centre_failure(partition, theta, t_event + t_offset, switching)
            break
        new_index = best_independent(theta)
        if len(switch_times) >= MAX_SWITCHES:
            status, message = Status.INTEGRATOR_FAILED, f"coordinate switching exceeded {MAX_SWITCHES} switches by t = {t_event + t_offset:.6g} s"
            break
        switch_times.append(t_event)
        pair = list(dependent_pair(new_index))
        partition = _Partition(L, pin, params, new_index, elbow_of(*theta[pair]), mass_and_forcing)
        t0 = t_event

    return out.result(L, d, m, g, pin, params, mass_and_forcing, switch_times, status, message, nfev)


def _independent_speed(L, theta, omega0, index) -> float:
    """The independent speed of the start velocity after projection onto ``J omega = 0``."""
    J = loop_jacobian(L, theta)
    consistent = omega0 - np.linalg.lstsq(J, J @ omega0, rcond=None)[0]
    return float(consistent[index])


def _dead_centre_event(partition: _Partition):
    def event(t, y):
        return partition.conditioning(partition.configuration(y[0])) - DEAD_CENTRE_RCOND

    # scipy's solve_ivp reads these attributes off the event function (its documented protocol).
    event.terminal = True  # type: ignore[attr-defined]
    event.direction = -1  # type: ignore[attr-defined]
    return event


def _switch_event(partition: _Partition):
    def event(t, y):
        kappa = partition_conditioning(partition.configuration(y[0]))
        threshold = min(SWITCH_RCOND, SWITCH_FRACTION * float(kappa.max()))
        return kappa[partition.independent] - threshold

    # scipy's solve_ivp reads these attributes off the event function (its documented protocol).
    event.terminal = True  # type: ignore[attr-defined]
    event.direction = -1  # type: ignore[attr-defined]
    return event


def _dead_centre_failure(partition: _Partition, theta, t, switching) -> tuple[Status, str]:
    i, (a, b) = partition.independent, partition.pair
    if switching:
        kappa = partition_conditioning(theta)
        return Status.SINGULAR, (  # the whole loop is singular
            f"the loop is singular at t = {t:.6g} s: every angle's dependent pair is near collinear "
            f"(best conditioning {kappa.max():.2g}); all bars lie on one line, so no coordinate is valid"
        )
    return Status.SINGULAR, (
        f"theta{i + 1} stopped being a valid coordinate at t = {t:.6g} s: bars {a + 1} and {b + 1} became "
        f"collinear (a dead centre: the conditioning of theta{i + 1} fell to {partition.conditioning(theta):.2g}, "
        f"limit {DEAD_CENTRE_RCOND:g}); the fixed-coordinate reduced model cannot continue past it, "
        f"choose method 'reduced', which switches coordinates (generalized coordinate partitioning)"
    )


class _Samples:
    def __init__(self):
        self.t, self.theta, self.omega, self.index = [], [], [], []
        self.end_theta = np.zeros(3)  # the state where integration stopped (set by the integration loop)
        self.end_omega = np.zeros(3)

    def add(self, partition, t, theta, omega):
        self.t.append(t)
        self.theta.append(np.array(theta))
        self.omega.append(np.array(omega))
        self.index.append(partition.independent)

    def result(self, L, d, m, g, pin, params, mass_and_forcing, switch_times, status, message, nfev):
        t = np.array(self.t)
        theta = np.array(self.theta).reshape(-1, 3)
        omega = np.array(self.omega).reshape(-1, 3)
        kinetic = np.array([0.5 * w @ mass_and_forcing(th, w, params)[0] @ w for th, w in zip(theta, omega)])
        potential = potential_energy(L, d, m, g, theta) if theta.size else np.zeros(0)
        J = loop_jacobian(L, theta)
        velocity = np.einsum("tij,tj->ti", J, omega) if theta.size else np.zeros((0, 2))
        return ReducedTrajectory(
            t=t,
            theta=theta,
            omega=omega,
            independent_index=np.array(self.index, dtype=int),
            n_switches=len(switch_times),
            switch_times=np.array(switch_times),
            kinetic=kinetic,
            potential=potential,
            energy=kinetic + potential,
            constraint_xy=loop_residual(L, theta, pin) if theta.size else np.zeros((0, 2)),
            constraint_velocity=velocity,
            status=status,
            message=message,
            nfev=nfev,
            conditioning=np.array([partition_conditioning(th) for th in theta]).reshape(-1, 3),
        )


def _collect(out: _Samples, partition: _Partition, sol, theta_start, t_eval, include_start: bool):
    """Append the samples of one segment; dependent angles are unwrapped step by step for continuity."""
    t0, t1 = float(sol.t[0]), float(sol.t[-1])
    if t_eval is None:
        wanted = sol.t if include_start else sol.t[1:]
    else:
        lower = (t_eval >= t0) if include_start else (t_eval > t0)
        wanted = t_eval[lower & (t_eval <= t1)]
    # walk through every accepted step so no dependent angle moves by pi between unwrapping references
    times = np.union1d(sol.t, wanted)
    keep = np.isin(times, wanted)
    y = sol.sol(times)
    reference = np.asarray(theta_start, dtype=float)
    for k, t in enumerate(times):
        theta, omega = partition.state(y[0, k], y[1, k], reference)
        reference = theta
        if keep[k]:
            out.add(partition, float(t), theta, omega)
    # the segment's end state seeds the next segment, whether or not it is an output sample
    out.end_theta, out.end_omega = theta, omega
