"""Chaos maps of a general mechanism: the plane of two initial body angles, each pixel coloured by the time until
a body first turns over (``python -m physics chaos-map --mechanism FILE --coordinates upper,lower`` or
``--preset NAME``; docs/stability.md, "A general mechanism").

The chain's map (:mod:`physics.studies.chaos_map`) carries over to any mechanism of mobility >= 2 (two free
coordinates span the plane; with fewer the map is refused, saying why):

* a pixel's start is the mechanism at rest with the two chosen bodies turned by ``x`` and ``y`` from their
  sketch (each in (-pi, pi)), every other body placed by position analysis with those two angles held (a
  pixel no pose reaches, as a closed linkage's can be, is "unreachable");
* its run is :func:`physics.mechanism.simulate.simulate_mechanism` sampled every ``step`` seconds up to
  ``t_max``, and a body *turns over* when its rotation from the sketch leaves [-pi, pi] (a mechanism sketched
  hanging at rest, as a pendulum, then flips exactly where the chain's map says it does);
* a run that stops (a singular pose) is "failed", coloured apart, never guessed.

Tiles and executors are the chain map's: row bands through any ``concurrent.futures.Executor`` (this process,
local processes, a Dask cluster), the same pixels whichever computes them.
"""

from __future__ import annotations

import math
import time
from concurrent.futures import Executor, as_completed
from dataclasses import dataclass

import numpy as np

from ..errors import LinkageError
from ..mechanism.constraints import Constraints
from ..mechanism.description import Mechanism
from .chaos_map import FORBIDDEN, grid, summary, to_rgb
from .mechanism_cases import FORMULATIONS, mobility, run_case
from .report import Progress

UNREACHABLE = -2.0  # no pose has these two angles (the flip-time array's value)
FAILED = -3.0  # the run stopped (a singular pose): its message is in the command's JSON
UNREACHABLE_RGB = (235, 235, 235)
FAILED_RGB = (200, 30, 30)
DEFAULT_RESOLUTION = 16  # pixels per side: every pixel is a run of the general engine
DEFAULT_T_MAX = 10.0
DEFAULT_STEP = 0.01  # s between samples: a flip is dated to this
TOLERANCE = 1e-8  # rtol = atol of each pixel's run
# Pixel-samples (pixels x t_max / step) one machine is asked for: about a day of one core at the Python-stepped
# engine's measured 1.5 ms a sample (a few hours on the compiled engine). A Dask cluster (--scheduler) is the fix.
MAX_LOCAL_PIXEL_SAMPLES = 5e7
POSE_STEPS = 50


def angle_indices(mechanism: Mechanism, coordinates: str | None) -> tuple[int, int]:
    """The ``q`` indices of two bodies' angles: ``"upper,lower"`` (``"upper.phi"`` too); default the first two
    bodies. One line naming the coordinate and the bodies otherwise."""
    names = [body.name for body in mechanism.bodies]
    chosen = names[:2] if coordinates is None else [c.strip() for c in coordinates.split(",")]
    if len(chosen) != 2:
        raise LinkageError(f"--coordinates = {coordinates!r}: expected two bodies' angles, e.g. "
                           f"--coordinates {','.join(names[:2])}")
    indices = []
    for item in chosen:
        body, _, what = item.partition(".")
        if body not in names or what not in ("", "phi"):
            raise LinkageError(f"--coordinates: {item!r} is not a body's angle; allowed {', '.join(names)} "
                               "(or BODY.phi)")
        indices.append(3 * names.index(body) + 2)
    if indices[0] == indices[1]:
        raise LinkageError(f"--coordinates = {coordinates!r}: the two coordinates must be different bodies")
    return indices[0], indices[1]


