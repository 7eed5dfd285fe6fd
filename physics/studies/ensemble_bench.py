"""The ensemble benchmark (``python -m physics bench --suite ensemble``): pendulum-steps per second of batched
RK4 ensembles (physics.ensemble), the cost of one real-time frame for 1000 copies, and what the fixed step
costs in accuracy.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ..chain_presets import get_preset
from ..ensemble import DEFAULT_STEP, Ensemble
from ..model import FORMULATION_NAMES, Settings
from ..simulate import simulate
from .report import Progress, machine_note, write_report

BENCH_COUNTS = (1, 100, 1000, 10000)
BENCH_SECONDS = 1.0  # wall time spent per measurement (at least one step)


def throughput(preset_name: str, method: str, count: int, step: float, seconds: float = BENCH_SECONDS) -> dict:
    """Pendulum-steps per second of ``count`` copies (one core, whatever else runs on the machine)."""
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
