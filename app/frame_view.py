"""The frame view: what one session draws, from the player's frames (player thread) into scene and panel.

Why apart from the session: drawing reads the runs, never changes what is simulated. It owns the scene of the
mechanism (one :class:`~app.scene.LinkageScene`, or three translucent ones in compare mode), the trace, the
reaction arrows, the floor; it feeds the plots and the status line of the panel it is given. Trace, plots and
status are refreshed less often than poses (30, 5 and 4 times a second).
"""

from __future__ import annotations

import math
import threading
from typing import Any, Callable

import numpy as np

import physics

from .divergence import DivergencePlots
from .logs import quietly
from .mechanism_compare import COMPARE_DEPTH_STEP, COMPARE_METHODS, compare_key
from .overlays import (
    METHOD_COLORS,
    PLOT_POINTS,
    ReactionArrows,
    TraceLine,
    energy_scale,
    relative_drift,
    status_markdown,
)
from .parameters import METHOD_LABELS, Display, SessionParameters
from .phase_view import phase_picture
from .player import SAMPLE_RATE, Frame
from .scene import LinkageScene, mechanism_reach

TRACE_EVERY = 2  # frames between trace updates (30 Hz)
PLOT_EVERY = 12  # frames between plot updates (5 Hz)
STATUS_EVERY = 15  # frames between status-line updates (4 Hz)
PLOT_SECONDS = 30.0  # simulated seconds shown by the plots


