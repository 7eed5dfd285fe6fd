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
import time
from pathlib import Path

import numpy as np

from .codegen import load_compiled
from .errors import LinkageError
from .kinematics import energies, joint_positions
from .model import BAUMGARTE_ALPHA, BAUMGARTE_BETA, FORMULATION_NAMES, Chain, check_state

# A copy whose system is this badly conditioned (or non-finite) is marked failed, as simulate() does.
from .simulate.run import SINGULAR_PIVOT_RATIO as SINGULAR_CONDITION  # one threshold for every path
MAX_COUNT = 1_000_000
DEFAULT_STEP = 1.0 / 240.0  # s: 8 steps per frame at 30 frames per second (accuracy in docs/stability.md)
RK4_WORK_ROWS = 7


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
            if not worst <= SINGULAR_CONDITION:
                self._mark_failures()

    def _mark_failures(self) -> None:
        bad = ~(self.condition <= SINGULAR_CONDITION) & self.alive
        if not bad.any():
            return
        first = int(np.flatnonzero(bad)[0])
        if self.alive.all():
            # an infinite condition is a singular matrix; NaN means the state itself stopped being finite
            kind = "became non-finite" if np.isnan(self.condition[first]) else "became singular"
            self.message = (f"copy {first} {kind} at t = {self.time:.6g} s (condition {self.condition[first]:.3g}); "
                            f"failed copies are left out of alive (their states are not to be trusted)")
        self.alive &= ~bad

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
        from .assembly import assemble, project_velocity

        L = chain.array("L")
        pin = np.asarray(chain.pin)
        previous = np.asarray(theta0, float)
        for k in range(count):
            theta[k] = assemble(L, pin, theta[k, : n - 2], theta_prev=previous)
            omega[k] = project_velocity(L, theta[k], omega[k])
            previous = theta[k]
    return np.ascontiguousarray(theta), np.ascontiguousarray(omega)


# ------------------------------------------------------------------------------------------------
# Benchmark (``python -m physics bench --suite ensemble``)

BENCH_COUNTS = (1, 100, 1000, 10000)
BENCH_SECONDS = 1.0  # wall time spent per measurement (at least one step)


def throughput(preset_name: str, method: str, count: int, step: float, seconds: float = BENCH_SECONDS) -> dict:
    """Pendulum-steps per second of ``count`` copies (one core, whatever else runs on the machine)."""
    from .presets import get_preset

    preset = get_preset(preset_name)
    ensemble = Ensemble(preset.chain, preset.theta0, preset.omega0, method=method, count=count, step=step)
    ensemble.run_steps(1)  # loads the compiled code
    steps = 1
    while True:
        start = time.perf_counter()
        ensemble.run_steps(steps)
        elapsed = time.perf_counter() - start
        if elapsed >= 0.2 * seconds or steps >= 1_000_000:
            break
        steps *= 4
    repeats = max(1, int(seconds / max(elapsed, 1e-9)))
    start = time.perf_counter()
    for _ in range(repeats):
        ensemble.run_steps(steps)
    elapsed = time.perf_counter() - start
    rate = count * steps * repeats / elapsed
    return {"preset": preset_name, "method": method, "count": count, "step": step,
            "pendulum_steps_per_second": rate, "alive": int(ensemble.alive.sum())}


def realtime_frame(preset_name: str, method: str, count: int, step: float, fps: float = 30.0) -> dict:
    """Cost of one real-time frame (1/fps simulated seconds) for ``count`` copies, physics only, plus the
    joint positions the app draws; the budget is 1/fps."""
    from .presets import get_preset

    preset = get_preset(preset_name)
    ensemble = Ensemble(preset.chain, preset.theta0, preset.omega0, method=method, count=count, step=step)
    ensemble.advance(1.0 / fps)
    times = []
    for _ in range(max(10, int(fps))):
        start = time.perf_counter()
        ensemble.advance(1.0 / fps)
        ensemble.joints()
        times.append(time.perf_counter() - start)
    frame = float(np.median(times))
    return {"preset": preset_name, "method": method, "count": count, "step": step, "fps_target": fps,
            "frame_seconds": frame, "budget_fraction": frame * fps, "max_fps_physics": 1.0 / frame}


