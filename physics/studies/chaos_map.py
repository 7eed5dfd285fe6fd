"""Chaos maps: the plane of initial angles (theta1, theta2), each pixel coloured by the time until a link
first flips over (passes the upward vertical), computed with the ensemble path in tiles.

``python -m physics chaos-map --preset double --resolution 400 --out map.png [--scheduler tcp://host:8786]
[--workers N]``

A general mechanism of mobility >= 2 (``--mechanism FILE [--coordinates BODY,BODY]``) gets the same map over
two of its bodies' initial angles, each pixel a run of the general engine (physics.studies.mechanism_chaos).

Why tiles through a ``concurrent.futures.Executor``: every pixel is an independent run, so the map splits
into row bands that any executor can run: the calling process (``--workers 1``), local processes
(``ProcessPoolExecutor``, the default), or a Dask cluster (``--scheduler``: ``Client.get_executor()``),
because a 4000 x 4000 map outgrows one machine. Each pixel's arithmetic is the same whichever tile or
machine computes it (the batched RK4 advances each state on its own), so every executor gives the same map,
bit for bit.

Physics: the chain starts at rest at ``theta1 = x``, ``theta2 = y`` (other angles 0), both in (-pi, pi);
a link flips when its unwrapped angle leaves [-pi, pi]. Pixels whose energy cannot lift any link over the
top are settled without integrating (exact bound from the potential energy); pixels that do not flip
within ``t_max`` are "not within t_max". Colour: log of the flip time, from ``step`` to ``t_max``.
"""

from __future__ import annotations

import io
import json
import math
import os
import time
from concurrent.futures import Executor, ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from ..arguments import Parser
from ..chain_presets import get_preset, preset_names
from ..errors import LinkageError
from ..kinematics import energies
from ..mechanism.presets import MECHANISM_PRESETS
from ..model import FORMULATION_NAMES, Chain
from ..outputs import check_output_path, write_output
from ..simulate.chain_system import chain_system
from .charts import colormap, png_bytes, write_png
from .report import Progress, machine_note

DEFAULT_T_MAX = 30.0
DEFAULT_STEP = 0.01
DEFAULT_RESOLUTION = 400
MAX_RESOLUTION = 20000
PIXELS_PER_TILE = 4096  # tile = a band of rows holding about this many pixels
COMPACT_EVERY = 8  # steps between removals of finished pixels from the batch
FORBIDDEN_RGB = (110, 110, 110)  # energy too low for any flip
NOT_FLIPPED_RGB = (0, 0, 0)  # allowed, but no flip within t_max
FORBIDDEN = -1.0  # value in the flip-time array for energetically forbidden pixels (NaN: not within t_max)


@dataclass(frozen=True)
class TileTask:
    """Everything a worker needs for one band of rows (plain data, cheap to pickle)."""

    method: str
    n: int
    params: tuple
    chain: Chain  # the chain written as a mechanism is built from it (physics.simulate.chain_system)
    theta1: tuple  # column angles (x axis)
    theta2: tuple  # this band's row angles (y axis)
    row_start: int
    t_max: float
    step: float


def grid(resolution: int, lo: float = -math.pi, hi: float = math.pi) -> np.ndarray:
    """Pixel-centre angles, increasing: ``lo + (i + 1/2) (hi - lo) / resolution``."""
    return lo + (np.arange(resolution) + 0.5) * (hi - lo) / resolution


def flip_energy(params: np.ndarray, n: int) -> float:
    """The least total energy with which some link can stand upright (theta_k = pi): below it, no flip.

    The potential is ``sum_j c_j cos(theta_j)`` with ``c_j = -g (m_j d_j + L_j * mass beyond bar j) <= 0``;
    with ``theta_k = pi`` and every other angle free, its minimum is ``-c_k + sum_{j != k} c_j``.
    """
    L, d, m, g = params[:n], params[n : 2 * n], params[2 * n : 3 * n], params[4 * n]
    beyond = np.concatenate([np.cumsum(m[::-1])[::-1][1:], [0.0]])
    c = -g * (m * d + L * beyond)
    return float(min(-c[k] + (c.sum() - c[k]) for k in range(n)))


