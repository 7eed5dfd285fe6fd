"""Ensembles: N copies of one mechanism, started a hair apart, advanced together with a fixed-step RK4.

Why: a chaotic pendulum is best understood by watching many nearly identical starts fan apart, and the
chaos map needs thousands of independent runs. Both want throughput, not adaptivity: every copy takes the
same fixed step, so the whole batch advances in one call of the generated module's ``rk4_batch_step``
(compiled with the right-hand side; one state after another on one core, no per-step Python work per copy).

Copy k starts at ``theta0 + k * spread`` (every angle shifted by the same amount) and ``omega0``; for a
closed loop, only the driving angles are shifted and the rest re-assembled, and Baumgarte terms hold the
loop (the batched step has no projection). Time advances in whole steps: ``advance(dt)`` takes as many
steps as fit, carrying the remainder, so the trajectory never depends on the frame rate that asked for it.
"""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import LinkageError
from .kernels.constants import RK4_WORK_ROWS, SINGULAR_PIVOT_RATIO
from .kinematics import energies, joint_positions
from .loop_closure import assemble, project_velocity

if TYPE_CHECKING:  # the general engine is loaded only for a mechanism's ensemble (a chain's start stays lean)
    from .mechanism.description import Mechanism
    from .simulate.trajectory import Trajectory
from .model import BAUMGARTE_ALPHA, BAUMGARTE_BETA, FORMULATION_NAMES, Chain, check_state
from .registry import METHODS
from .simulate.chain_system import chain_system

# A copy whose system's pivot ratio exceeds SINGULAR_PIVOT_RATIO (or is non-finite) is marked failed, as
# simulate() does: one threshold for every path.
MAX_COUNT = 1_000_000
DEFAULT_STEP = 1.0 / 240.0  # s: 8 steps per frame at 30 frames per second (accuracy in docs/stability.md)


