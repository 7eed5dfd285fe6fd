"""Long runs on the command line: estimated up front, reported while they run, stopped by Ctrl+C with what they
computed.

Why: the compiled integrators run a whole horizon inside one compiled call, which neither prints nor notices
Ctrl+C, and an adaptive run's cost is unknown before it starts (``simulate --t-end 1e6`` ran for minutes
without a word). So :func:`simulate_in_segments` first runs the request with a small step budget
(``PROBE_STEPS``): most runs finish inside it, unchanged. One that does not is measured (integration steps
per simulated second, seconds per step) and refused at once when the estimate exceeds ``max_steps``; else it
goes on in segments of about ``SEGMENT_SECONDS`` each, from the last state reached, printing a progress line on
stderr every ``PROGRESS_EVERY`` seconds. Ctrl+C between or inside a segment ends the run with the samples
computed so far (the caller writes them to ``OUT.partial`` and exits 3). A segment restarts the adaptive
integrator at its start, so a segmented run agrees with an unsegmented one to the tolerance, not bit for bit.
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Any, TextIO

import numpy as np

from .errors import LinkageError
from .model import DEFAULT_MAX_STEPS, MAX_STEPS_LIMIT, Chain, Settings
from .notices import notify
from .registry import INTEGRATORS, METHODS
from .simulate import simulate
from .simulate.chain_system import chain_system
from .simulate.trajectory import Trajectory
from .status import Status

PROBE_STEPS = 20_000  # the first call's step budget: a run within it is done in one call, as always
SEGMENT_SECONDS = 1.0  # wall time aimed at per segment: how soon Ctrl+C and a progress line can come
MIN_SEGMENT_STEPS = 10  # bounds of a segment in integration steps, whatever the measured pace says
MAX_SEGMENT_STEPS = 10_000_000
PROGRESS_EVERY = 3.0  # seconds between progress lines
PROGRESS_AFTER = 5.0  # runs estimated shorter than this print no progress line


def duration_text(seconds: float) -> str:
    """``42 s``, ``3.5 min``, ``2.1 h``."""
    if seconds < 10:
        return f"{seconds:.2g} s"
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.1f} h"


class ProgressLine:
    """``simulated 120.0 of 1000000 s (0.01 %), about 3.2 min left`` on stderr, at most every PROGRESS_EVERY s."""

    def __init__(self, total: float, what: str = "simulated", stream: TextIO | None = None):
        self.total = total
        self.what = what
        self.stream = stream  # None: through logging ("physics.long_run", physics.notices), one line each
        self.start = time.perf_counter()
        self.last = self.start
        self.printed = 0

    def update(self, done: float, seconds_left: float | None = None) -> None:
        now = time.perf_counter()
        if now - self.last < PROGRESS_EVERY:
            return
        self.last = now
        if seconds_left is None:
            rate = done / max(now - self.start, 1e-9)
            seconds_left = (self.total - done) / rate if rate > 0 else math.inf
        left = f", about {duration_text(seconds_left)} left" if math.isfinite(seconds_left) else ""
        line = f"{self.what} {done:.6g} of {self.total:.6g} s ({100.0 * done / self.total:.2f} %){left}"
        if self.stream is None:
            notify(line, "physics.long_run")
        else:
            print(line, file=self.stream, flush=True)
        self.printed += 1


def _rows(trajectory: Trajectory, keep: slice | np.ndarray) -> dict:
    """The per-sample arrays of ``trajectory`` cut to ``keep`` (axis 0), by field name."""
    count = len(trajectory.t)
    return {f.name: getattr(trajectory, f.name)[keep] for f in dataclasses.fields(trajectory)
            if isinstance(getattr(trajectory, f.name), np.ndarray) and getattr(trajectory, f.name).shape[:1] == (count,)}


def _joined(first: Trajectory, pieces: list[dict], times: np.ndarray) -> Trajectory:
    """One Trajectory from the probe's rows and the segments' rows; ``t`` the requested sample times exactly."""
    fields: dict[str, Any] = {name: np.concatenate([piece[name] for piece in pieces], axis=0) for name in pieces[0]}
    fields["t"] = times[: len(fields["t"])]
    return dataclasses.replace(first, **fields)


def _estimate_refusal(settings: Settings, steps: float, reached: float, seconds_per_step: float) -> str:
    estimate = steps / reached * settings.t_end
    return (
        f"t_end = {settings.t_end:g} s: about {estimate:.3g} integration steps (the first {steps:.0f} reached "
        f"t = {reached:.4g} s), more than max_steps = {settings.max_steps:.3g} (about "
        f"{duration_text(estimate * seconds_per_step)} at the measured {seconds_per_step * 1e6:.3g} us a step); "
        f"shorten --t-end, loosen --rtol/--atol, or raise --max-steps (at most {MAX_STEPS_LIMIT:.0e})"
    )


def simulate_in_segments(chain: Chain, theta0, omega0, settings: Settings, stream: TextIO | None = None) -> Trajectory:
    """``physics.simulate`` for the command line: the same samples, estimated up front, progress on ``stream``
    (default: the ``physics.long_run`` logger, physics.notices, which the command prints on stderr) for long
    runs, Ctrl+C answered with the samples so far (status failed, message "interrupted").
    Raises LinkageError when the estimate exceeds ``settings.max_steps``."""
    spec = INTEGRATORS[settings.integrator]
    times = np.linspace(0.0, settings.t_end, settings.samples)
    if not METHODS[settings.method].reduced:
        # loaded before the clock starts (the pace is the run's): the system physics.simulate integrates
        chain_system(chain, settings.method, settings.damping)
    started = time.perf_counter()
    if spec.fixed_step:
        # the cost is known (t_end / step steps, held to max_steps by Settings): a first segment of PROBE_STEPS
        rate = 1.0 / settings.step
        probe_end = min(settings.t_end, PROBE_STEPS / rate)
        if probe_end >= times[1]:
            index = int(np.searchsorted(times, probe_end, side="right")) - 1
            first = simulate(chain, theta0, omega0, settings.model_copy(update={"t_end": float(times[index]),
                                                                                 "samples": index + 1}))
            if index == settings.samples - 1 or not first.success:
                return first
            start = (first, [_rows(first, slice(None))], index, float(times[index]))
        else:
            first = simulate(chain, theta0, omega0, settings.model_copy(update={"t_end": probe_end, "samples": 2}))
            if not first.success:
                return first
            start = (first, [_rows(first, slice(0, 1))], 0, probe_end)
    else:
        budget = min(PROBE_STEPS, settings.max_steps)
        first = simulate(chain, theta0, omega0, settings.model_copy(update={"max_steps": budget}))
        if first.success or first.status != Status.MAX_STEPS or budget == settings.max_steps or len(first.t) == 0:
            return first
        reached = float(first.stats.get("t_reached", first.t[-1]))
        if not reached > 0.0:
            return first
        rate = first.n_steps / reached
        seconds_per_step = (time.perf_counter() - started) / max(first.n_steps, 1)
        if rate * settings.t_end > settings.max_steps:
            raise LinkageError(_estimate_refusal(settings, first.n_steps, reached, seconds_per_step))
        start = (first, [_rows(first, slice(None))], len(first.t) - 1, float(times[len(first.t) - 1]))
    seconds_per_step = (time.perf_counter() - started) / max(first.n_steps, 1)
    return _continue(chain, start, times, settings, rate, seconds_per_step, stream)


def _continue(chain: Chain, start: tuple, times: np.ndarray, settings: Settings, rate: float,
              seconds_per_step: float, stream: TextIO | None) -> Trajectory:
    """Go on from ``start`` = (the first call's Trajectory, the rows kept so far, the index of the last sample
    kept, the time of the first call's last state), in segments, to the end of ``times``."""
    spec = INTEGRATORS[settings.integrator]
    first, pieces, index, t_now = start
    theta, omega = first.theta[-1], first.omega[-1]
    steps_used = first.n_steps
    status, message = int(Status.OK), "ok"
    estimated_seconds = (settings.t_end - t_now) * rate * seconds_per_step
    progress = ProgressLine(settings.t_end, stream=stream) if estimated_seconds > PROGRESS_AFTER else None
    while index < len(times) - 1:
        span = SEGMENT_SECONDS / max(seconds_per_step * rate, 1e-300)
        span = min(max(span, MIN_SEGMENT_STEPS / rate), MAX_SEGMENT_STEPS / rate)
        if spec.fixed_step:  # whole steps: a segment's last step is not cut short
            span = max(1, round(span * rate)) / rate
        span = max(span, 1e-9 * max(1.0, abs(t_now)))
        if t_now == times[index] and times[index + 1] - t_now <= span:
            target = min(len(times) - 1, index + max(1, int(min(span / (times[1] - times[0]), len(times)))))
            end, samples, record = float(times[target]), target - index + 1, True
        else:
            end = min(float(times[index + 1]), t_now + span)
            target, samples, record = index + 1, 2, end >= times[index + 1]
            end = float(times[target]) if record else end
        update: dict = {"t_end": end - t_now, "samples": samples}
        if not spec.fixed_step:
            if steps_used >= settings.max_steps:
                status, message = int(Status.MAX_STEPS), Status.MAX_STEPS.message(t_now)
                break
            update["max_steps"] = settings.max_steps - steps_used
        clock = time.perf_counter()
        try:
            piece = simulate(chain, theta, omega, settings.model_copy(update=update), t_start=t_now, continuing=True)
        except KeyboardInterrupt:
            status, message = int(Status.INTEGRATOR_FAILED), f"interrupted (Ctrl+C) at t = {t_now:.6g} s"
            break
        steps_used += piece.n_steps
        if piece.n_steps:
            seconds_per_step = (time.perf_counter() - clock) / piece.n_steps
            if not spec.fixed_step and piece.n_steps >= MIN_SEGMENT_STEPS:
                rate = max(piece.n_steps / (end - t_now), 1e-300)
        if not piece.success:
            kept = len(piece.t) if samples > 2 else 0
            if kept > 1:
                pieces.append(_rows(piece, slice(1, kept)))
            status, message = piece.status, piece.message
            break
        if record:
            pieces.append(_rows(piece, slice(1, None) if samples > 2 else slice(-1, None)))
            index = target
        theta, omega, t_now = piece.theta[-1], piece.omega[-1], end
        if progress is not None:
            progress.update(t_now, (settings.t_end - t_now) * rate * seconds_per_step)
    joined = _joined(first, pieces, times)
    joined.status, joined.message, joined.n_steps = status, message, steps_used
    return joined


# ---------------------------------------------------------------------------------------------
# Mechanism runs (``python -m physics mechanism``): their cost per simulated second at a fixed sample spacing
# (integration and the samples' kernels, or one position analysis per sample), so a short first segment,
# after the one-time loading, measures it.

PROBE_SPAN = 2.0  # simulated seconds of the first segment of a mechanism run (milliseconds on the compiled engine)
MAX_MECHANISM_SECONDS = 600.0  # a mechanism run estimated longer than this is refused up front
SEGMENTED_AFTER = 5.0  # runs estimated shorter than this run in one call, exactly as before
MAX_MECHANISM_SEGMENT = math.inf  # simulated seconds a segment of a mechanism run covers at most


def simulate_mechanism_in_segments(mechanism, t_end: float, samples: int, method: str, stabilization: str,
                                   stream: TextIO | None = None, rtol: float = 1e-10, atol: float = 1e-10,
                                   **options):
    """``simulate_mechanism`` for the command line: a run estimated (from its first PROBE_SPAN simulated
    seconds) over MAX_MECHANISM_SECONDS is refused with the estimate (LinkageError); a long one runs in segments
    with a progress line on ``stream``; Ctrl+C returns ``(run so far, "interrupted ...")``, and a run stopped
    midway (a singular pose, the step budget) ``(run up to the stop, its message)``. Returns
    ``(Trajectory, None)`` when complete. ``options``: simulate_mechanism's integrator, step, max_steps,
    backend; ``max_steps`` is the whole run's budget, as for a chain's segments (each segment gets what is left)."""
    from .mechanism.simulate import simulate_mechanism as simulate_whole  # noqa: PLC0415 - chains never load it
    budget = options.get("max_steps") or DEFAULT_MAX_STEPS

    def simulate_mechanism(*args, **keywords):
        return simulate_whole(*args, **{**options, **keywords})

    def outcome(run):
        return run, (None if run.success else run.message)

    if t_end <= PROBE_SPAN:  # shorter than the probe: one call
        return outcome(simulate_mechanism(mechanism, t_end=t_end, samples=samples, method=method,
                                          stabilization=stabilization, rtol=rtol, atol=atol))
    times = np.linspace(0.0, t_end, samples)
    spacing = float(times[1] - times[0])

    def segment(t_now: float, index: int, span: float, q, qdot):
        """(run, index of the last sample it holds or None, end time)."""
        if t_now == times[index] and spacing <= span:
            target = min(samples - 1, index + max(1, int(min(span / spacing, samples))))
            end, count = float(times[target]), target - index + 1
        else:
            target, count = index + 1, 2
            end = min(float(times[index + 1]), t_now + span)
            if end >= times[index + 1]:
                end = float(times[target])
        run = simulate_mechanism(mechanism, t_end=end - t_now, samples=count, q0=q, qdot0=qdot, t_start=t_now,
                                 method=method, stabilization=stabilization, rtol=rtol, atol=atol,
                                 max_steps=budget - used)
        return run, (target if end == times[target] else None), end

    # one-time costs first (the structure's generated code derived or loaded, the kernels' machine code): the
    # probe below measures the run's own pace, not them
    simulate_mechanism(mechanism, t_end=1e-3, samples=2, method=method, stabilization=stabilization, rtol=rtol,
                       atol=atol)
    used = 0  # integration steps the segments have taken, of the run's budget
    clock = time.perf_counter()
    first, reached, end = segment(0.0, 0, PROBE_SPAN, None, None)
    if not first.success:  # stopped within the probe: its rows on the run's sample times, and its reason
        return dataclasses.replace(first, **_rows(first, np.isin(first.t, times))), first.message
    if reached == samples - 1:
        return first, None
    elapsed = time.perf_counter() - clock
    if first.integrated:
        pace = elapsed / end  # wall seconds per simulated second (integration and sampling at this spacing)
        estimate = pace * t_end
    else:  # the motors fix every body: each sample is one position analysis, whatever the time between them
        estimate = elapsed / len(first.t) * samples
        pace = elapsed / len(first.t) / spacing
    if estimate > MAX_MECHANISM_SECONDS:
        raise LinkageError(
            f"--t-end {t_end:g} with --samples {samples}: about {duration_text(estimate)} of computing (the first "
            f"{end:.3g} s took {duration_text(pace * end)}), more than the {duration_text(MAX_MECHANISM_SECONDS)} a "
            "mechanism run may take; shorten --t-end or take fewer --samples"
        )
    if estimate < SEGMENTED_AFTER:
        return outcome(simulate_mechanism(mechanism, t_end=t_end, samples=samples, method=method,
                                          stabilization=stabilization, rtol=rtol, atol=atol))
    pieces = [_rows(first, slice(None) if reached is not None else slice(0, 1))]
    index = reached if reached is not None else 0
    t_now, q, qdot = end, first.q[-1], first.qdot[-1]
    steps, evaluations = first.n_steps, first.n_rhs
    used = steps
    progress = ProgressLine(t_end, stream=stream)
    interrupted = None
    stopped = None
    while index < samples - 1:
        if used >= budget:  # the budget is spent: stopped here, as a single run would have been
            interrupted = f"{mechanism.name}: {Status.describe(int(Status.MAX_STEPS), t_now)}"
            stopped = dataclasses.replace(first, status=int(Status.MAX_STEPS), message=interrupted)
            break
        clock = time.perf_counter()
        try:
            span = min(SEGMENT_SECONDS / max(pace, 1e-300), MAX_MECHANISM_SEGMENT)
            run, reached, end = segment(t_now, index, span, q, qdot)
        except KeyboardInterrupt:
            interrupted = f"interrupted (Ctrl+C) at t = {t_now:.6g} s"
            break
        pace = max((time.perf_counter() - clock) / (end - t_now), 1e-300)
        steps, evaluations = steps + run.n_steps, evaluations + run.n_rhs
        used = steps
        if not run.success:  # stopped midway: keep its samples (those on the run's sample times) and its reason
            if reached is not None:
                pieces.append(_rows(run, slice(1, None)))
            interrupted, stopped = run.message, run
            break
        if reached is not None:
            pieces.append(_rows(run, slice(1, None)))  # its first row is the state it started from
            index = reached
        t_now, q, qdot = end, run.q[-1], run.qdot[-1]
        progress.update(t_now, (t_end - t_now) * pace)
    fields: dict[str, Any] = {name: np.concatenate([piece[name] for piece in pieces], axis=0) for name in pieces[0]}
    fields["t"] = times[: len(fields["t"])]
    joined = dataclasses.replace(first, **fields, n_steps=steps, n_rhs=evaluations)
    if stopped is not None:
        joined = dataclasses.replace(joined, status=stopped.status, message=stopped.message)
    return joined, interrupted