def compute_tile(task: TileTask) -> tuple[int, np.ndarray]:
    """Flip times of one band: shape ``(len(theta2), len(theta1))``; NaN = not within t_max, FORBIDDEN = no
    flip possible. Runs in whichever process the executor picks."""
    # the chain written as a mechanism (its coordinates may be the angles in another order: a flip is any angle
    # leaving [-pi, pi], whichever the order)
    system = chain_system(task.chain, task.method)
    compiled = system.compiled
    params = np.asarray(task.params, dtype=float)  # the chain's numbers: its energies
    n = task.n
    columns, rows = len(task.theta1), len(task.theta2)
    theta = np.zeros((rows * columns, n))
    theta[:, 0] = np.tile(np.asarray(task.theta1), rows)
    theta[:, 1] = np.repeat(np.asarray(task.theta2), columns)
    omega = np.zeros_like(theta)
    times = np.full(rows * columns, np.nan)
    energy = energies(params, theta, omega)[2]
    allowed = energy >= flip_energy(params, n)
    times[~allowed] = FORBIDDEN
    active = np.flatnonzero(allowed)
    theta = system.coordinates(theta[active])
    omega = system.coordinates(omega[active])
    work = np.empty((7, n))
    condition = np.empty(len(active))
    steps = int(math.ceil(task.t_max / task.step - 1e-9))
    flipped_any = np.zeros(len(active), dtype=bool)
    for k in range(1, steps + 1):
        if len(active) == 0:
            break
        compiled.rk4_batch_step(theta, omega, system.params, task.step, 0.0, 0.0, work, condition)
        over = np.abs(theta) > math.pi
        flipped = over.any(axis=1) | ~np.isfinite(theta).all(axis=1)
        if flipped.any():
            newly = flipped & ~flipped_any
            times[active[newly]] = k * task.step
            flipped_any |= flipped
        if k % COMPACT_EVERY == 0 and flipped_any.any():
            keep = ~flipped_any
            active, theta, omega = active[keep], np.ascontiguousarray(theta[keep]), np.ascontiguousarray(omega[keep])
            condition = np.empty(len(active))
            flipped_any = np.zeros(len(active), dtype=bool)
    return task.row_start, times.reshape(rows, columns)


