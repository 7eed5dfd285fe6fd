"""Simulation ahead of the display, and the frame clock that shows it.

One :class:`Player` per session owns one background thread. The thread keeps every run's samples about a
second ahead of the displayed time by calling :func:`physics.simulate` in short chunks (each continuing from
the last stored sample with ``t_start``), and 60 times a second hands the frame at the displayed time to the
session's ``on_frame`` callback, which moves the scene. A change of parameters replaces the runs and wakes
the thread at once: the first chunk after a restart is short and shown as soon as it is computed, so the new
motion appears within a few milliseconds of the change (measured in ``latencies``).

The player knows nothing of viser; it sees runs (one normally, three in compare mode) and samples.
"""

from __future__ import annotations

import collections
import threading
import time
import traceback
from typing import Callable

import numpy as np

from physics.status import Status

from .runs import (
    Frame,
    Restart,
    Run,
    RunFrame,
    RunSpec,
    finite_prefix,
)

SAMPLE_RATE = 60.0  # samples per simulated second; also the display's frames per wall-clock second
SAMPLE_DT = 1.0 / SAMPLE_RATE
HISTORY_SECONDS = 120.0  # what a session keeps for plots and export; bounds its memory
LOOKAHEAD_SECONDS = 1.0  # simulated time kept ready ahead of the display (times the playback speed)
MAX_CHUNK_SECONDS = 2.0
# Chunk lengths adapt to the work a chunk took, counted in right-hand-side evaluations, never to the wall
# clock: a run is then the same, bit for bit, whatever the machine's load or the frame timing (each chunk
# restarts the integrator, so its boundaries shape the result). About half a frame of compute for a triple
# pendulum; the budget shrinks with the square of the chain length, as the cost of one evaluation grows.
CHUNK_WORK_BUDGET = 3000.0  # right-hand-side evaluations per chunk at n = 3
MAX_SPEED = 8.0
# One call of the integrator is given at most this many steps (times (3/n)^2, like the work budget; doubled for a
# run while a call ends before its first new sample, up to the run's own max_steps). A stiff start (a bar of almost
# no inertia between heavy ones) can need a million steps of an explicit integrator per 0.25 s: bounded calls keep
# the player answering restarts meanwhile, and the first new pose comes after about one sample's worth of steps.
CHUNK_STEP_CAP = 3000
# A motion that needs more steps than this for one sample (1/60 s) cannot be played: the cap stops doubling there
# and the run stops with a sentence naming the fix (an implicit integrator, more inertia, less damping). Without it
# the doubling went on to the run's max_steps (1e7), minutes per call on a busy machine, and the restart was never
# shown (the long control run: a damped bar of next to no inertia).
PLAYABLE_STEPS = 250_000
# A frame is skipped while the previous one waits to be sent (see Player), but never for longer than this: a
# browser whose buffer never empties still sees 4 frames per second, and a wrong "not delivered" never freezes.
MAX_DEFER_SECONDS = 0.25
MAX_STEP_SECONDS = MAX_DEFER_SECONDS + 2 * SAMPLE_DT  # most wall time one frame advances the display by


def _chunk_work(traj) -> int:
    """The work a chunk took: right-hand-side evaluations (steps for integrators that count none)."""
    return int(getattr(traj, "n_rhs", 0) or getattr(traj, "n_steps", 0))


def _capped(traj, spec, cap: int) -> bool:
    """The call stopped at the player's step cap, not at the run's own max_steps (nothing failed)."""
    limit = _step_limit(spec.settings)
    return traj.status == Status.MAX_STEPS and limit is not None and cap < limit


def too_stiff(settings, steps: int) -> str:
    """Why a run that reaches no next sample within :data:`PLAYABLE_STEPS` stops, and what would play it."""
    integrator = getattr(settings, "integrator", "the integrator")
    return (f"too stiff to play: {integrator} took {steps:,} steps without reaching the next sample "
            f"({SAMPLE_DT * 1000:.3g} ms on); choose Radau or LSODA (implicit) in the Simulation tab, or give the "
            "bars more inertia or less damping")


def next_chunk_seconds(seconds: float, work: int, n: int) -> float:
    """The next chunk's length from this one's work alone (deterministic: see CHUNK_WORK_BUDGET)."""
    budget = CHUNK_WORK_BUDGET * (3.0 / max(n, 1)) ** 2
    if work > budget and seconds > 2 * SAMPLE_DT:
        return max(2 * SAMPLE_DT, seconds / 2)
    if work < budget / 4:
        return min(MAX_CHUNK_SECONDS, seconds * 2)
    return seconds


