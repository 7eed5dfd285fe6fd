"""Compare mode's two divergence plots, over the whole run: the report's Figures 12-13 and their honest version.

The seed report checks its three derivations by plotting the difference between methods (x_NE - x_DAE, x_NE -
x_Lagrange). Run with the same integrator and tolerance, the formulations take the same steps, so that
difference is rounding: it says the equations are the same, not that the motion is right (docs/seed-report.md,
section 2). The honest plot draws each method against a converged reference run of the same start (DOP853 at
:data:`REFERENCE_TOLERANCE`, projected onto the loop for a closed chain), computed alongside by the player as a
fourth run that is not drawn in the scene, on a log scale, with the level :data:`VISIBLE_GAP` drawn and the time
each method first passes it written under the plot.

Both plots keep every stored sample of the run (the ring holds the last two minutes), not a sliding window, so
the growth of a divergence stays in view (issue 14, item 10).
"""

from __future__ import annotations

import math

import numpy as np

import physics
from physics.model import validated

from .logs import quietly
from .overlays import METHOD_COLORS, Plot
from .parameters import METHOD_LABELS, SessionParameters, settings_data
from .runs import RunSpec

REFERENCE_LABEL = "reference"
REFERENCE_INTEGRATOR = "DOP853"
# Tight enough that the reference's own error stays far below the methods' at the app's tolerances (1e-6 ..
# 1e-12), loose enough that the player keeps ahead of the display (DOP853 takes large steps even here).
REFERENCE_TOLERANCE = 1e-12
# The tip "leaves" the true motion when it is this far from the reference (as in the seed report: a clearly
# visible gap for mechanisms a few units long).
VISIBLE_GAP = 0.1
MAX_PLOTTED_SAMPLES = 1200  # samples read per series from the ring (the plot draws 300 of them)
GAP_COLOR = (140, 140, 140)  # a contrast of at least 3 on the light panel and on the dark one (150 grey was 2.96)


def reference_spec(params: SessionParameters, methods: tuple[str, ...]) -> RunSpec:
    """The converged run of the session's start: the first compared method's settings at DOP853, tight."""
    base = settings_data(params.settings_for(methods[0]))
    update = {"integrator": REFERENCE_INTEGRATOR, "rtol": REFERENCE_TOLERANCE, "atol": REFERENCE_TOLERANCE}
    if params.pinned:
        update["stabilization"] = "projection"
    return RunSpec(REFERENCE_LABEL, params.chain, validated(physics.Settings, **{**base, **update}))


def aligned_tips(runs: dict, labels: list[str], t_shown: float,
                 point: str = "joints") -> tuple[np.ndarray, dict[str, np.ndarray]] | None:
    """Time (m,) and each run's tip (m, 2) on the samples every run has, from the oldest stored one up to the
    displayed time (every ``stride``-th sample, at most :data:`MAX_PLOTTED_SAMPLES`); None if a run is missing.
    ``point``: the ring field the tip is read from: a chain's ``joints`` (its last point, the tip) or a general
    mechanism's ``trace_xy`` (the traced point)."""
    if any(label not in runs or len(runs[label].ring) < 2 for label in labels):
        return None
    rings = [runs[label].ring for label in labels]
    t0 = max(ring.t_first for ring in rings)
    t1 = min(min(ring.t_last for ring in rings), t_shown)
    if t1 <= t0:
        return None
    first = [ring.index_at(t0) for ring in rings]
    count = min(ring.index_at(t1) - i0 for ring, i0 in zip(rings, first)) + 1
    stride = max(1, math.ceil(count / MAX_PLOTTED_SAMPLES))
    windows = [ring.window(i0, i0 + count - 1, names=["t", point], stride=stride) for ring, i0 in zip(rings, first)]
    tips = {label: data[point][:, -1] if point == "joints" else data[point] for label, data in zip(labels, windows)}
    return windows[0]["t"], tips


def first_passing(t: np.ndarray, gap: np.ndarray, level: float = VISIBLE_GAP) -> float | None:
    """The first time where ``gap`` exceeds ``level``, or None."""
    above = np.flatnonzero(gap > level)
    return float(t[above[0]]) if above.size else None


class DivergencePlots:
    """Feeds the panel's "Tip divergence from Newton-Euler" plot and owns the honest plot below it.

    A general mechanism (app/mechanism_compare.py) passes its traced point (``point="trace_xy"``, ``noun``) and a
    visible gap in proportion to its size (a Jansen leg is far smaller than a chain of 1 m bars)."""

    def __init__(self, gui, methods: tuple[str, ...], between_methods: Plot, *, point: str = "joints",
                 noun: str = "Tip", gap: float = VISIBLE_GAP) -> None:
        self.methods = methods
        self.between_methods = between_methods
        self.point, self.noun, self.gap = point, noun, gap
        self.honest = Plot(
            gui, f"{noun} error vs a converged run (DOP853, {REFERENCE_TOLERANCE:g})",
            [METHOD_LABELS[m] for m in methods] + [f"{gap:g} (visible)"],
            [METHOD_COLORS[m] for m in methods] + [GAP_COLOR], log=True, height=150, y_label="m",
        )
        self.passing = gui.add_markdown("")
        order = between_methods.handle.order
        self.honest.handle.order = order + 0.001
        self.passing.order = order + 0.002
        self.passing_times: dict[str, float | None] = {}
        self.set_visible(False)

    def set_visible(self, visible: bool) -> None:
        self.honest.set_visible(visible)
        if self.passing.visible != visible:
            self.passing.visible = visible

    def remove(self) -> None:
        """Drop the honest plot and its line (the between-methods plot belongs to the panel)."""
        self.honest.remove()
        quietly(self.passing.remove, "removing the divergence line")

    def update(self, runs: dict, t_shown: float) -> None:
        """Both plots from the stored runs up to ``t_shown`` (player thread, a few times a second)."""
        aligned = aligned_tips(runs, [*self.methods, REFERENCE_LABEL], t_shown, self.point)
        if aligned is None:
            return
        t, tips = aligned
        first = tips[self.methods[0]]
        self.between_methods.update(t, *[np.linalg.norm(first - tips[m], axis=1) for m in self.methods[1:]])
        errors = [np.linalg.norm(tips[m] - tips[REFERENCE_LABEL], axis=1) for m in self.methods]
        self.honest.update(t, *errors, np.full_like(t, self.gap))
        self.passing_times = {m: first_passing(t, e, self.gap) for m, e in zip(self.methods, errors)}
        self.passing.content = passing_markdown(self.passing_times, float(t[-1]), self.noun, self.gap)


def passing_markdown(times: dict[str, float | None], t_last: float, noun: str = "Tip",
                     gap: float = VISIBLE_GAP) -> str:
    parts = [f"{METHOD_LABELS[m]} at **{t:.2f} s**" if t is not None else f"{METHOD_LABELS[m]}: not yet"
             for m, t in times.items()]
    return (f"{noun} more than {gap:g} from the converged run (the motion drawn is no longer the true one): "
            + "; ".join(parts) + f" (up to t = {t_last:.1f} s).")