class Ensemble:
    """``count`` perturbed copies of ``chain`` advanced in lockstep by RK4 with step ``step``.

    ``theta``, ``omega``: current states, shape ``(count, n)``; ``time``: simulated seconds so far;
    ``alive``: copies whose every step stayed finite and well conditioned; ``message`` says what failed.
    """

    def __init__(
        self,
        chain: Chain,
        theta0,
        omega0,
        method: str = "lagrange",
        count: int = 100,
        spread: float = 1e-9,
        step: float = DEFAULT_STEP,
        damping: float = 0.0,
    ):
        if method not in FORMULATION_NAMES:
            raise LinkageError(f"method = {method!r}: ensembles use {', '.join(FORMULATION_NAMES)}")
        if not (isinstance(count, (int, np.integer)) and 1 <= count <= MAX_COUNT):
            raise LinkageError(f"count = {count}: allowed range 1 <= count <= {MAX_COUNT}")
        if not (math.isfinite(spread) and abs(spread) <= 1.0):
            raise LinkageError(f"spread = {spread}: allowed range -1 <= spread <= 1 (radians between copies)")
        if not (math.isfinite(step) and 0.0 < step <= 0.1):
            raise LinkageError(f"step = {step}: allowed range 0 < step <= 0.1 s")
        theta0, omega0 = check_state(chain.n, theta0, omega0)
        self.chain = chain
        self.method = method
        self.count = int(count)
        self.spread = float(spread)
        self.step = float(step)
        self.n = chain.n
        self.params = chain.params(damping=damping)
        self.lengths = chain.array("L")
        # the system physics.simulate integrates, the chain as a mechanism (whose coordinates may be the angles
        # in another order: run_steps permutes in and out)
        self._system = chain_system(chain, method, damping)
        self._compiled = self._system.compiled
        self._identity = bool(np.array_equal(self._system.order, np.arange(self.n)))
        self._alpha, self._beta = (BAUMGARTE_ALPHA, BAUMGARTE_BETA) if chain.pinned else (0.0, 0.0)
        self.theta, self.omega = initial_states(chain, theta0, omega0, self.count, self.spread)
        self._work = np.empty((RK4_WORK_ROWS, self.n))
        self.condition = np.zeros(self.count)
        self.alive = np.ones(self.count, dtype=bool)
        self.steps_taken = 0
        self._pending = 0.0
        self.message = "ok"

    @property
    def time(self) -> float:
        return self.steps_taken * self.step

    def advance(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Advance by ``dt`` seconds (in whole steps; the remainder carries over); return copies of
        ``(theta (N, n), omega (N, n))``."""
        if not (math.isfinite(dt) and dt >= 0.0):
            raise LinkageError(f"dt = {dt}: must be a finite number of seconds >= 0")
        self._pending += dt
        steps = int(math.floor(self._pending / self.step + 1e-9))
        self._pending = max(0.0, self._pending - steps * self.step)
        self.run_steps(steps)
        return self.theta.copy(), self.omega.copy()

    def prepare(self) -> None:
        """Compile the batch step now, on a scratch copy of copy 0 (the states are not touched). Why: its first
        call compiles (seconds; two minutes on a loaded 2-core machine from an empty cache), and whoever builds
        copies in a worker (the app) must not leave that to the first :meth:`advance`, which runs on the
        display's frame thread and would stall every frame meanwhile."""
        theta, omega = self._system.coordinates(self.theta[:1]), self._system.coordinates(self.omega[:1])
        self._compiled.rk4_batch_step(theta, omega, self._system.params, self.step, self._alpha, self._beta,
                                      np.empty_like(self._work), np.zeros(1))

    def run_steps(self, steps: int) -> None:
        """Take ``steps`` RK4 steps (the hot loop: one compiled call per step for the whole batch). The states
        are stepped in the system's coordinate order and put back in the chain's once per call (nothing to do
        where the system's order is the chain's)."""
        if steps <= 0:
            return
        step_batch = self._compiled.rk4_batch_step
        params = self._system.params
        if self._identity:
            theta, omega = self.theta, self.omega
        else:
            theta, omega = self._system.coordinates(self.theta), self._system.coordinates(self.omega)
        try:
            for _ in range(steps):
                worst = step_batch(theta, omega, params, self.step, self._alpha, self._beta, self._work,
                                   self.condition)
                self.steps_taken += 1
                if not worst <= SINGULAR_PIVOT_RATIO:
                    self._mark_failures()
        finally:
            if not self._identity:
                self.theta[...] = self._system.bars(theta)
                self.omega[...] = self._system.bars(omega)

    def _mark_failures(self) -> None:
        bad = ~(self.condition <= SINGULAR_PIVOT_RATIO) & self.alive
        if not bad.any():
            return
        first = int(np.flatnonzero(bad)[0])
        if self.alive.all():
            # an infinite condition is a singular matrix; NaN means the state itself stopped being finite
            kind = "became non-finite" if np.isnan(self.condition[first]) else "became singular"
            self.message = (f"copy {first} {kind} at t = {self.time:.6g} s (condition {self.condition[first]:.3g}); "
                            f"failed copies are left out of alive (their states are not to be trusted)")
        self.alive &= ~bad

    @property
    def pending(self) -> float:
        """Seconds asked of :meth:`advance` but not yet stepped (less than one step): the copies' states are
        this much behind the time asked."""
        return self._pending

    def anchor(self, theta, omega) -> float:
        """Shift every copy by the same amount so that copy 0 (started exactly at the given start) is at
        ``(theta, omega)``: the state a more accurate run (the app's displayed one) has reached at this time.

        Why: the copies are advanced by fixed-step RK4 and the displayed run by an adaptive integrator; their
        difference, however small, grows as fast as the copies' own spread in a chaotic motion, so the whole fan
        would drift away from the displayed pendulum. Shifting all copies together keeps their differences (the
        spread, computed by one integrator for all) and removes the common drift. Returns the size of the shift
        (largest entry, rad or rad/s)."""
        theta = np.asarray(theta, dtype=float).reshape(self.theta.shape[1])
        omega = np.asarray(omega, dtype=float).reshape(self.omega.shape[1])
        shift_theta, shift_omega = theta - self.theta[0], omega - self.omega[0]
        if not (np.all(np.isfinite(shift_theta)) and np.all(np.isfinite(shift_omega))):
            raise LinkageError("anchor: the state must be finite")
        self.theta += shift_theta[None, :]
        self.omega += shift_omega[None, :]
        return float(max(np.max(np.abs(shift_theta)), np.max(np.abs(shift_omega))))

    def joints(self) -> np.ndarray:
        """Joint positions O, 1..n of every copy: shape ``(N, n + 1, 2)``."""
        return joint_positions(self.lengths, self.theta)

    def energy(self) -> np.ndarray:
        """Total energy of every copy, shape ``(N,)``."""
        return energies(self.params, self.theta, self.omega)[2]

    def tip_spread(self) -> float:
        """Largest distance of any living copy's tip from copy 0's tip: how far the fan has opened."""
        tips = self.joints()[:, -1, :]
        living = tips[self.alive]
        if living.size == 0:
            return float("nan")
        return float(np.max(np.hypot(*(living - tips[0]).T)))


def initial_states(chain: Chain, theta0, omega0, count: int, spread: float) -> tuple[np.ndarray, np.ndarray]:
    """Copy k: every angle shifted by ``k * spread`` (open chains), or the driving angles shifted and the loop
    re-assembled with velocities projected onto it (closed chains). Shapes ``(count, n)``."""
    n = chain.n
    offsets = spread * np.arange(count, dtype=float)
    theta = np.asarray(theta0, float)[None, :] + offsets[:, None]
    omega = np.tile(np.asarray(omega0, float), (count, 1))
    if chain.pinned:
        L = chain.array("L")
        pin = np.asarray(chain.pin)
        previous = np.asarray(theta0, float)
        for k in range(count):
            theta[k] = assemble(L, pin, theta[k, : n - 2], theta_prev=previous)
            omega[k] = project_velocity(L, theta[k], omega[k])
            previous = theta[k]
    return np.ascontiguousarray(theta), np.ascontiguousarray(omega)


# ------------------------------------------------------------------------------------------------
# Any mechanism (physics.mechanism): copies run one by one through the general engine

MAX_MECHANISM_COUNT = 1000  # each copy is a whole run of simulate_mechanism (about 0.1-1 s for a few seconds)
_FAILURE_TIME = re.compile(r"t = ([-+0-9.eE]+) s")


def probe_reference(mechanism: Mechanism) -> str:
    """``body.point`` an ensemble (and a study) follows: the traced point, else the last body's last point (a chain
    written as a mechanism: its tip)."""
    if mechanism.trace is not None and not mechanism.trace.startswith("ground."):
        return mechanism.trace
    last = mechanism.bodies[-1]
    return f"{last.name}.{list(last.points)[-1]}"


def point_path(mechanism: Mechanism, q: np.ndarray, reference: str) -> np.ndarray:
    """Where the point ``body.point`` is at every pose of ``q (T, 3 B)``: shape ``(T, 2)``. A body's ``q`` is its
    centre of mass and its rotation from the sketch, so a point drawn at ``p`` moves to ``r + R(phi) (p - c)``."""
    name, _, point = reference.partition(".")
    k = [body.name for body in mechanism.bodies].index(name)
    body = mechanism.body(name)
    arm = np.subtract(body.points[point], body.centre)
    q = np.atleast_2d(q)
    x, y, phi = q[:, 3 * k], q[:, 3 * k + 1], q[:, 3 * k + 2]
    c, s = np.cos(phi), np.sin(phi)
    return np.column_stack([x + c * arm[0] - s * arm[1], y + s * arm[0] + c * arm[1]])


class MechanismEnsemble:
    """``count`` copies of any mechanism, copy k started with every body turned ``k * spread`` rad further than
    the start (``q0``, default the assembled sketch) and closed again by the engine's assembly, at rest or at
    ``qdot0`` projected onto the constraints; each run by :func:`physics.mechanism.simulate.simulate_mechanism`
    over ``t_end`` seconds at ``samples`` times.

    Why not the chains' batched RK4: a general mechanism has no batched kernel yet, so each copy is a whole run
    of the general engine (the chosen integrator, DOP853 by default, method and stabilisation); the results have the
    chain ensemble's shape. A mechanism its motors fully drive (mobility 0) has one pose at each instant, so
    every copy follows the same path and the fan never opens (``note`` says so). A copy whose run stops (a
    singular pose) is left out of ``alive`` from the time its message names; ``message`` quotes the first.
    """

    def __init__(self, mechanism: Mechanism, count: int = 20, spread: float = 1e-9, t_end: float = 2.0,
                 samples: int = 101, method: str = "dae", stabilization: str = "projection", rtol: float = 1e-10,
                 atol: float = 1e-10, q0=None, qdot0=None, integrator: str = "DOP853", step: float | None = None,
                 max_steps: int | None = None, backend: str = "compiled"):
        if not (isinstance(count, (int, np.integer)) and 1 <= count <= MAX_MECHANISM_COUNT):
            raise LinkageError(f"count = {count}: allowed range 1 <= count <= {MAX_MECHANISM_COUNT} for a mechanism "
                               "(each copy is a whole run of the general engine)")
        if not (math.isfinite(spread) and abs(spread) <= 1.0):
            raise LinkageError(f"spread = {spread}: allowed range -1 <= spread <= 1 (radians between copies)")
        from .mechanism.assembly import assemble as assemble_mechanism  # noqa: PLC0415 - see TYPE_CHECKING above
        from .mechanism.simulate import run_options  # noqa: PLC0415

        # every other option is checked by the engine's own boundary, with its one line
        integration: dict[str, Any] = dict(integrator=integrator, step=step, max_steps=max_steps, backend=backend)
        run_options(t_end=t_end, samples=samples, t_start=0.0, method=method, stabilization=stabilization,
                    rtol=rtol, atol=atol, **integration)
        self.mechanism = mechanism
        self.count, self.spread = int(count), float(spread)
        self.options: dict[str, Any] = dict(method=method, stabilization=stabilization, rtol=rtol, atol=atol,
                                            **integration)
        if METHODS[method].reduced:  # its loops close by position analysis: no stabilisation to pass
            self.options.pop("stabilization")
        self.t_end, self.samples = float(t_end), int(samples)
        start = assemble_mechanism(mechanism, None if q0 is None else np.asarray(q0, dtype=float))
        self.mobility = start.mobility
        self.start = start.q
        self.qdot0 = qdot0
        self.probe = probe_reference(mechanism)
        self.t = np.linspace(0.0, self.t_end, self.samples)
        self.runs: list[Trajectory | None] = []
        self.failed_at = np.full(self.count, np.inf)  # the time each copy's run stopped (inf: it did not)
        self.message = "ok"
        self.note = ("the motors fix every body (mobility 0): every copy follows the same path"
                     if self.mobility == 0 else "")

    def start_of(self, k: int) -> np.ndarray:
        """Copy k's start before assembly: every body turned ``k * spread`` rad."""
        q = self.start.copy()
        q[2::3] += k * self.spread
        return q

    def run(self, progress=None) -> MechanismEnsemble:
        """Run every copy (``progress(k)`` after each, if given); returns self."""
        from .mechanism.simulate import simulate_mechanism  # noqa: PLC0415 - see TYPE_CHECKING above

        for k in range(self.count):
            try:
                run = simulate_mechanism(self.mechanism, self.t_end, self.samples, q0=self.start_of(k),
                                         qdot0=self.qdot0, **self.options)
                if int(getattr(run, "status", 0)) != 0:  # an engine that keeps a stopped run's samples
                    raise LinkageError(f"{getattr(run, 'message', 'stopped')} (t = {float(run.t[-1]):g} s)")
                self.runs.append(run)
            except (LinkageError, np.linalg.LinAlgError) as error:  # a copy that stops is a failed copy, not the end
                self.runs.append(None)
                found = _FAILURE_TIME.search(str(error))
                self.failed_at[k] = float(found.group(1)) if found else 0.0
                if self.message == "ok":
                    self.message = f"copy {k}: {error}; failed copies are left out of alive from then on"
            if progress is not None:
                progress(k)
        return self

    @property
    def alive(self) -> np.ndarray:
        """Copies whose runs reached the end, shape ``(count,)``."""
        return np.isinf(self.failed_at)

    def alive_counts(self) -> np.ndarray:
        """Living copies at each sample time, shape ``(samples,)``."""
        return np.sum(self.t[:, None] < self.failed_at[None, :], axis=1)

    def tips(self) -> np.ndarray:
        """The probe point of every copy at every sample, ``(count, samples, 2)``; NaN for a failed copy."""
        out = np.full((self.count, self.samples, 2), np.nan)
        for k, run in enumerate(self.runs):
            if run is not None:
                out[k] = point_path(self.mechanism, run.q, self.probe)
        return out

    def tip_spread(self) -> np.ndarray:
        """Largest distance of any living copy's probe point from copy 0's at each sample (NaN if copy 0 failed)."""
        tips = self.tips()
        distance = np.hypot(*(tips - tips[0][None, :, :]).transpose(2, 0, 1))
        with np.errstate(invalid="ignore"):
            return np.where(np.isnan(distance).all(axis=0), np.nan, np.nanmax(np.where(
                np.isnan(distance), -np.inf, distance), axis=0)) if self.alive[0] else np.full(self.samples, np.nan)

    def energy_drift(self) -> np.ndarray:
        """Largest ``|E - E0|`` over the living copies at each sample, over the largest ``|E0|`` (as the chain
        ensemble's; a motor does work, so a driven mechanism's energy is not conserved)."""
        energies_ = np.array([run.energy for run in self.runs if run is not None])
        if energies_.size == 0:
            return np.full(self.samples, np.nan)
        scale = max(float(np.max(np.abs(energies_[:, 0]))), 1e-300)
        return np.max(np.abs(energies_ - energies_[:, :1]), axis=0) / scale

    def outlines(self) -> np.ndarray:
        """Every body's points in order at the end of each run, ``(count, points, 2)`` (NaN for a failed copy): the
        polylines :func:`physics.studies.charts.fan_picture` draws."""
        names = [f"{body.name}.{point}" for body in self.mechanism.bodies for point in body.points]
        out = np.full((self.count, len(names), 2), np.nan)
        for k, run in enumerate(self.runs):
            if run is not None:
                out[k] = [point_path(self.mechanism, run.q[-1], name)[0] for name in names]
        return out

    def columns(self) -> dict[str, list]:
        """The time series the chain ensemble writes: ``t, tip_spread, alive, energy_drift``."""
        return {"t": self.t.tolist(), "tip_spread": self.tip_spread().tolist(),
                "alive": self.alive_counts().tolist(), "energy_drift": self.energy_drift().tolist()}

    def document(self) -> dict:
        """The chain ensemble's JSON keys (``method, count, spread, t, tip_spread, alive, energy_drift, message,
        final_tips``) with the mechanism's: its name, mobility, stabilisation, the probe point and the note."""
        tips = self.tips()
        return {"mechanism": self.mechanism.name, "mobility": self.mobility, "method": self.options["method"],
                "stabilization": self.options.get("stabilization", "position analysis"), "count": self.count,
                "spread": self.spread, "t_end": self.t_end, "probe": self.probe, **self.columns(),
                "message": self.message, "note": self.note, "final_tips": tips[:, -1, :].tolist()}