def first_step_cap(n: int) -> int:
    """The steps one integrator call of an ``n``-bar run is first given (see CHUNK_STEP_CAP)."""
    return max(1, int(CHUNK_STEP_CAP * (3.0 / max(n, 1)) ** 2))


def _step_limit(settings) -> int | None:
    """The run's own max_steps (None: its integrator counts no steps the player could bound, a mechanism's)."""
    limit = getattr(settings, "max_steps", None)
    return limit if isinstance(limit, int) else None


EXACT_SAMPLE = 1e-6  # of a sample interval: a time this close to a sample's is that sample's


class Player:
    """Background simulation and frame clock of one session.

    ``simulate(chain, theta0, omega0, settings, t_start)`` is physics.simulate (injected, so tests can
    count calls); ``make_settings(settings, t_end, samples)`` returns a copy with the chunk's horizon;
    ``on_frame(frame)`` moves the scene (called on the player thread, under the player's lock);
    ``on_failure(message)`` reports a run that stopped; ``prepare(spec, theta0, omega0)`` runs before a run's
    first chunk (loads compiled code, possibly slowly, with a notice); ``ready_for_frame()`` says whether the
    previous frame has been delivered (app/delivery.py): if not, a playing frame is skipped (the displayed
    time still follows the wall clock) rather than rendered over an unsent one, for at most
    MAX_DEFER_SECONDS. Chunks after the first continue a run and are passed ``continuing=True``: a closed loop's drift belongs to the run and is not re-checked at each chunk.
    """

    def __init__(
        self,
        simulate: Callable,
        make_settings: Callable,
        on_frame: Callable[[Frame], None],
        on_failure: Callable[[str], None],
        prepare: Callable[[RunSpec, np.ndarray, np.ndarray], None] | None = None,
        name: str = "player",
        ready_for_frame: Callable[[], bool] | None = None,
    ) -> None:
        self._simulate = simulate
        self._make_settings = make_settings
        self._on_frame = on_frame
        self._on_failure = on_failure
        self._prepare = prepare or (lambda spec, theta0, omega0: None)
        self._ready_for_frame = ready_for_frame or (lambda: True)
        self.lock = threading.RLock()
        self._wake = threading.Event()
        self._stop = False
        self._pending: Restart | None = None
        self._restarting = False
        self._installing: Restart | None = None  # the restart being installed (popped from _pending)
        self._failure_reported = False
        self.runs: list[Run] = []
        self.generation = 0  # bumped at every restart; chunks of an older generation are dropped
        self.display_time = 0.0
        self.playing = False
        # held (the session designing, app/design_view.py; set by hold()): paused, and a restart installed meanwhile
        # stays paused whatever its request said; only play() plays again (the session's Play
        # leaves design mode first)
        self.held = False
        self.speed = 1.0
        self.frame_counter = 0
        self.frames_deferred = 0  # frame times skipped because the previous frame had not been delivered yet
        self.frame_interval = SAMPLE_DT  # wall seconds between frames; the server widens it under load
        self.latencies: collections.deque[float] = collections.deque(maxlen=256)  # seconds, restart -> pose
        self.last_restart_shown = 0.0  # perf_counter() when the first frame of the latest restart was sent
        self._restart_time: float | None = None
        self._seek_target: float | None = None
        self._seek_done = threading.Event()
        self._last_frame_wall = time.monotonic()
        self._dirty = True  # something to show although the displayed time did not move
        self._last_shown_time: float | None = None
        self._idle_ticks = 0
        self._rate_window: collections.deque[tuple[float, float]] = collections.deque(maxlen=120)
        self.error: str | None = None
        self._thread = threading.Thread(target=self._loop, name=name, daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ commands (any thread)
    def restart(
        self,
        specs: list[RunSpec],
        t0: float,
        starts: list[tuple[np.ndarray, np.ndarray]],
        *,
        keep_history: bool,
        play: bool | None = None,
    ) -> None:
        """Replace the runs, starting each from ``starts[i]`` at time ``t0``.

        ``keep_history``: keep the stored samples up to ``t0`` (a parameter change mid-run); otherwise the
        runs start afresh (reset, new mechanism). Applied by the player thread as soon as it wakes.
        """
        with self.lock:
            earlier = self._pending or self._installing
            if play is None and earlier is not None:
                # "as it is" means as the restart it replaces would leave it: a session's first start (play)
                # followed at once by a link's or a setup's values (None) plays, as without them
                play = earlier.play
            self._pending = Restart(list(specs), float(t0), list(starts), keep_history, time.perf_counter(), play)
        self._wake.set()

    def play(self) -> None:
        with self.lock:
            self.playing = True
            self._last_frame_wall = time.monotonic()
        self._wake.set()

    def pause(self) -> None:
        with self.lock:
            self.playing = False
        self._wake.set()

    def hold(self, on: bool) -> None:
        """Hold the player paused (design mode) or let it go. Pausing and holding are one step under the lock: a
        start already installed and playing is paused here at once, not when a later request is installed, and no
        restart installed while held plays (see ``_install``). Letting go plays nothing: Play does."""
        with self.lock:
            self.held = bool(on)
            if self.held:
                self.playing = False
                self._dirty = True  # the pose shown is redrawn paused
        self._wake.set()

    def touch(self) -> None:
        """Redraw the current frame (an overlay was switched on or off while paused)."""
        with self.lock:
            self._dirty = True
        self._wake.set()

    def set_speed(self, speed: float) -> None:
        with self.lock:
            self.speed = float(min(max(speed, 0.01), MAX_SPEED))

    def step(self, frames: int = 1) -> None:
        """Advance the paused display by ``frames`` samples (waits for them to be simulated)."""
        with self.lock:
            self.playing = False
            if self.runs:
                self._seek_target = self.display_time + frames * SAMPLE_DT
        self._wake.set()

    def seek(self, t: float, timeout: float = 60.0) -> bool:
        """Pause and show time ``t`` (simulating up to it first); blocks until shown or ``timeout``."""
        with self.lock:
            self.playing = False
            self._seek_target = float(t)
            self._seek_done.clear()
        self._wake.set()
        return self._seek_done.wait(timeout)

    def wait_idle(self, timeout: float = 10.0) -> bool:
        """Wait until no restart is pending (the last requested one has been shown)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with self.lock:
                if self._pending is None and not self._restarting and self._restart_time is None:
                    return True
            time.sleep(0.002)
        return False

    def stop(self, timeout: float = 2.0) -> None:
        self._stop = True
        self._wake.set()
        if threading.current_thread() is not self._thread:
            self._thread.join(timeout)

    @property
    def restart_pending(self) -> bool:
        """A restart was asked for and has not been shown yet (the runs in ``runs`` are about to go)."""
        with self.lock:
            return self._pending is not None or self._restarting or self._restart_time is not None

    @property
    def alive(self) -> bool:
        return self._thread.is_alive()

    @property
    def thread(self) -> threading.Thread:
        """The player's thread (after :meth:`stop` it may still finish a chunk: the memory trim waits for it)."""
        return self._thread

    def superseded(self) -> bool:
        """True while the restart being installed is no longer wanted: a newer one waits, or the player stops.
        ``prepare`` polls it to cancel a slow build (app/warm.py kills its worker)."""
        return self._stop or self._pending is not None

    # ------------------------------------------------------------------ state (any thread)
    def state_at(self, t: float, exact: bool = False) -> tuple[np.ndarray, np.ndarray] | None:
        """``(theta, omega)`` of the first run at time ``t``, interpolated linearly between its stored samples
        (1/60 s apart); None when ``t`` is not stored, or with ``exact`` when ``t`` is not a sample's time."""
        with self.lock:
            if not self.runs or len(self.runs[0].ring) < 2:
                return None
            ring = self.runs[0].ring
            x_name, v_name = self.runs[0].spec.state_fields
            if not ring.t_first <= t <= ring.t_last:
                return None
            i = min(ring.index_at(t), len(ring) - 2)
            frac = min(max((t - (ring.t_first + i * ring.dt)) / ring.dt, 0.0), 1.0)
            if exact:
                if min(frac, 1.0 - frac) > EXACT_SAMPLE:
                    return None
                i, frac = (i, 0.0) if frac <= EXACT_SAMPLE else (i + 1, 0.0)
                return ring.get(x_name, i).copy(), ring.get(v_name, i).copy()
            theta = ring.get(x_name, i) + frac * (ring.get(x_name, i + 1) - ring.get(x_name, i))
            omega = ring.get(v_name, i) + frac * (ring.get(v_name, i + 1) - ring.get(v_name, i))
            return np.array(theta), np.array(omega)

    def current_state(self) -> tuple[float, np.ndarray, np.ndarray] | None:
        """``(t, theta, omega)`` of the first run at the sample at or before the displayed time."""
        found = self.current_start()
        return None if found is None else found[1:]

    def current_start(self) -> tuple[RunSpec, float, np.ndarray, np.ndarray] | None:
        """``(spec, t, theta, omega)``: :meth:`current_state` with the run it belongs to, read in one step, so
        that a caller never goes on from a state of another mechanism than the one it asks about."""
        with self.lock:
            request = self._pending or self._installing
            if request is not None:  # a restart not shown yet: its start is the state to go on from
                theta, omega = request.starts[0]
                return request.specs[0], request.t0, np.array(theta, dtype=float), np.array(omega, dtype=float)
            if not self.runs or len(self.runs[0].ring) == 0:
                return None
            run = self.runs[0]
            ring = run.ring
            x_name, v_name = run.spec.state_fields
            i = ring.index_at(self.display_time)
            return run.spec, ring.t_first + i * ring.dt, ring.get(x_name, i).copy(), ring.get(v_name, i).copy()

    def real_time_factor(self) -> float:
        """Simulated seconds shown per wall-clock second over the last two seconds."""
        with self.lock:
            if len(self._rate_window) < 2:
                return 0.0
            (w0, s0), (w1, s1) = self._rate_window[0], self._rate_window[-1]
        return (s1 - s0) / (w1 - w0) if w1 > w0 else 0.0

    # ------------------------------------------------------------------ the thread
    def _loop(self) -> None:
        next_frame = time.monotonic()
        while not self._stop:
            try:
                self._apply_restart()
                produced = self._produce_one()
                now = time.monotonic()
                interval = self.frame_interval
                if self._restart_time is not None and self._ready_to_show():
                    self._render(now, restarted=True)
                    next_frame = now + interval
                elif self._seek_target is not None and self._seek_ready():
                    self._render(now)
                    next_frame = now + interval
                elif now >= next_frame:
                    self._render(now)
                    next_frame += interval
                    if next_frame < now:  # fell behind (slow integrator): skip frames, do not burst
                        next_frame = now + interval
                if produced and time.monotonic() < next_frame - 0.002:
                    continue  # more to compute and time left before the next frame
                self._wake.wait(max(0.0, next_frame - time.monotonic()))
                self._wake.clear()
            except Exception as error:  # never let one session's error kill its thread silently
                traceback.print_exc()
                with self.lock:
                    self.playing = False
                    self.error = f"{type(error).__name__}: {error}"
                    self._restart_time = None
                    self._pending = None
                    self._seek_target = None
                    self._seek_done.set()
                try:
                    self._on_failure(f"internal error in the player: {self.error}")
                except Exception:
                    traceback.print_exc()
                self._wake.wait(0.5)
                self._wake.clear()
        self._release()

    def _release(self) -> None:
        """Drop the samples when the thread ends (the session closed): a closed session's objects are freed
        only by Python's cyclic collector, often minutes later, but its rings (the bulk of its memory) go now,
        so a server's memory follows its audience (app/memory.py)."""
        with self.lock:
            self.runs = []
            self._pending = None
            self._installing = None

    def _apply_restart(self) -> None:
        with self.lock:
            pending, self._pending = self._pending, None
            if pending is not None:
                self._restarting = True
                self._installing = pending
        if pending is None:
            return
        try:
            self._install(pending)
        finally:
            with self.lock:
                self._restarting = False
                self._installing = None

    def _install(self, pending: Restart) -> None:
        """Replace the runs by ``pending``'s; the slow parts (loading code, the first sample) run unlocked."""
        for spec, (theta0, omega0) in zip(pending.specs, pending.starts):
            if self.superseded():  # a burst of edits: only the last one is prepared and shown
                return
            try:
                self._prepare(spec, theta0, omega0)  # may take long on a cold cache (deriving, compiling)
            except Exception:
                if self.superseded():  # cancelled for the newer request, which the loop installs next
                    return
                raise
        seeds = [self._seed(spec, pending.t0, *start) for spec, start in zip(pending.specs, pending.starts)]
        with self.lock:
            if self._pending is not None:  # a newer request arrived meanwhile: it wins
                return
            old = {run.spec.label: run for run in self.runs}
            runs = []
            for spec, (sample, failed) in zip(pending.specs, seeds):
                capacity = int((HISTORY_SECONDS + LOOKAHEAD_SECONDS * MAX_SPEED + MAX_CHUNK_SECONDS) * SAMPLE_RATE)
                prev = old.get(spec.label)
                if (
                    pending.keep_history
                    and prev is not None
                    and prev.spec.layout == spec.layout
                    and len(prev.ring)
                ):
                    ring = prev.ring
                    ring.truncate_after(ring.index_at(pending.t0))
                    # the start state replaces the stored sample at t0 (e.g. a re-assembled loop)
                    ring.truncate_after(len(ring) - 2)
                else:
                    ring = spec.new_ring(capacity, SAMPLE_DT)
                ring.append(sample)
                runs.append(Run(spec=spec, ring=ring, com_ratio=spec.com_ratio(), failed=failed))
            self.runs = runs
            self._failure_reported = False
            self.generation += 1
            self.display_time = pending.t0
            self._restart_time = pending.requested_at
            self._rate_window.clear()
            if pending.play is not None:
                self.playing = pending.play and not self.held
            self._last_frame_wall = time.monotonic()

    def _seed(self, spec: RunSpec, t0: float, theta0: np.ndarray, omega0: np.ndarray) -> tuple[dict, str | None]:
        """The start state as a run's first sample, and the failure message if it cannot move.

        A one-sample-interval simulation gives every field. If the start cannot be integrated at all (a
        singular position), the sample is built from kinematics alone, so the scene still shows where the
        mechanism stands."""
        cap = first_step_cap(spec.work_n)
        try:
            traj = self._simulate_chunk(spec, t0, theta0, omega0, 0, step_cap=cap)
        except ValueError as error:  # LinkageError: e.g. a start that does not close the loop
            traj, message = None, str(error)
        else:
            message = traj.message
        if traj is not None and len(traj.t) > 0:
            chunk = {k: v[:1] for k, v in spec.chunk(traj).items()}
            if finite_prefix(chunk, spec.state_fields) == 1:
                stopped = traj.status < 0 and len(traj.t) < 2 and not _capped(traj, spec, cap)
                failed = message if stopped else None
                return chunk, failed
        return spec.still_sample(t0, theta0, omega0), message or "the start state could not be evaluated"

    def _simulate_chunk(self, spec: RunSpec, t0: float, theta0, omega0, steps: int, continuing: bool = False,
                        step_cap: int | None = None):
        """Simulate ``steps`` sample intervals from ``t0``; ``steps = 0`` evaluates the start state only. At most
        ``step_cap`` integrator steps (when below the run's own max_steps: see CHUNK_STEP_CAP)."""
        horizon = max(steps, 1) * SAMPLE_DT
        settings = self._make_settings(spec.settings, horizon, max(steps, 1) + 1)
        limit = _step_limit(settings)
        if step_cap is not None and limit is not None and step_cap < limit:
            settings = settings.model_copy(update={"max_steps": step_cap})
        simulate = spec.simulate or self._simulate
        if continuing:
            return simulate(spec.chain, theta0, omega0, settings, t_start=t0, continuing=True)
        return simulate(spec.chain, theta0, omega0, settings, t_start=t0)

    def _needs_more(self, run: Run) -> bool:
        if run.failed is not None or len(run.ring) == 0:
            return False
        ahead = LOOKAHEAD_SECONDS * max(self.speed, 1.0)
        target = self.display_time + ahead
        if self._seek_target is not None:
            target = max(target, self._seek_target + SAMPLE_DT)
        return run.ring.t_last < target

    def _produce_one(self) -> bool:
        """Simulate one chunk for the run that is furthest behind; True if something was computed."""
        with self.lock:
            candidates = [run for run in self.runs if self._needs_more(run)]
            if not candidates:
                return False
            run = min(candidates, key=lambda r: r.ring.t_last)
            generation = self.generation
            i = len(run.ring) - 1
            t0 = run.ring.t_last
            theta0 = run.ring.get(run.spec.state_fields[0], i).copy()
            omega0 = run.ring.get(run.spec.state_fields[1], i).copy()
            seconds = run.chunk_seconds
            spec = run.spec
            cap = run.step_cap or first_step_cap(spec.work_n)
        steps = max(1, int(round(seconds * SAMPLE_RATE)))
        started = time.perf_counter()
        try:
            traj = self._simulate_chunk(spec, t0, theta0, omega0, steps, continuing=True, step_cap=cap)
        except ValueError as error:  # LinkageError for this start: the run stops here, with its message
            with self.lock:
                if generation == self.generation and run in self.runs:
                    run.failed = str(error)
            return True
        elapsed = time.perf_counter() - started
        with self.lock:
            if generation != self.generation or run not in self.runs:
                return True  # a restart happened meanwhile: this chunk belongs to the past
            run.compute_seconds += elapsed
            chunk = spec.chunk(traj)
            chunk = {k: v[1:] for k, v in chunk.items()}  # the first sample is the stored start
            good = finite_prefix(chunk, spec.state_fields)
            run.ring.append({k: v[:good] for k, v in chunk.items()})
            run.simulated_seconds += good * SAMPLE_DT
            if _capped(traj, spec, cap) and good == len(chunk["t"]):  # not a failure: the next call goes on
                if good == 0 and cap >= PLAYABLE_STEPS:
                    run.failed = too_stiff(spec.settings, cap)
                else:
                    run.step_cap = cap if good else 2 * cap  # no new sample within the cap: twice as many
            elif traj.status < 0:
                run.failed = traj.message or f"simulation failed (status {traj.status})"
            elif good < len(chunk["t"]):
                run.failed = f"the state became non-finite at t = {t0 + (good + 1) * SAMPLE_DT:.4g} s"
            elif len(chunk["t"]) < steps:
                run.failed = traj.message or "the simulation stopped early"
            run.chunk_seconds = next_chunk_seconds(run.chunk_seconds, _chunk_work(traj), spec.work_n)
        return True

    def _available_until(self) -> float:
        """The latest time every run can show (the slowest run's newest sample)."""
        return min(run.ring.t_last for run in self.runs) if self.runs else 0.0

    def _ready_to_show(self) -> bool:
        with self.lock:
            if self._pending is not None:
                return False
            return all(len(run.ring) > 1 or run.failed is not None for run in self.runs)

    def _seek_ready(self) -> bool:
        with self.lock:
            if self._seek_target is None:
                return False
            if self._available_until() >= self._seek_target - 1e-9:
                return True
            return any(run.failed is not None for run in self.runs)  # cannot get there

    def _render(self, now: float, restarted: bool = False) -> None:
        if (not restarted and self._seek_target is None and self.playing
                and now - self._last_frame_wall < MAX_DEFER_SECONDS and not self._ready_for_frame()):
            with self.lock:
                self.frames_deferred += 1
            return
        with self.lock:
            wall_dt = now - self._last_frame_wall
            self._last_frame_wall = now
            if not self.runs:
                return
            limit = self._available_until()
            failed = [run.failed for run in self.runs if run.failed is not None]
            if self._seek_target is not None:
                self.display_time = min(self._seek_target, limit)
                if self._seek_target <= limit + 1e-9 or failed:
                    self._seek_target = None
                    self._seek_done.set()
            elif self.playing and not restarted:
                # real time across deferred frames; a longer stall (a busy machine) does not jump ahead
                self.display_time = min(self.display_time + self.speed * min(wall_dt, MAX_STEP_SECONDS), limit)
            self._rate_window.append((now, self.display_time))
            moved = self.display_time != self._last_shown_time
            if not (restarted or moved or self._dirty):
                # paused and unchanged: only refresh the status line now and then (4 Hz)
                self._idle_ticks += 1
                if self._idle_ticks % 15:
                    return
            self._dirty = False
            self._last_shown_time = self.display_time
            frames = []
            for run in self.runs:
                ring = run.ring
                if len(ring) == 0:
                    continue
                i = ring.index_at(self.display_time)
                joints = ring.get("joints", i)
                com = ring.get("com", i) if ring.has("com") else None  # a mechanism stores its centres of mass
                if i + 1 < len(ring):
                    frac = (self.display_time - (ring.t_first + i * ring.dt)) / ring.dt
                    frac = min(max(frac, 0.0), 1.0)
                    joints = joints + frac * (ring.get("joints", i + 1) - joints)
                    if com is not None:
                        com = com + frac * (ring.get("com", i + 1) - com)
                joints = np.array(joints)
                if com is None:
                    com = joints[:-1] + run.com_ratio[:, None] * (joints[1:] - joints[:-1])
                com = np.array(com)
                frames.append(RunFrame(run.spec.label, i, joints, com))
            self.frame_counter += 1
            frame = Frame(self.display_time, frames, restarted, self._restart_time, self.frame_counter)
            self._on_frame(frame)
            if restarted and self._restart_time is not None:
                self.last_restart_shown = time.perf_counter()
                self.latencies.append(self.last_restart_shown - self._restart_time)
                self._restart_time = None
            at_end = failed and self.display_time >= limit - 1e-9
            if at_end and not self._failure_reported:  # once per restart, however the display got there
                self._failure_reported = True
                self.playing = False
                message = failed[0]
            else:
                message = None
        if message is not None:
            self._on_failure(message)
