"""The live free-body diagram of one body in the 3D scene, for any preset or mechanism file: every load
on it at the displayed sample, with names and values, the labels laid out so that none covers another.

Where the loads come from: every body of every preset (a chain is hosted as the mechanism it is, app/chain_knobs.py)
may have any number of pins, a slider and motors, so its loads come from :func:`physics.mechanism.statics.free_body`
on the DAE's solve at the displayed sample (the three formulations' reactions agree with it to 1e-9). That solve
takes about 4 ms for the Jansen leg, so it runs on every second frame (30 Hz) and a sample already drawn (a paused
or slowed run shows the same sample frame after frame) is not solved again. A pure couple (a motor's torque, a
damped pin) has no point to draw an arrow at: :attr:`FreeBodyView.couples` holds its text for the panel.

The diagram is drawn at the ring's sample at or before the displayed time (where its values belong), the same
sample as the reaction arrows; in compare mode it is the first run's, as for those arrows.

Labels (issue 26: "-R1 = 5.42 N" was drawn over "m1·g = 1 N"): each label is a box of text sized in the scene
(a fixed fraction of the mechanism's size, so it zooms with the arrows and the boxes keep apart at every zoom;
labels sized on the screen could not be laid out once for every zoom), placed at its arrow's head or, if that
box meets one already placed, at the nearest free slot above or below (:func:`layout_labels`).
"""

from __future__ import annotations

import shlex
import threading
from dataclasses import dataclass

import numpy as np

from physics.mechanism import Mechanism
from physics.mechanism.statics import FreeBody, evaluate, free_body

from .logs import quietly
from .scene import to_world

FORCE_COLORS = {  # the colours of physics/fbd.py's SVG, in the order of the list above
    "gravity": (34, 34, 34),
    "proximal": (78, 121, 167),
    "distal": (225, 87, 89),
    "pin": (89, 161, 79),
    "slider": (242, 142, 43),  # a general mechanism's
    "damping": (176, 122, 161),
}
LABEL_EVERY = 6  # frames between label-text updates (10 Hz): values stay readable while the arrows move
DRAW_EVERY = 2  # frames between a general mechanism's diagrams (30 Hz): each is one DAE solve
LABEL_HEIGHT = 0.045  # a label's text height, as a fraction of the mechanism's size (scene units)
CHAR_WIDTH = 0.62  # a character's width as a fraction of the text height: wider than the font's average
LABEL_GAP = 0.15  # the gap between two labels' slots, as a fraction of the text height

Box = tuple[float, float, float, float]  # (x0, y0, x1, y1) in the physics plane, metres


@dataclass(frozen=True)
class DrawnForce:
    """One arrow of the diagram: ``force`` (2,) in N applied at ``point_xy`` (2,); ``kind`` picks its colour."""

    name: str
    kind: str
    point_xy: np.ndarray
    force: np.ndarray

    def label(self) -> str:
        return f"{self.name} = {float(np.hypot(*self.force)):.3g} N"


def drawn_loads(loads: FreeBody) -> tuple[list[DrawnForce], list[str]]:
    """A mechanism body's forces at a point as arrows, and each couple as a line of text (its moment, N·m)."""
    forces = [DrawnForce(load.name, load.kind if load.kind in ("gravity", "pin", "slider") else "damping",
                         np.array(load.at, dtype=float), np.array(load.force, dtype=float))
              for load in loads.loads if load.at is not None]
    couples = [f"{load.name}: {load.moment:.3g} N·m" for load in loads.loads if load.at is None]
    return forces, couples


def label_box(anchor_xy: np.ndarray, text: str, height: float) -> Box:
    """The box a label's text covers when its bottom-left corner is at ``anchor_xy`` (text ``height`` high)."""
    x, y = float(anchor_xy[0]), float(anchor_xy[1])
    return (x, y, x + CHAR_WIDTH * height * len(text), y + height)


def boxes_meet(a: Box, b: Box) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def layout_labels(heads_xy: np.ndarray, texts: list[str], height: float) -> list[Box]:
    """One box per label, none meeting another: each at its arrow's head if free, else in the nearest free slot
    straight above or below it (slots a text height plus a gap apart, tried 0, +1, -1, +2, ...). Each box placed
    blocks at most two slots of a later label, so one of the first ``2 * len(texts) + 1`` is free."""
    step = height * (1.0 + LABEL_GAP)
    placed: list[Box] = []
    for head, text in zip(np.asarray(heads_xy, dtype=float), texts):
        for k in range(2 * len(texts) + 1):
            shift = (k + 1) // 2 * (1 if k % 2 else -1)
            box = label_box(head + np.array([0.0, shift * step]), text, height)
            if not any(boxes_meet(box, other) for other in placed):
                break
        placed.append(box)
    return placed


