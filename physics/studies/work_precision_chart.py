"""The work-precision diagram (SVG): error against wall time, one curve per configuration.

Apart from :mod:`physics.studies.work_precision` so that the sweep (which returns a chart for the app) and
the report writer (which saves one per case) can both draw it.
"""

from __future__ import annotations

from ..registry import INTEGRATOR_NAMES
from .charts import DASHES, MARKERS, PALETTE, Series, line_chart, panel_line_chart

SEED_BASELINE = "seed-baseline"  # the backend field of the seed-style baseline's curves


# Colour by integrator, dash and marker by method: one entry per registry name, in registry order.
_INTEGRATOR_COLOURS = {name: k for k, name in enumerate(INTEGRATOR_NAMES)}
_FORMULATION_DASH = {"newton_euler": 1, "lagrange": 0, "dae": 2, "reduced": 3}
# A general mechanism's curves (physics.studies.mechanism_work_precision) also name their stabilisation: colour
# by it there (one integrator today); the chain's curves have no such key and keep their colours.
_STABILIZATION_COLOURS = {"none": 2, "baumgarte": 0, "projection": 4, "position analysis": 6}


def probe_name(case: dict) -> str:
    return case.get("probe", "tip")


def _note(case: dict, narrow: bool) -> str:
    if any("stabilization" in curve for curve in case["curves"]):
        return "colour: stabilisation; dash/marker: method"
    return "colour: integrator; dash/marker: formulation" + ("" if narrow else "; black crosses: seed-style baseline")


def chart(case_name: str, case: dict, *, narrow: bool = False) -> str:
    """The SVG work-precision diagram of one case: every curve, the baseline's as black crosses. ``narrow``: the
    version drawn for the app's panel (:func:`~physics.studies.charts.panel_line_chart`: its width, text of at
    least 14 px, the legend under the plot)."""
    series = []
    for curve in case["curves"] + case["baseline"]:
        points = [p for p in curve["points"] if p["error"] is not None]
        if curve["backend"] == SEED_BASELINE:
            color, dash, marker = "#222222", DASHES[_FORMULATION_DASH[curve["formulation"]]], "cross"
        elif "stabilization" in curve:
            color = PALETTE[_STABILIZATION_COLOURS.get(curve["stabilization"], 8)]
            dash = DASHES[_FORMULATION_DASH[curve["formulation"]]]
            marker = MARKERS[_FORMULATION_DASH[curve["formulation"]] % len(MARKERS)]
        else:
            color = PALETTE[_INTEGRATOR_COLOURS[curve["integrator"]]]
            dash = DASHES[_FORMULATION_DASH[curve["formulation"]]]
            marker = MARKERS[_FORMULATION_DASH[curve["formulation"]] % len(MARKERS)]
        labels = [f"{curve['label']} {curve['knob']}={p[curve['knob']]:g}: {p['seconds'] * 1e3:.3g} ms, "
                  f"error {p['error']:.2e}" for p in points]
        series.append(Series(curve["label"].split(" (sympy")[0], [p["seconds"] for p in points],
                             [max(p["error"], 1e-16) for p in points], color=color, dash=dash, marker=marker,
                             point_labels=labels))
    uncertainty = case["reference"]["uncertainty"]
    hlines = [(max(uncertainty, 1e-16), "reference uncertainty")]
    if narrow:
        return panel_line_chart(series, title=f"Work-precision: {probe_name(case)} error at {case['horizon']:g} s",
                                x_label="wall time per run (s), median", y_label=f"{probe_name(case)} position error",
                                log_x=True, log_y=True, hlines=hlines, note=_note(case, narrow))
    return line_chart(
        series,
        title=f"Work-precision: {case_name}, {probe_name(case)} error at t = {case['horizon']:g} s",
        x_label="wall time per run (s), median",
        y_label=f"{probe_name(case)} position error",
        log_x=True,
        log_y=True,
        width=980,
        height=560,
        hlines=hlines,
        note=_note(case, narrow),
    )
