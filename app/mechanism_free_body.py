"""The live free-body diagram of one body of a general mechanism: every load on it at the displayed state.

Why apart from the chain's (app/free_body_view.py): a chain's loads are read off its ring by position (bar k's
proximal and distal joints); a mechanism's body may have any number of pins, a slider and motors, so its loads
come from physics itself, :func:`physics.mechanism.statics.free_body` on the DAE's solve at the displayed
sample (``evaluate``; the three formulations' reactions agree with it to 1e-9, and the DAE needs no compiled
code in the server). The drawing is the chain's: the same arrows, colours, labels and scale. A pure couple
(a motor's torque, a damped pin) has no point to draw an arrow at: it is listed under the Body menu, where
:attr:`couples` holds its text.

It is drawn on every second frame (30 Hz): one solve and one free-body sum take about 4 ms for the Jansen leg;
a sample already drawn (a paused or slowed run shows the same sample frame after frame) is not solved again.
"""

from __future__ import annotations

import numpy as np

from physics.mechanism import Mechanism
from physics.mechanism.statics import FreeBody, evaluate, free_body

from .free_body_view import DrawnForce, FreeBodyView

DRAW_EVERY = 2  # frames between diagrams (30 Hz)


def drawn_loads(loads: FreeBody) -> tuple[list[DrawnForce], list[str]]:
    """The forces at a point as arrows, and each couple as a line of text (its moment, N·m)."""
    forces = [DrawnForce(load.name, load.kind if load.kind in ("gravity", "pin", "slider") else "damping",
                         np.array(load.at, dtype=float), np.array(load.force, dtype=float))
              for load in loads.loads if load.at is not None]
    couples = [f"{load.name}: {load.moment:.3g} N·m" for load in loads.loads if load.at is None]
    return forces, couples


class MechanismFreeBody(FreeBodyView):
    """The chain's view with a mechanism's loads; ``bar`` is the body's number (1-based, the description's
    order), ``size`` the mechanism's drawing size (the arrows' thickness)."""

    def __init__(self, scene_api, arrow_scale, redraw=lambda: None, root: str = "/free_body") -> None:
        super().__init__(scene_api, arrow_scale, redraw, root)
        self.couples: list[str] = []
        self.loads: FreeBody | None = None  # the last diagram's loads and balance (tests, the snapshot)
        self.solves = 0  # diagrams computed (tests: a sample shown again is not solved again)
        self._drawn: tuple | None = None  # (ring, sample time, body) of the diagram on screen

    def hide(self) -> None:
        self._drawn = None  # drawn again when shown again
        super().hide()

    def _remove_nodes(self) -> None:
        self._drawn = None
        super()._remove_nodes()

    def _update(self, frame, runs: dict) -> None:
        rf = frame.runs[0] if frame.runs else None
        run = runs.get(rf.label) if rf is not None else None
        mechanism: Mechanism | None = getattr(run.spec, "mechanism", None) if run is not None else None
        if rf is None or run is None or mechanism is None or len(run.ring) == 0 \
                or not 1 <= self.bar <= len(mechanism.bodies):
            self.hide()
            return
        if not (frame.restarted or self._frames % DRAW_EVERY == 0 or self.shown_bar != self.bar):
            self._frames += 1
            return
        ring = run.ring
        i = min(rf.index, len(ring) - 1)
        t = float(ring.get("t", i))
        key = (id(ring), t, self.bar)
        if key == self._drawn and not frame.restarted and self.shown_bar == self.bar:
            self._frames += 1
            return  # this sample's diagram is on screen already
        self.solves += 1
        instant = evaluate(mechanism, ring.get("q", i), ring.get("qdot", i), "dae", t)
        body = mechanism.bodies[self.bar - 1]
        self.loads = free_body(mechanism, instant, body.name)
        forces, self.couples = drawn_loads(self.loads)
        size = float(getattr(run.spec, "draw").size)
        sketch = np.array(list(body.points.values()), dtype=float).reshape(-1, 2)
        extent = max((float(np.hypot(*(a - b))) for a in sketch for b in sketch), default=0.0)  # the body's size
        self._draw(forces, max(extent, 0.25 * size), size,
                   force_labels=frame.restarted or self._frames % (3 * DRAW_EVERY) == 0)
        self._frames += 1
        self.shown = forces
        self.shown_bar = self.bar
        self.shown_t = t
        self._drawn = key