def check_mechanism_map(mechanism: Mechanism, method: str, resolution: int, t_max: float, step: float,
                        workers: int = 1, scheduler: str | None = None) -> None:
    """Refuse, before any work, a map the mechanism cannot span or one out of proportion (one line each)."""
    free = mobility(mechanism)
    if free < 2:
        raise LinkageError(f"{mechanism.name}: mobility {free}; a chaos map spans two initial coordinates, so it "
                           "needs a mechanism of mobility >= 2 (two free coordinates), e.g. a double pendulum")
    if method not in FORMULATIONS:
        raise LinkageError(f"method = {method!r}: allowed {', '.join(FORMULATIONS)}")
    if not (isinstance(resolution, (int, np.integer)) and 1 <= resolution <= 2000):
        raise LinkageError(f"resolution = {resolution}: allowed range 1 <= resolution <= 2000 for a mechanism")
    if not (math.isfinite(t_max) and 0.0 < t_max <= 1e4):
        raise LinkageError(f"t_max = {t_max}: allowed range 0 < t_max <= 1e4 s for a mechanism")
    if not (math.isfinite(step) and 0.0 < step <= min(0.1, t_max)):
        raise LinkageError(f"step = {step}: allowed range 0 < step <= min(0.1, t_max) s")
    pixel_samples = resolution**2 * math.ceil(t_max / step - 1e-9)
    if scheduler is None and pixel_samples > MAX_LOCAL_PIXEL_SAMPLES:
        raise LinkageError(f"--resolution {resolution}, --t-max {t_max:g}, --step {step:g}: {pixel_samples:.3g} "
                           f"pixel-samples of the general engine, more than the {MAX_LOCAL_PIXEL_SAMPLES:.0e} one "
                           "machine takes (about a day of one core); lower --resolution or --t-max, raise --step, "
                           "or use a Dask cluster (--scheduler)")


def pose_with_angles(constraints: Constraints, guess: np.ndarray, indices: tuple[int, int],
                     values: tuple[float, float], scale: float) -> np.ndarray | None:
    """The pose nearest ``guess`` that closes every joint with ``q[indices] = values`` (Newton, minimum-norm
    steps on the constraints and the two held angles), or None when none is found."""
    q = np.array(guess, dtype=float)
    q[list(indices)] = values
    held = np.zeros((2, q.size))
    held[0, indices[0]] = held[1, indices[1]] = 1.0
    for _ in range(POSE_STEPS):
        residual = np.concatenate([constraints.residual(q, 0.0), q[list(indices)] - np.asarray(values)])
        if np.max(np.abs(residual)) <= 1e-12 * scale:
            return q
        jacobian = np.vstack([constraints.jacobian(q), held])
        step, *_ = np.linalg.lstsq(jacobian, -residual, rcond=None)
        q = q + step
        if not np.all(np.isfinite(q)):
            return None
    return None


@dataclass(frozen=True)
class MechanismTile:
    """One band of rows (plain data: the mechanism as JSON, cheap to pickle for a worker)."""

    mechanism_json: str
    indices: tuple[int, int]
    columns: tuple  # the first coordinate's values (x axis)
    rows: tuple  # this band's values of the second (y axis)
    row_start: int
    t_max: float
    step: float
    method: str


def compute_mechanism_tile(task: MechanismTile) -> tuple[int, np.ndarray, list[str]]:
    """Flip times of one band (NaN: no turn within t_max; UNREACHABLE; FAILED) and the failures' messages."""
    mechanism = Mechanism.model_validate_json(task.mechanism_json)
    constraints = Constraints(mechanism)
    sketch = constraints.sketch_pose()
    scale = max(1.0, float(np.max(np.abs(sketch))))
    samples = int(math.ceil(task.t_max / task.step - 1e-9)) + 1
    times = np.full((len(task.rows), len(task.columns)), np.nan)
    messages: list[str] = []
    for i, y in enumerate(task.rows):
        for j, x in enumerate(task.columns):
            q0 = pose_with_angles(constraints, sketch, task.indices, (x, y), scale)
            if q0 is None:
                times[i, j] = UNREACHABLE
                continue
            outcome = run_case(mechanism, samples * task.step - task.step, samples, q0=q0, method=task.method,
                               rtol=TOLERANCE, atol=TOLERANCE)
            if outcome.run is None:
                times[i, j] = FAILED
                messages.append(f"({x:.4g}, {y:.4g}): {outcome.message}")
                continue
            over = np.flatnonzero(np.any(np.abs(outcome.run.q[:, 2::3]) > math.pi, axis=1))
            if over.size:
                times[i, j] = outcome.run.t[over[0]]
    return task.row_start, times, messages