def step_accuracy(preset_name: str, method: str, step: float, t_end: float = 20.0) -> dict:
    """Relative energy drift and tip error after ``t_end`` of a single copy at this step, against DOP853
    at 1e-12: what the fixed step costs in accuracy."""
    from .model import Settings
    from .presets import get_preset
    from .simulate import simulate

    preset = get_preset(preset_name)
    ensemble = Ensemble(preset.chain, preset.theta0, preset.omega0, method=method, count=1, step=step)
    e0 = float(ensemble.energy()[0])
    scale = max(abs(e0), 1.0)
    ensemble.run_steps(int(round(t_end / step)))
    drift = abs(float(ensemble.energy()[0]) - e0) / scale
    reference = simulate(preset.chain, preset.theta0, preset.omega0,
                         Settings(method=method, integrator="DOP853", rtol=1e-12, atol=1e-12,
                                  t_end=ensemble.time, samples=2))
    tip_error = float(np.hypot(*(ensemble.joints()[0, -1] - reference.tip_xy[-1])))
    return {"preset": preset_name, "step": step, "t_end": ensemble.time, "energy_drift": drift,
            "tip_error": tip_error}


def benchmark(out: Path, quick: bool = False, progress: bool = True) -> list[Path]:
    from .bench import Progress, machine_note, write_report

    counts = BENCH_COUNTS[:3] if quick else BENCH_COUNTS
    methods = ("lagrange",) if quick else FORMULATION_NAMES
    seconds = 0.3 if quick else BENCH_SECONDS
    steps = (DEFAULT_STEP,) if quick else (1.0 / 60.0, 1.0 / 120.0, DEFAULT_STEP, 1.0 / 480.0, 1.0 / 960.0)
    bar = Progress(len(counts) * len(methods) + len(methods) + len(steps), "ensemble", progress)
    rows, frames, accuracy = [], [], []
    for method in methods:
        for count in counts:
            rows.append(throughput("triple-c", method, count, DEFAULT_STEP, seconds))
            bar.step(f"{method} N={count}")
        frames.append(realtime_frame("triple-c", method, 1000, DEFAULT_STEP))
        bar.step(f"{method} frame")
    for step in steps:
        accuracy.append(step_accuracy("triple-c", "lagrange", step))
        bar.step(f"step {step:.3g}")
    bar.close()
    document = {"kind": "ensemble", "machine": machine_note(), "throughput": rows, "realtime_1000": frames,
                "step_accuracy": accuracy}
    return write_report(out, "ensemble", document, ensemble_markdown(document))


def ensemble_markdown(document: dict) -> str:
    lines = ["| formulation | N | pendulum-steps / s |", "| --- | --- | --- |"]
    for row in document["throughput"]:
        lines.append(f"| {row['method']} | {row['count']} | {row['pendulum_steps_per_second']:.3g} |")
    lines += ["", "| formulation | 1000 copies, one 1/30 s frame (8 RK4 steps + joints) | share of the 33 ms budget |",
              "| --- | --- | --- |"]
    for row in document["realtime_1000"]:
        lines.append(f"| {row['method']} | {row['frame_seconds'] * 1e3:.3g} ms | {100 * row['budget_fraction']:.0f} % |")
    lines += ["", "| RK4 step (s) | energy drift after 20 s | tip error after 20 s (vs DOP853 1e-12) |",
              "| --- | --- | --- |"]
    for row in document["step_accuracy"]:
        lines.append(f"| {row['step']:.4g} | {row['energy_drift']:.2e} | {row['tip_error']:.2e} |")
    machine = document["machine"]
    lines += ["", f"Machine: {machine['cpus']} CPUs, load average {machine['load_average_1_5_15']}."]
    return "\n".join(lines) + "\n"