class FreeBodyView:
    """Arrows and value labels of one body's loads, under ``root`` in a session's scene; ``bar`` is the chosen
    body's number (1-based: a chain's bar, a mechanism's body in the description's order).

    ``arrow_scale`` returns the display's arrow scale (at 1 the largest force on the body is drawn one body
    length long); ``redraw`` asks the player for a frame (a change while paused)."""

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
        self.label_boxes: list[Box] = []  # where the labels are, in the physics plane (tests)
        self.label_heads = np.zeros((0, 2))  # the arrows' heads the labels belong to (tests)
        self.couples: list[str] = []  # a mechanism body's pure couples, as text (the panel lists them)
        self.loads: FreeBody | None = None  # a mechanism's last diagram: loads and balance (tests, the snapshot)
        self.solves = 0  # a mechanism's diagrams computed (tests: a sample shown again is not solved again)
        self._drawn: tuple | None = None  # (ring, sample time, body) of a mechanism's diagram on screen
        self._arrows = None
        self._labels: list = []
        self._label_height = 0.0
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
        """Draw the chosen body's loads for ``frame`` (the first run shown), or hide them if there is none."""
        with self._lock:
            if self.on:
                rf = frame.runs[0] if frame.runs else None
                run = runs.get(rf.label) if rf is not None else None
                if rf is None or run is None or len(run.ring) == 0:
                    self.hide()
                else:
                    self._update_mechanism(frame, rf, run)

    def _update_mechanism(self, frame, rf, run) -> None:
        mechanism: Mechanism = run.spec.mechanism
        if not 1 <= self.bar <= len(mechanism.bodies):
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
        size = float(run.spec.draw.size)
        sketch = np.array(list(body.points.values()), dtype=float).reshape(-1, 2)
        extent = max((float(np.hypot(*(a - b))) for a in sketch for b in sketch), default=0.0)  # the body's size
        self._draw(forces, max(extent, 0.25 * size), size,
                   force_labels=frame.restarted or self._frames % (3 * DRAW_EVERY) == 0)
        self._frames += 1
        self.shown = forces
        self.shown_bar = self.bar
        self.shown_t = t
        self._drawn = key

    def _draw(self, forces: list[DrawnForce], length: float, reach: float, force_labels: bool) -> None:
        """``forces`` to scale among themselves, as in physics/fbd.py's SVG: the largest is ``length`` (the
        body's size) long, times the display's arrow scale; the labels carry the names and values, laid out
        apart (:func:`layout_labels`); ``reach``, the mechanism's size, sets the arrows' thickness and the
        labels' height."""
        length = max(length, 1e-3)
        largest = max(max(float(np.hypot(*f.force)) for f in forces), 1e-12)
        scale = self._arrow_scale() * length / largest
        radius = 0.012 * reach
        height = LABEL_HEIGHT * reach
        starts = np.array([f.point_xy for f in forces])
        ends = starts + scale * np.array([f.force for f in forces])
        points = np.stack([to_world(starts), to_world(ends)], axis=1).astype(np.float32)
        fresh = len(self._labels) != len(forces) or height != self._label_height
        texts = [f.label() for f in forces]
        if not fresh and not force_labels:
            # the labels keep their text until the next update: a box as wide as the longer of the two texts
            texts = [max(old.text, new, key=len) for old, new in zip(self._labels, texts)]
        self.label_boxes = layout_labels(ends, texts, height)
        self.label_heads = ends
        corners = to_world(np.array([box[:2] for box in self.label_boxes]))
        if self._arrows is None or fresh:
            self._remove_nodes()
            colors = np.array([FORCE_COLORS[f.kind] for f in forces], dtype=np.uint8)
            self._arrows = self.scene_api.add_arrows(
                f"{self.root}/arrows", points=points, colors=colors, shaft_radius=radius,
                head_radius=2.5 * radius, head_length=6 * radius,
            )
            self._labels = [self.scene_api.add_label(f"{self.root}/label_{k}", f.label(), position=tuple(corner),
                                                     font_size_mode="scene", font_scene_height=height,
                                                     anchor="bottom-left")
                            for k, (f, corner) in enumerate(zip(forces, corners))]
            self._label_height = height
            return
        self._arrows.points = points
        if not self._arrows.visible:
            self._arrows.visible = True
        for handle, f, corner in zip(self._labels, forces, corners):
            handle.position = tuple(corner)
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
        self._drawn = None  # drawn again when shown again
        if self._arrows is not None and self._arrows.visible:
            self._arrows.visible = False
        for handle in self._labels:
            if handle.visible:
                handle.visible = False

    def _remove_nodes(self) -> None:
        self._drawn = None
        if self._arrows is not None:
            quietly(self._arrows.remove, "removing the free-body arrows")
            self._arrows = None
        for handle in self._labels:
            quietly(handle.remove, "removing a free-body label")
        self._labels = []

    def remove(self) -> None:
        with self._lock:
            self._remove_nodes()


def fbd_command(preset: str | None, *, links: int | None = None, bar: int | None = None,
                body: str | None = None) -> str:
    """The command that writes the SVG of the diagram shown: the preset actually shown (issue 26: the help
    named ``triple-a`` whatever was shown), ``--links`` for the n-bar chain, a chain's ``--bar`` or a
    mechanism's ``--body``; ``--mechanism FILE`` for a mechanism loaded from a file (no preset)."""
    source = f"--preset {preset}" if preset else "--mechanism FILE"
    if preset == "chain" and links is not None:
        source += f" --links {links}"
    which = f"--body {shlex.quote(body)}" if body is not None else f"--bar {bar if bar is not None else 1}"
    return f"python -m physics fbd {source} {which} --time 2.5 --out fbd.svg"
