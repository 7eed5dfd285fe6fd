"""The live free-body diagram of one bar in the 3D scene: every force on it at the displayed sample, with values.

Why here and not in physics/fbd.py: that module solves the DAE for one state (right for an SVG on demand); on
the player thread nothing is solved. The ring already holds, per sample, the joint positions and every joint
reaction (physics/chain_reactions.py, every method) and the pin's reaction of a closed loop, so a frame only picks
values. The forces on bar k (1-based), with the sign convention of docs/architecture.md:

* gravity ``(0, -m_k g)`` at its centre of mass G_k;
* ``R_{k-1}`` at its proximal joint: the force ON bar k BY bar k-1 (the ground for k = 1);
* ``-R_k`` at its distal joint: Newton's third law on the force bar k exerts on bar k+1 (not on the last bar);
* ``R_H`` at the tip of the last bar of a closed chain: the force ON bar n BY the ground at the pin.

The diagram is drawn at the ring's sample at or before the displayed time (where its values belong), the same
sample as the reaction arrows; in compare mode it is the Newton-Euler run's, as for those arrows.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np

from .logs import quietly
from .scene import mechanism_reach, to_world

FORCE_COLORS = {  # the colours of physics/fbd.py's SVG, in the order of the list above
    "gravity": (34, 34, 34),
    "proximal": (78, 121, 167),
    "distal": (225, 87, 89),
    "pin": (89, 161, 79),
    "slider": (242, 142, 43),  # a general mechanism's (app/mechanism_free_body.py)
    "damping": (176, 122, 161),
}
LABEL_EVERY = 6  # frames between label-text updates (10 Hz): values stay readable while the arrows move


@dataclass(frozen=True)
class DrawnForce:
    """One arrow of the diagram: ``force`` (2,) in N applied at ``point_xy`` (2,); ``kind`` picks its colour."""

    name: str
    kind: str
    point_xy: np.ndarray
    force: np.ndarray

    def label(self) -> str:
        return f"{self.name} = {float(np.hypot(*self.force)):.3g} N"


def forces_on_bar(chain, bar: int, theta: np.ndarray, joints: np.ndarray, reactions: np.ndarray,
                  tip_reaction: np.ndarray | None) -> list[DrawnForce]:
    """Every force on bar ``bar`` (1-based) of ``chain`` (a physics.Chain) at one sample.

    ``theta`` (n,), ``joints`` (n+1, 2), ``reactions`` (n, 2) (entry k: on bar k+1 by bar k or the ground),
    ``tip_reaction`` (2,) for a closed chain, else None."""
    n = chain.n
    i = bar - 1
    bar_data = chain.bars[i]
    along = np.array([np.sin(theta[i]), -np.cos(theta[i])])
    com = joints[i] + bar_data.d * along
    forces = [
        DrawnForce(f"m{bar}·g", "gravity", com, np.array([0.0, -bar_data.m * chain.g])),
        DrawnForce(f"R{i}", "proximal", joints[i].copy(), np.array(reactions[i], dtype=float)),
    ]
    if bar < n:
        forces.append(DrawnForce(f"-R{bar}", "distal", joints[bar].copy(), -np.array(reactions[bar], dtype=float)))
    elif tip_reaction is not None:
        forces.append(DrawnForce("RH", "pin", joints[n].copy(), np.array(tip_reaction, dtype=float)))
    return forces


class FreeBodyView:
    """Arrows and value labels of one bar's forces, under ``root`` in a session's scene.

    ``arrow_scale`` returns the display's arrow scale (at 1 the largest force on the bar is drawn one bar length
    long); ``redraw`` asks the player for a frame (a change while paused)."""

    def __init__(self, scene_api, arrow_scale, redraw=lambda: None, root: str = "/free_body") -> None:
        self.scene_api = scene_api
        self._redraw = redraw
        self.root = root
        self._arrow_scale = arrow_scale
        self.on = False
        self.bar = 1
        self.shown: list[DrawnForce] = []  # what is drawn now (tests and the snapshot read it)
        self.shown_t: float | None = None
        self.shown_bar: int | None = None
        self._arrows = None
        self._labels: list = []
        self._frames = 0
        self._lock = threading.Lock()  # the GUI thread changes the bar while the player thread draws

    def set_on(self, on: bool) -> None:
        with self._lock:
            self.on = bool(on)
            if not self.on:
                self.hide()
        self._redraw()

    def set_bar(self, bar: int) -> None:
        with self._lock:
            self.bar = int(bar)
            self._remove_nodes()  # the number of forces may change (the last bar has no distal reaction)

    # ------------------------------------------------------------------ every frame (player thread)
    def update(self, frame, runs: dict) -> None:
        """Draw the chosen bar's forces for ``frame`` (the first run shown), or hide them if there is none."""
        with self._lock:
            if self.on:
                self._update(frame, runs)

    def _update(self, frame, runs: dict) -> None:
        rf = frame.runs[0] if frame.runs else None
        run = runs.get(rf.label) if rf is not None else None
        if rf is None or run is None or len(run.ring) == 0 or not 1 <= self.bar <= run.spec.n:
            self.hide()
            return
        ring, chain = run.ring, run.spec.chain
        i = min(rf.index, len(ring) - 1)
        forces = forces_on_bar(
            chain, self.bar, ring.get("theta", i), ring.get("joints", i), ring.get("reactions", i),
            ring.get("tip_reaction", i) if chain.pinned else None,
        )
        self._draw(forces, float(chain.bars[self.bar - 1].L), mechanism_reach(chain.array("L"), chain.pin),
                   force_labels=frame.restarted or self._frames % LABEL_EVERY == 0)
        self._frames += 1
        self.shown = forces
        self.shown_bar = self.bar
        self.shown_t = float(ring.get("t", i))

    def _draw(self, forces: list[DrawnForce], length: float, reach: float, force_labels: bool) -> None:
        """``forces`` to scale among themselves, as in physics/fbd.py's SVG: the largest is ``length`` (the
        body's size) long, times the display's arrow scale; the labels carry the values; ``reach``, the
        mechanism's size, sets the arrows' thickness."""
        length = max(length, 1e-3)
        largest = max(max(float(np.hypot(*f.force)) for f in forces), 1e-12)
        scale = self._arrow_scale() * length / largest
        radius = 0.012 * reach
        starts = np.array([f.point_xy for f in forces])
        ends = starts + scale * np.array([f.force for f in forces])
        points = np.stack([to_world(starts), to_world(ends)], axis=1).astype(np.float32)
        if self._arrows is None or len(self._labels) != len(forces):
            self._remove_nodes()
            colors = np.array([FORCE_COLORS[f.kind] for f in forces], dtype=np.uint8)
            self._arrows = self.scene_api.add_arrows(
                f"{self.root}/arrows", points=points, colors=colors, shaft_radius=radius,
                head_radius=2.5 * radius, head_length=6 * radius,
            )
            self._labels = [self.scene_api.add_label(f"{self.root}/label_{k}", f.label(), position=tuple(end),
                                                     font_screen_scale=0.8)
                            for k, (f, end) in enumerate(zip(forces, to_world(ends)))]
            return
        self._arrows.points = points
        if not self._arrows.visible:
            self._arrows.visible = True
        for handle, f, end in zip(self._labels, forces, to_world(ends)):
            handle.position = tuple(end)
            if force_labels:
                handle.text = f.label()
            if not handle.visible:
                handle.visible = True

    # ------------------------------------------------------------------ read-outs and cleanup
    def labels(self) -> list[str]:
        return [handle.text for handle in self._labels]

    def visible(self) -> bool:
        return self._arrows is not None and bool(self._arrows.visible)

    def hide(self) -> None:
        if self._arrows is not None and self._arrows.visible:
            self._arrows.visible = False
        for handle in self._labels:
            if handle.visible:
                handle.visible = False

    def _remove_nodes(self) -> None:
        if self._arrows is not None:
            quietly(self._arrows.remove, "removing the free-body arrows")
            self._arrows = None
        for handle in self._labels:
            quietly(handle.remove, "removing a free-body label")
        self._labels = []

    def remove(self) -> None:
        with self._lock:
            self._remove_nodes()