def tiles(chain, method: str, resolution: int, t_max: float, step: float) -> list[TileTask]:
    """Row bands of about PIXELS_PER_TILE pixels covering the map."""
    angles = grid(resolution)
    band = max(1, PIXELS_PER_TILE // resolution)
    params = tuple(float(v) for v in chain.params())
    return [
        TileTask(method, chain.n, params, chain, tuple(angles), tuple(angles[start : start + band]), start, t_max,
                 step)
        for start in range(0, resolution, band)
    ]


def compute_map(chain, method: str = "lagrange", resolution: int = DEFAULT_RESOLUTION, t_max: float = DEFAULT_T_MAX,
                step: float = DEFAULT_STEP, executor: Executor | None = None, progress: bool = False) -> np.ndarray:
    """Flip-time map, shape ``(resolution, resolution)``: row i is theta2 = grid[i] (increasing), column j is
    theta1 = grid[j]. ``executor=None`` runs every tile in this process."""
    check_map_arguments(chain, method, resolution, t_max, step)
    tasks = tiles(chain, method, resolution, t_max, step)
    result = np.empty((resolution, resolution))
    bar = None
    if progress:
        bar = Progress(len(tasks), "chaos-map", True)
    try:
        if executor is None:
            for task in tasks:
                start, band = compute_tile(task)
                result[start : start + band.shape[0]] = band
                if bar:
                    bar.step(f"rows {start}")
        else:
            futures = [executor.submit(compute_tile, task) for task in tasks]
            for future in as_completed(futures):
                start, band = future.result()
                result[start : start + band.shape[0]] = band
                if bar:
                    bar.step(f"rows {start}")
    finally:
        if bar:
            bar.close()
    return result


def check_map_arguments(chain, method, resolution, t_max, step) -> None:
    if chain.pinned:
        raise LinkageError("chaos maps are for open chains (the tip must be free); choose preset double or a triple")
    if chain.n < 2:
        raise LinkageError(f"links = {chain.n}: a chaos map needs at least 2 bars (theta1 and theta2 span the map)")
    if method not in FORMULATION_NAMES:
        raise LinkageError(f"method = {method!r}: allowed {', '.join(FORMULATION_NAMES)}")
    if not (isinstance(resolution, (int, np.integer)) and 1 <= resolution <= MAX_RESOLUTION):
        raise LinkageError(f"resolution = {resolution}: allowed range 1 <= resolution <= {MAX_RESOLUTION}")
    if not (math.isfinite(t_max) and 0.0 < t_max <= 1e5):
        raise LinkageError(f"t_max = {t_max}: allowed range 0 < t_max <= 1e5 s")
    if not (math.isfinite(step) and 0.0 < step <= min(0.1, t_max)):
        raise LinkageError(f"step = {step}: allowed range 0 < step <= min(0.1, t_max) s")


def to_rgb(times: np.ndarray, t_max: float, step: float) -> np.ndarray:
    """Image rows top to bottom = theta2 from +pi down to -pi; colour = log flip time from step to t_max."""
    with np.errstate(invalid="ignore", divide="ignore"):
        value = np.log(np.clip(times, step, t_max) / step) / math.log(t_max / step)
    value = np.where(times > 0, value, np.nan)
    rgb = colormap(value, missing_rgb=NOT_FLIPPED_RGB)
    rgb[times == FORBIDDEN] = FORBIDDEN_RGB
    return rgb[::-1]


def summary(times: np.ndarray) -> dict:
    total = times.size
    forbidden = int(np.count_nonzero(times == FORBIDDEN))
    flipped = int(np.count_nonzero(times > 0))
    return {"pixels": total, "forbidden": forbidden, "flipped": flipped,
            "not_within_t_max": total - forbidden - flipped,
            "median_flip_time": float(np.median(times[times > 0])) if flipped else None}


# ------------------------------------------------------------------------------------------------
# Executors


def make_executor(workers: int | None, scheduler: str | None):
    """``(executor or None, close)``: None = this process; ProcessPoolExecutor for workers > 1; a Dask
    distributed executor for a scheduler address (dask imported only then)."""
    if scheduler:
        try:  # dask boundary: imported only when a scheduler is given (an optional extra)
            from distributed import Client  # noqa: PLC0415
        except ImportError:
            raise LinkageError(
                "--scheduler needs Dask: pip install 'dask[distributed]' (the 'dask' extra of linkage-lab)"
            ) from None
        try:
            client = Client(scheduler, timeout="10s")
        except Exception as error:  # noqa: BLE001 - any connection failure becomes one clear line
            raise LinkageError(f"--scheduler {scheduler}: cannot connect ({type(error).__name__}: {error})") from None
        return client.get_executor(), client.close
    if workers is None:
        workers = os.cpu_count() or 1
    if workers <= 1:
        return None, lambda: None
    pool = ProcessPoolExecutor(max_workers=workers)
    return pool, pool.shutdown


def build_parser() -> Parser:
    parser = Parser(prog="python -m physics chaos-map", description="time-to-first-flip map of initial angles")
    parser.add_argument("--preset", default=None, choices=preset_names() + tuple(MECHANISM_PRESETS),
                        help="a chain (default double) or a mechanism preset")
    parser.add_argument("--mechanism", default=None, metavar="FILE",
                        help="a mechanism file of mobility >= 2: the map over two of its bodies' angles")
    parser.add_argument("--coordinates", default=None, metavar="BODY,BODY",
                        help="for a mechanism: the two bodies whose initial angles span the map (default: the first two)")
    parser.add_argument("--links", type=int, default=None, help="bars for --preset chain")
    parser.add_argument("--method", default="lagrange", choices=FORMULATION_NAMES)
    parser.add_argument("--resolution", type=int, default=None,
                        help=f"pixels per side (default {DEFAULT_RESOLUTION}; a mechanism: 16)")
    parser.add_argument("--t-max", type=float, default=None,
                        help=f"longest time followed (s; default {DEFAULT_T_MAX:g}; a mechanism: 10)")
    parser.add_argument("--step", type=float, default=None,
                        help=f"RK4 step (s; default {DEFAULT_STEP:g}); a mechanism: the sampling interval")
    parser.add_argument("--out", default="chaos-map.png", help="PNG file to write")
    parser.add_argument("--data", default=None, help="also save the flip times (.npy)")
    parser.add_argument("--workers", type=int, default=None, help="local processes (default: all cores; 1 = here)")
    parser.add_argument("--scheduler", default=None, metavar="tcp://host:8786", help="Dask scheduler address")
    parser.add_argument("--no-progress", action="store_true")
    return parser


# Bytes held per pixel at the peak (measured: 8 for the flip times, about 105 while colouring and encoding the
# PNG), rounded up; and what one local worker process holds (its own numpy, numba and compiled code).
BYTES_PER_PIXEL = 120
BYTES_PER_WORKER = 80e6
# Pixel-steps (pixels x t_max / step, an upper bound: many pixels stop early) one machine is asked for at most:
# about a day of one core at the measured 1.3e6 pixel-steps a second. A Dask cluster (--scheduler) is the fix.
MAX_LOCAL_PIXEL_STEPS = 1e11
MAX_STEPS_PER_PIXEL = 1e9


def available_memory() -> float:
    """Bytes the machine can still give (MemAvailable of /proc/meminfo; elsewhere the physical memory)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return math.inf


def usable_cores() -> int:
    """The cores this process may run on (its affinity), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def check_machine_bounds(resolution: int, t_max: float, step: float, workers: int, scheduler: str | None) -> None:
    """Refuse, before any work, a map this machine cannot hold or a local run out of proportion: one line with
    the estimate, the limit and the fix."""
    cores = usable_cores()
    if scheduler is None and workers > cores:
        raise LinkageError(f"--workers = {workers}: this machine gives {cores} cores; allowed range 1 <= workers <= "
                           f"{cores} (more processes only share the cores, each holding about "
                           f"{BYTES_PER_WORKER / 1e6:.0f} MB)")
    local_workers = 0 if scheduler else (workers if workers > 1 else 0)
    needed = resolution**2 * BYTES_PER_PIXEL + local_workers * BYTES_PER_WORKER
    budget = 0.5 * available_memory()
    if needed > budget:
        largest = int(math.sqrt(max(budget - local_workers * BYTES_PER_WORKER, 0.0) / BYTES_PER_PIXEL))
        raise LinkageError(f"--resolution = {resolution}: the map needs about {needed / 1e9:.3g} GB, more than half "
                           f"the {2 * budget / 1e9:.3g} GB this machine has free; use --resolution {largest} or less")
    steps_per_pixel = t_max / step
    if not steps_per_pixel <= MAX_STEPS_PER_PIXEL:
        raise LinkageError(f"--t-max {t_max:g} / --step {step:g} = {steps_per_pixel:.3g} steps per pixel, more than the "
                           f"{MAX_STEPS_PER_PIXEL:.0e} allowed; raise --step or lower --t-max")
    pixel_steps = resolution**2 * math.ceil(steps_per_pixel - 1e-9)
    if scheduler is None and pixel_steps > MAX_LOCAL_PIXEL_STEPS:
        raise LinkageError(f"--resolution {resolution}, --t-max {t_max:g}, --step {step:g}: up to {pixel_steps:.3g} "
                           f"pixel-steps, more than the {MAX_LOCAL_PIXEL_STEPS:.0e} one machine takes (about a day of "
                           "one core); lower --resolution or --t-max, raise --step, or use a Dask cluster (--scheduler)")


def data_path(data: str) -> str:
    """Where ``--data`` goes: numpy's ``.npy`` file, the suffix added when missing (as ``np.save`` does), except
    for a device such as ``/dev/full`` or ``/dev/stdout``, written as named (``np.save`` used to write
    ``/dev/full.npy`` instead and exit 0)."""
    path = Path(data)
    try:
        device = path.exists() and not path.is_file()
    except OSError:  # a name too long, say: check_output_path reports it
        device = False
    return data if data.endswith(".npy") or device else data + ".npy"


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    if args.workers is not None and args.workers < 1:
        raise LinkageError(f"--workers = {args.workers}: allowed range 1 <= workers <= {usable_cores()}")
    if args.mechanism is not None or args.preset in MECHANISM_PRESETS:
        return _mechanism_main(args)
    if args.coordinates is not None:
        raise LinkageError("--coordinates: applies to a mechanism (--mechanism FILE or a mechanism preset); a "
                           "chain's map spans theta1 and theta2")
    args.preset = args.preset or "double"
    args.resolution = DEFAULT_RESOLUTION if args.resolution is None else args.resolution
    args.t_max = DEFAULT_T_MAX if args.t_max is None else args.t_max
    args.step = DEFAULT_STEP if args.step is None else args.step
    preset = get_preset(args.preset, args.links)
    check_map_arguments(preset.chain, args.method, args.resolution, args.t_max, args.step)
    workers = usable_cores() if args.workers is None else args.workers
    check_machine_bounds(args.resolution, args.t_max, args.step, workers, args.scheduler)
    check_output_path(args.out, suffixes=(".png",))
    if args.data is not None:
        check_output_path(data_path(args.data), "--data")
    executor, close = make_executor(workers, args.scheduler)
    start = time.perf_counter()
    try:
        times = compute_map(preset.chain, args.method, args.resolution, args.t_max, args.step, executor,
                            progress=not args.no_progress)
    finally:
        close()
    elapsed = time.perf_counter() - start
    write_output(args.out, png_bytes(to_rgb(times, args.t_max, args.step)))
    if args.data is not None:
        buffer = io.BytesIO()
        np.save(buffer, times)
        write_output(data_path(args.data), buffer.getvalue(), "--data")
    info = summary(times)
    info.update(seconds=elapsed, pixels_per_second=times.size / elapsed, out=args.out, preset=args.preset,
                t_max=args.t_max, step=args.step)
    print(json.dumps(info))
    return 0


def _mechanism_main(args) -> int:
    """The map of a general mechanism (physics.studies.mechanism_chaos): the same files and JSON keys, plus the
    mechanism, its two coordinates and the unreachable and failed pixels."""
    # the general engine's study, loaded only when a mechanism is mapped
    from . import mechanism_chaos  # noqa: PLC0415
    from .mechanism_cases import load_case  # noqa: PLC0415

    if args.preset is not None and args.mechanism is not None:
        raise LinkageError("give one of --preset NAME or --mechanism FILE")
    if args.links is not None:
        raise LinkageError(f"--links = {args.links}: applies to --preset chain only")
    mechanism = load_case(args.preset, args.mechanism)
    resolution = mechanism_chaos.DEFAULT_RESOLUTION if args.resolution is None else args.resolution
    t_max = mechanism_chaos.DEFAULT_T_MAX if args.t_max is None else args.t_max
    step = mechanism_chaos.DEFAULT_STEP if args.step is None else args.step
    mechanism_chaos.angle_indices(mechanism, args.coordinates)
    workers = usable_cores() if args.workers is None else args.workers
    mechanism_chaos.check_mechanism_map(mechanism, args.method, resolution, t_max, step, workers, args.scheduler)
    if args.scheduler is None and workers > usable_cores():
        check_machine_bounds(1, 1.0, 1.0, workers, None)  # the one line naming the cores
    check_output_path(args.out, suffixes=(".png",))
    if args.data is not None:
        check_output_path(data_path(args.data), "--data")
    executor, close = make_executor(workers, args.scheduler)
    try:
        times, info = mechanism_chaos.run_map(mechanism, args.coordinates, args.method, resolution, t_max, step,
                                              executor, not args.no_progress)
    finally:
        close()
    write_output(args.out, png_bytes(mechanism_chaos.mechanism_rgb(times, t_max, step)))
    if args.data is not None:
        buffer = io.BytesIO()
        np.save(buffer, times)
        write_output(data_path(args.data), buffer.getvalue(), "--data")
    info.update(out=args.out, preset=args.preset)
    print(json.dumps(info))
    return 0


# ------------------------------------------------------------------------------------------------
# Benchmark (``python -m physics bench --suite chaos``)


def benchmark(out: Path, quick: bool = False, progress: bool = True) -> list[Path]:
    """Pixels per second in this process, then with 1 and 2 local worker processes (same map)."""
    chain = get_preset("double").chain
    resolution = 48 if quick else 160
    t_max = 10.0 if quick else DEFAULT_T_MAX
    bar = Progress(3, "chaos", progress)
    compute_map(chain, resolution=8, t_max=0.1)  # load the compiled code in this process
    rows: list[dict] = []
    reference: np.ndarray | None = None
    # (label, workers, a pool even for one worker): one worker process measures the cost of the process hop.
    for label, workers, pooled in (("in-process", 1, False), ("1 worker process", 1, True),
                                   ("2 worker processes", 2, False)):
        executor: Executor | None
        if pooled:
            pool = ProcessPoolExecutor(max_workers=workers)
            executor, close = pool, pool.shutdown
        else:
            executor, close = make_executor(workers, None)
        if executor is not None:  # start the workers and load the code there, untimed
            list(executor.map(compute_tile, tiles(chain, "lagrange", 4, 0.1, DEFAULT_STEP)))
        start = time.perf_counter()
        times = compute_map(chain, resolution=resolution, t_max=t_max, executor=executor)
        elapsed = time.perf_counter() - start
        close()
        if reference is None:
            reference = times
        identical = bool(np.array_equal(np.nan_to_num(times, nan=-2.0), np.nan_to_num(reference, nan=-2.0)))
        rows.append({"executor": label, "seconds": elapsed, "pixels_per_second": times.size / elapsed,
                     "identical_to_in_process": identical})
        bar.step(label)
    bar.close()
    assert reference is not None
    document: dict = {"kind": "chaos-map", "machine": machine_note(), "preset": "double", "resolution": resolution,
                "t_max": t_max, "step": DEFAULT_STEP, "summary": summary(reference), "runs": rows,
                "scaling_1_to_2_workers": rows[1]["seconds"] / rows[2]["seconds"]}
    out.mkdir(parents=True, exist_ok=True)
    path = out / "chaos.json"
    path.write_text(json.dumps(document, indent=1))
    lines = [f"double pendulum, {resolution} x {resolution} pixels, t_max = {t_max:g} s, RK4 step {DEFAULT_STEP:g} s",
             "", "| executor | seconds | pixels / s | same map |", "| --- | --- | --- | --- |"]
    for row in rows:
        lines.append(f"| {row['executor']} | {row['seconds']:.2f} | {row['pixels_per_second']:.0f} | "
                     f"{'yes' if row['identical_to_in_process'] else 'NO'} |")
    lines.append("")
    lines.append(f"Scaling 1 -> 2 workers: {document['scaling_1_to_2_workers']:.2f}x; machine "
                 f"{document['machine']['cpus']} CPUs, load average {document['machine']['load_average_1_5_15']}.")
    md = out / "chaos.md"
    md.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    png = out / "chaos-map-bench.png"
    write_png(png, to_rgb(reference, t_max, DEFAULT_STEP))
    return [path, md, png]


# ------------------------------------------------------------------------------------------------
# A framed picture: axes, ticks and a colour bar (the app's Analysis tab)

FRAME_TEXT_PX = 16
"""px: the framed picture's text. The picture is about 390 px wide and the app shows it at its panel's width
(about 350 px at 1920 x 1080), so this text is shown at about 14.5 px; PIL's built-in bitmap font (about 11 px,
digits 7 px tall) was shown 6 px tall."""
FRAME_LEFT, FRAME_BOTTOM, FRAME_TOP, BAR_WIDTH, BAR_GAP, BAR_LABELS = 48, 44, 50, 14, 10, 56  # 384 px wide at 256
LEGEND_HEIGHT = 44


def _log_ticks(step: float, t_max: float) -> list[float]:
    """1, 2, 5 times powers of ten between ``step`` and ``t_max``, thinned to at most six."""
    ticks = [m * 10.0 ** e for e in range(math.floor(math.log10(step)), math.ceil(math.log10(t_max)) + 1)
             for m in (1.0, 2.0, 5.0) if step <= m * 10.0 ** e <= t_max]
    while len(ticks) > 6:
        ticks = ticks[::2]
    return ticks


def _frame_font() -> ImageFont.FreeTypeFont | ImageFont.ImageFont:
    """The framed picture's font: Pillow's own scalable font at :data:`FRAME_TEXT_PX` (its bitmap font, far
    smaller, only where Pillow was built without FreeType)."""
    return ImageFont.load_default(size=FRAME_TEXT_PX)


def framed_picture(rgb: np.ndarray, t_max: float, step: float, title: str = "first flip time of the double pendulum",
                   axes: tuple[str, str] = ("theta1", "theta2")) -> np.ndarray:
    """``rgb`` (a map from :func:`to_rgb`, any size) with its axes (``axes``: the first across, the second up, in
    degrees, ticks every 90), a colour bar of the first flip time on a log scale from ``step`` to ``t_max`` with
    ticks in seconds, and a key for the two colours that are not times. ``title`` and ``axes`` name another
    mechanism's map (the app's for a general mechanism). Its text is :data:`FRAME_TEXT_PX` px, for the app's
    panel."""
    height, width = rgb.shape[:2]
    total_w = FRAME_LEFT + width + BAR_GAP + BAR_WIDTH + BAR_LABELS
    total_h = FRAME_TOP + height + FRAME_BOTTOM + LEGEND_HEIGHT
    image = Image.new("RGB", (total_w, total_h), (255, 255, 255))
    image.paste(Image.fromarray(np.ascontiguousarray(rgb, dtype=np.uint8)), (FRAME_LEFT, FRAME_TOP))
    draw = ImageDraw.Draw(image)
    font = _frame_font()
    scalable = isinstance(font, ImageFont.FreeTypeFont)
    ink = (40, 40, 40)

    def text(xy: tuple[float, float], words: str, anchor: str = "la") -> None:
        """``words`` placed by ``anchor`` (PIL's: l/m/r across, a/m top/middle): only a scalable font takes one."""
        if scalable:
            draw.text(xy, words, fill=ink, font=font, anchor=anchor)
        else:
            draw.text((xy[0] - (0 if anchor[0] == "l" else 12), xy[1] - (6 if anchor[1] == "m" else 0)), words,
                      fill=ink, font=font)

    x0, y0, x1, y1 = FRAME_LEFT, FRAME_TOP, FRAME_LEFT + width, FRAME_TOP + height
    draw.rectangle([x0 - 1, y0 - 1, x1, y1], outline=ink)
    shown = title
    while scalable and len(shown) > 8 and draw.textlength(shown, font=font) > total_w - 8:
        shown = shown.rstrip("\u2026")[:-1] + "\u2026"  # a long mechanism name: cut, not drawn past the edge
    text((4, 4), shown)
    for degrees in (-180, -90, 0, 90, 180):
        fraction = (degrees + 180) / 360.0
        x = x0 + fraction * width
        draw.line([(x, y1), (x, y1 + 4)], fill=ink)
        text((min(max(x, 20), total_w - 20), y1 + 6), f"{degrees}", "ma")
        y = y1 - fraction * height
        draw.line([(x0 - 5, y), (x0 - 1, y)], fill=ink)
        text((x0 - 7, y), f"{degrees}", "rm")
    text(((x0 + x1) / 2, y1 + 8 + FRAME_TEXT_PX), f"{axes[0]} (deg)", "ma")
    text((4, y0 - 6 - FRAME_TEXT_PX), f"{axes[1]} (deg)")
    # the colour bar: bottom = step, top = t_max, log scale (as to_rgb colours the map)
    bx0, bx1 = x1 + BAR_GAP, x1 + BAR_GAP + BAR_WIDTH
    bar = colormap(np.linspace(1.0, 0.0, height)[:, None].repeat(BAR_WIDTH, axis=1))
    image.paste(Image.fromarray(bar), (bx0, y0))
    draw.rectangle([bx0 - 1, y0 - 1, bx1, y1], outline=ink)
    for seconds in _log_ticks(step, t_max):
        fraction = math.log(seconds / step) / math.log(t_max / step)
        y = y1 - fraction * height
        draw.line([(bx1, y), (bx1 + 4, y)], fill=ink)
        text((bx1 + 6, y), f"{seconds:g} s", "lm")
    ly = y1 + FRAME_BOTTOM
    for i, (colour, words) in enumerate(((NOT_FLIPPED_RGB, f"no flip within {t_max:g} s"),
                                         (FORBIDDEN_RGB, "too little energy to flip"))):
        row = ly + i * (FRAME_TEXT_PX + 6)
        draw.rectangle([x0, row, x0 + 12, row + 12], fill=colour, outline=ink)
        text((x0 + 18, row + 6), words, "lm")
    return np.asarray(image)