class FrameView:
    """Scene nodes, overlays, plots and status of one session. ``panel`` is the session's
    :class:`~app.controls.Controls` (its plots and status line); ``player_lock`` guards the scene against the
    player thread."""

    def __init__(self, target, player_lock, notice: Callable[[], str | None]) -> None:
        self.target = target
        self._player_lock = player_lock
        self._notice = notice
        self.panel: Any = None  # the session's Controls, set once they exist (they are built after the scene)
        scene_api = target.scene
        self.floor = scene_api.add_grid(
            "/floor", width=20.0, height=20.0, plane="xy", cell_size=0.25, section_size=1.0,
            position=(0.0, 0.0, -1.0),
        )
        self.scene = LinkageScene(target, "/linkage")
        self.trace = TraceLine(scene_api, "/linkage/trace")
        self.arrows = ReactionArrows(scene_api, "/linkage/reactions")
        self.compare_scenes: dict[str, LinkageScene] = {}
        self.compare_traces: dict[str, TraceLine] = {}
        self.divergence: DivergencePlots | None = None  # set by the session
        self.compare = False
        self.display = Display()
        self.reactions_on = False
        self.segment_t0 = 0.0  # time of the latest change: the energy error counts from here
        self.energy_ref = 0.0
        self.label = ""
        self._frame_lock = threading.Lock()
        self.last_frame: Frame | None = None
        self._compare_key: list = []
        self._compare_frames: dict = {}
        self.frames_sent = 0
        self._status_playing: bool | None = None  # "playing" or "paused" as the status line last said

    # ------------------------------------------------------------------ building
    def build(self, params: SessionParameters) -> None:
        """(Re)make the nodes for ``params`` (and the compare mode in force)."""
        lengths = np.array(params.L)
        with self._player_lock:
            if self.compare:
                self.scene.set_visible(False)
                self.trace.update(np.zeros((0, 2)))
                reach = mechanism_reach(lengths, params.pin)
                for k, method in enumerate(COMPARE_METHODS):
                    if method not in self.compare_scenes:
                        color = METHOD_COLORS[method]
                        # opaque, one distinct colour each, a little apart in depth: where the runs agree the
                        # front one shows (no blend into one colour), where they part all three show
                        self._compare_frames[method] = self.target.scene.add_frame(
                            f"/compare/{method}", show_axes=False, position=(0.0, COMPARE_DEPTH_STEP * k * reach, 0.0))
                        self.compare_scenes[method] = LinkageScene(self.target, f"/compare/{method}", palette=[color])
                        self.compare_traces[method] = TraceLine(
                            self.target.scene, f"/compare/{method}/trace", color=color
                        )
                    self.compare_scenes[method].build(lengths, params.pin)
                self._show_compare_key(reach)
            else:
                for method in list(self.compare_scenes):
                    self.compare_scenes.pop(method).remove()
                    self.compare_traces.pop(method).remove()
                    frame = self._compare_frames.pop(method, None)
                    if frame is not None:
                        quietly(frame.remove, "removing a compare frame")
                self._hide_compare_key()
                self.scene.build(lengths, params.pin)
                self.scene.set_visible(True)
            reach = mechanism_reach(lengths, params.pin)
            self.floor.position = (0.0, 0.0, -1.08 * reach)
            if not reactions_available(params):
                self.arrows.hide()

    def _show_compare_key(self, reach: float) -> None:
        self._hide_compare_key()
        self._compare_key = compare_key(self.target.scene, reach)

    def _hide_compare_key(self) -> None:
        for handle in self._compare_key:
            quietly(handle.remove, "removing the compare key")
        self._compare_key = []

    def resize(self, params: SessionParameters) -> None:
        """New lengths or pin, same nodes."""
        with self._player_lock:
            for scene in [self.scene, *self.compare_scenes.values()]:
                scene.resize(np.array(params.L), params.pin)

    def show_start(self, params: SessionParameters) -> None:
        """Put the nodes at the start pose before the first frame (a cold start derives for a while)."""
        L = np.array(params.L, dtype=float)
        joints = physics.joint_positions(L, params.theta0)
        ratio = np.divide(np.array(params.d), L, out=np.zeros_like(L), where=L > 0)
        com = joints[:-1] + ratio[:, None] * (joints[1:] - joints[:-1])
        with self._player_lock, self.target.atomic():
            for scene in [self.scene, *self.compare_scenes.values()]:
                if scene.layout is not None:
                    scene.show(joints, com)
            # nothing of the mechanism before: its trace and plots would sit beside the new start while a cold
            # cache derives the new equations (the first frame of the new run redraws them)
            for trace in [self.trace, *self.compare_traces.values()]:
                trace.update(np.zeros((0, 2)))
            if self.panel is not None:
                self.panel.clear_plots()

    def hide_arrows(self) -> None:
        with self._player_lock:
            self.arrows.hide()

    # ------------------------------------------------------------------ every frame (player thread)
    def draw(self, frame: Frame, runs: dict, playing: bool, real_time_factor: float) -> None:
        with self.target.atomic():
            for rf in frame.runs:
                scene = self.scene if rf.label == "main" else self.compare_scenes.get(rf.label)
                if scene is None or scene.layout is None or scene.layout.n + 1 != len(rf.joints):
                    continue
                scene.show(rf.joints, rf.com)
            if frame.restarted or frame.counter % TRACE_EVERY == 0:
                self._update_traces(frame, runs)
            if self.reactions_on:
                self._update_arrows(frame, runs)
        # Every frame is flushed: otherwise viser's sender, idle since its last window, waits up to one
        # window (1/60 s) before it looks again, so a frame drawn just after it dozed off meets the next one
        # in the buffer and is coalesced away (viewers of --shared received 39 of 57 frames/s).
        quietly(self.target.flush, "flushing a frame")
        if frame.restarted:
            self.energy_ref = self._energy_at(runs, frame, self.segment_t0)
        if self.panel is not None and (frame.restarted or frame.counter % PLOT_EVERY == 0):
            self._update_plots(frame, runs)
        if self.panel is not None and (frame.restarted or frame.counter % STATUS_EVERY == 0
                                       or playing != self._status_playing):
            self.panel.show_status(self.status_text(playing, real_time_factor, frame, runs))
            self._status_playing = playing
            first = runs.get(frame.runs[0].label) if frame.runs else None
            if first is not None and len(first.ring):
                self.panel.show_timeline(frame.t, first.ring.t_first, frame.restarted)
        with self._frame_lock:
            self.last_frame = frame
            self.frames_sent += 1

    def _trace_window(self, ring, index: int) -> np.ndarray:
        count = int(round(self.display.trace_seconds * SAMPLE_RATE))
        if count < 2:
            return np.zeros((0, 2))
        return ring.series("trace_xy", index - count, index)

    def _update_traces(self, frame: Frame, runs) -> None:
        for rf in frame.runs:
            run = runs.get(rf.label)
            if run is None:
                continue
            trace = self.trace if rf.label == "main" else self.compare_traces.get(rf.label)
            if trace is not None:
                trace.update(self._trace_window(run.ring, rf.index))

    def _update_arrows(self, frame: Frame, runs) -> None:
        """Arrows of the first run shown: the main run, or in compare mode the Newton-Euler run (the other
        formulations' reactions agree with it to 1e-9 until the runs part)."""
        rf = frame.runs[0] if frame.runs else None
        run = runs.get(rf.label) if rf is not None else None
        if rf is None or run is None or "reactions" not in run.ring.field_names():
            self.arrows.hide()
            return
        spec = run.spec  # the run's own description: the session's parameters may already be newer
        ring = run.ring
        points = [rf.joints[:-1]]
        forces = [ring.get("reactions", rf.index)]
        if spec.pinned:
            points.append(rf.joints[-1:])
            forces.append(ring.get("tip_reaction", rf.index)[None, :])
        chain = spec.chain
        weight = max(float(np.sum(chain.array("m"))) * chain.g, 1e-9)
        reach = mechanism_reach(chain.array("L"), chain.pin)
        # scale 1 draws the total weight as an arrow as long as the mechanism's reach
        scale = self.display.arrow_scale * reach / weight
        self.arrows.update(np.concatenate(points), np.concatenate(forces), scale, radius=0.008 * reach)

    @staticmethod
    def _energy_at(runs, frame: Frame, t: float) -> float:
        run = runs.get(frame.runs[0].label) if frame.runs else None
        if run is None or len(run.ring) == 0:
            return 0.0
        return float(run.ring.get("energy", run.ring.index_at(t)))

    def _update_plots(self, frame: Frame, runs) -> None:
        if not frame.runs:
            return
        first = runs.get(frame.runs[0].label)
        if first is None:
            return
        i = frame.runs[0].index
        span = int(PLOT_SECONDS * SAMPLE_RATE)
        # read every stride-th sample, ending at the displayed one: the plots show PLOT_POINTS points anyway
        span = min(span, i)
        stride = max(1, -(-span // PLOT_POINTS))
        chain = first.spec.chain  # the run's own chain: the session's parameters may already be newer
        kind = self.panel.plot_kind
        extra = ["theta", "omega"] if kind in ("angles", "phase") else []
        data = first.ring.window(i - (span // stride) * stride, i, stride=stride, names=[
            "t", "kinetic", "potential", "energy"] + extra + (["constraint_xy"] if chain.pinned else []))
        t = data["t"]
        c = self.panel
        if kind == "angles" and c.angle_plot is not None and data["theta"].shape[1] == len(c.angle_plot.labels):
            c.angle_plot.update(t, *np.degrees(data["theta"]).T)
        elif kind == "phase" and len(t) >= 2:
            c.phase_image.image = phase_picture(np.degrees(data["theta"]), np.degrees(data["omega"]))
        c.energy_plot.update(t, data["energy"], data["kinetic"], data["potential"])
        scale = energy_scale(chain.array("m"), chain.array("L"), chain.g)
        in_segment = t >= self.segment_t0 - 1e-9
        c.drift_plot.update(t[in_segment], relative_drift(data["energy"][in_segment], self.energy_ref, scale))
        if chain.pinned:
            c.constraint_plot.update(t, np.hypot(data["constraint_xy"][:, 0], data["constraint_xy"][:, 1]))
        if self.compare and self.divergence is not None:
            self.divergence.update(runs, frame.t)

    # ------------------------------------------------------------------ read-outs
    def current_values(self, runs: dict, frame: Frame | None = None) -> dict:
        """Energy error and constraint error at the displayed sample of the first run."""
        frame = frame or self.last_frame
        if frame is None or not frame.runs:
            return {}
        run = runs.get(frame.runs[0].label)
        if run is None or len(run.ring) == 0:
            return {}
        i = min(frame.runs[0].index, len(run.ring) - 1)
        chain = run.spec.chain
        energy = float(run.ring.get("energy", i))
        scale = energy_scale(chain.array("m"), chain.array("L"), chain.g)
        out = {
            "kinetic": float(run.ring.get("kinetic", i)),
            "potential": float(run.ring.get("potential", i)),
            "total": energy,
            "reference": self.energy_ref,
            "relative_drift": float(relative_drift(np.array([energy]), self.energy_ref, scale)[0]),
        }
        if chain.pinned and "constraint_xy" in run.ring.field_names():
            cxy = run.ring.get("constraint_xy", i)
            out["constraint_error"] = float(math.hypot(cxy[0], cxy[1]))
        return out

    def status_text(self, playing: bool, real_time_factor: float, frame: Frame | None = None, runs=None) -> str:
        values = self.current_values(runs or {}, frame) if runs is not None else {}
        t = frame.t if frame is not None else (self.last_frame.t if self.last_frame else 0.0)
        if self.compare:
            label = "compare: " + ", ".join(METHOD_LABELS[m] for m in COMPARE_METHODS)
        else:
            label = self.label
        return status_markdown(t, playing, real_time_factor, label, values.get("relative_drift"),
                               values.get("constraint_error"), self._notice())

    def scene_nodes(self) -> dict:
        """Poses and visibility of every node (the snapshot's ``scene.nodes``)."""
        nodes = {}
        for scene in [self.scene] if not self.compare else list(self.compare_scenes.values()):
            nodes.update(scene.poses())
        for trace in [self.trace] if not self.compare else list(self.compare_traces.values()):
            nodes[trace.name] = {"visible": bool(trace.handle.visible), "points": trace.points_shown}
        if self.arrows.handle is not None:
            nodes[self.arrows.name] = {"visible": bool(self.arrows.handle.visible), "arrows": self.arrows.count}
        return nodes

    def remove(self) -> None:
        """Drop every node (a shared scene outlives its session)."""
        with self._player_lock:
            for scene in [self.scene, *self.compare_scenes.values()]:
                scene.remove()
            for trace in [self.trace, *self.compare_traces.values()]:
                trace.remove()
            self.arrows.remove()
            quietly(self.floor.remove, "removing the floor")


def reactions_available(params: SessionParameters) -> bool:
    """Joint reactions exist for every method: the DAE solves for them, the others recover them from the
    accelerations (physics/chain_reactions.py); closed loops add the pin's."""
    return True