def mechanism_tiles(mechanism: Mechanism, indices: tuple[int, int], resolution: int, t_max: float, step: float,
                    method: str, pixels_per_tile: int = 64) -> list[MechanismTile]:
    """Row bands of about ``pixels_per_tile`` pixels (a pixel is a whole run: small bands keep workers busy)."""
    angles = tuple(float(v) for v in grid(resolution))
    band = max(1, pixels_per_tile // resolution)
    text = mechanism.model_dump_json()
    return [MechanismTile(text, indices, angles, angles[start : start + band], start, t_max, step, method)
            for start in range(0, resolution, band)]


def compute_mechanism_map(mechanism: Mechanism, coordinates: str | None = None, method: str = "lagrange",
                          resolution: int = DEFAULT_RESOLUTION, t_max: float = DEFAULT_T_MAX,
                          step: float = DEFAULT_STEP, executor: Executor | None = None,
                          progress: bool = False) -> tuple[np.ndarray, list[str]]:
    """Flip-time map ``(resolution, resolution)`` (row i: the second angle = grid[i]; column j: the first =
    grid[j]) and the failed pixels' messages. ``executor=None`` runs every tile in this process."""
    indices = angle_indices(mechanism, coordinates)
    check_mechanism_map(mechanism, method, resolution, t_max, step)
    tasks = mechanism_tiles(mechanism, indices, resolution, t_max, step, method)
    result = np.empty((resolution, resolution))
    messages: list[str] = []
    bar = Progress(len(tasks), "chaos-map", progress) if progress else None

    def keep(start: int, band: np.ndarray, failed: list[str]) -> None:
        result[start : start + band.shape[0]] = band
        messages.extend(failed)
        if bar:
            bar.step(f"rows {start}")

    try:
        if executor is None:
            for task in tasks:
                keep(*compute_mechanism_tile(task))
        else:
            for future in as_completed([executor.submit(compute_mechanism_tile, task) for task in tasks]):
                keep(*future.result())
    finally:
        if bar:
            bar.close()
    return result, messages


def mechanism_rgb(times: np.ndarray, t_max: float, step: float) -> np.ndarray:
    """The chain map's colours, with unreachable and failed pixels in their own."""
    rgb = to_rgb(np.where(times < 0, np.nan, times), t_max, step)
    flipped_rows = times[::-1]
    rgb[flipped_rows == UNREACHABLE] = UNREACHABLE_RGB
    rgb[flipped_rows == FAILED] = FAILED_RGB
    return rgb


def mechanism_summary(times: np.ndarray, messages: list[str]) -> dict:
    """The chain map's summary, with the unreachable and failed pixels counted (and the first failure quoted)."""
    info = summary(np.where(times < 0, np.nan, times))
    unreachable = int(np.count_nonzero(times == UNREACHABLE))
    failed = int(np.count_nonzero(times == FAILED))
    info.update(forbidden=int(np.count_nonzero(times == FORBIDDEN)), unreachable=unreachable, failed=failed,
                not_within_t_max=info["not_within_t_max"] - unreachable - failed,
                first_failure=messages[0] if messages else None)
    return info


def run_map(mechanism: Mechanism, coordinates: str | None, method: str, resolution: int, t_max: float,
            step: float, executor: Executor | None, progress: bool) -> tuple[np.ndarray, dict]:
    """The map and its JSON summary for the command (physics.studies.chaos_map.main)."""
    start = time.perf_counter()
    times, messages = compute_mechanism_map(mechanism, coordinates, method, resolution, t_max, step, executor,
                                            progress)
    elapsed = time.perf_counter() - start
    names = [body.name for body in mechanism.bodies]
    first, second = angle_indices(mechanism, coordinates)
    info = mechanism_summary(times, messages)
    info.update(seconds=elapsed, pixels_per_second=times.size / elapsed, mechanism=mechanism.name,
                coordinates=[f"{names[first // 3]}.phi", f"{names[second // 3]}.phi"], method=method,
                t_max=t_max, step=step)
    return times, info
