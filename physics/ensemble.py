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

import numpy as np

from .assembly import assemble, project_velocity
from .codegen import load_compiled
from .errors import LinkageError
from .kernels.constants import RK4_WORK_ROWS, SINGULAR_PIVOT_RATIO
from .kinematics import energies, joint_positions
from .model import BAUMGARTE_ALPHA, BAUMGARTE_BETA, FORMULATION_NAMES, Chain, check_state

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
        self._compiled = load_compiled(method, chain.n, chain.pinned)
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

    def run_steps(self, steps: int) -> None:
        """Take ``steps`` RK4 steps (the hot loop: one compiled call per step for the whole batch)."""
        step_batch = self._compiled.rk4_batch_step
        for _ in range(steps):
            worst = step_batch(self.theta, self.omega, self.params, self.step, self._alpha, self._beta,
                               self._work, self.condition)
            self.steps_taken += 1
            if not worst <= SINGULAR_PIVOT_RATIO:
                self._mark_failures()

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
