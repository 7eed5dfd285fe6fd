"""``python -m physics bench --suite design``: the latency of one drag in Design mode, server side.

Why: the issue's target is a dragged point's re-assembled mechanism and its coupler curve within 50 ms for the
presets' sizes. Each timed call moves a ground pivot (not the motor's) of a preset opened as a design to a new
place near its own (every call a new position, so nothing is remembered from a call before), re-assembles it on its branch
(:func:`physics.mechanism.design_analysis.drag`) and traces its full-cycle coupler curve
(:func:`~physics.mechanism.design_analysis.coupler_curve`); the median of the repeats is reported.
"""

from __future__ import annotations

import math
import statistics
import time
from pathlib import Path

from ..mechanism.design import design_from_mechanism
from ..mechanism.design_analysis import CURVE_SAMPLES, coupler_curve, drag
from ..mechanism.presets import MECHANISM_PRESETS
from .report import Progress, machine_note, write_report

DESIGN_PRESETS = ("crank-rocker", "jansen-leg")
STEP = 0.002  # metres: a mouse's small move at the presets' scale; the pivot wanders within +-STEP of its place


def drag_latency(preset: str, repeats: int) -> dict:
    """Median, fastest and slowest seconds of one drag + coupler curve of ``preset``'s free ground pivot."""
    design = design_from_mechanism(MECHANISM_PRESETS[preset]())
    motor_pins = {driver.joint for driver in design.drivers}
    driven_points = {ref for joint in design.joints if joint.name in motor_pins for ref in (joint.a, joint.b)}
    pivot = next(f"ground.{name}" for name, _ in design.ground if f"ground.{name}" not in driven_points)
    x, y = design.point(pivot)
    coupler_curve(drag(design, pivot, (x + STEP / 2, y)))  # warm-up: the first prepared pieces of this structure
    times = []
    for k in range(repeats):
        start = time.perf_counter()
        moved = drag(design, pivot, (x + STEP * math.sin(k + 1.0), y + STEP * math.cos(k + 1.0)))
        curve = coupler_curve(moved)
        times.append(time.perf_counter() - start)
    return {"preset": preset, "pivot": pivot, "bodies": len(design.bodies), "joints": len(design.joints),
            "curve_samples": CURVE_SAMPLES, "curve_points_assembled": int((curve == curve).all(axis=1).sum()),
            "repeats": repeats, "median_s": statistics.median(times), "min_s": min(times), "max_s": max(times)}


def benchmark(out: Path, quick: bool = False, progress: bool = True) -> list[Path]:
    bar = Progress(len(DESIGN_PRESETS), "design", progress)
    rows = []
    for preset in DESIGN_PRESETS:
        rows.append(drag_latency(preset, 5 if quick else 21))
        bar.step(preset)
    bar.close()
    document = {"kind": "design", "machine": machine_note(), "drags": rows}
    return write_report(out, "design", document, design_markdown(document))


def design_markdown(document: dict) -> str:
    lines = ["| preset | pivot dragged | bodies | joints | curve points | median drag + curve | fastest | slowest |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in document["drags"]:
        lines.append(f"| {r['preset']} | {r['pivot']} | {r['bodies']} | {r['joints']} | "
                     f"{r['curve_points_assembled']}/{r['curve_samples'] + 1} | {r['median_s'] * 1e3:.1f} ms | "
                     f"{r['min_s'] * 1e3:.1f} ms | {r['max_s'] * 1e3:.1f} ms |")
    return "\n".join(lines) + "\n"
