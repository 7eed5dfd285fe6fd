"""The 3D picture of a general mechanism: every body's bars, its points and centres of mass, the ground.

Chains and mechanisms alike: the same batched nodes under one root, so a frame is two messages whatever the
linkage and the tools that count frames (app/wsclient.py) see no difference::

    {root}/bars        one batched box mesh: instance k is segment k of the drawing (a bar body is one segment,
                       a plate the edges of its outline), coloured by body, then one thin grey bar per gear
                       pair between its two pins (the drawing's ``meshes``: a joint kind drawn as ``"mesh"``)
    {root}/spheres     one batched sphere mesh: instances 0..P-1 the drawn points (joints larger), then one per
                       centre of mass
    {root}/ground_k    the fixed points; {root}/guides the sliders' guides on the ground (static)

Part names for :meth:`poses`: ``bar_k`` (segment k, 1-based), the instance k - 1 of ``{root}/bars``; :meth:`parts`
names the points, centres and ground blocks, and :meth:`instance_of` says where each is drawn, so that a picture
waits for the browser to show the server's poses (app/snapshot.py).
"""

from __future__ import annotations

import dataclasses
import functools
import threading

import numpy as np

from .logs import quietly
from .mechanism_runs import GUIDE_MARGIN_FRACTION, Drawing
from .scene import (
    BAR_COLORS,
    BAR_WIDTH_FRACTION,
    COM_COLOR,
    COM_RADIUS_FRACTION,
    GROUND_COLOR,
    JOINT_COLOR,
    JOINT_RADIUS_FRACTION,
    bar_instances,
    instance_colors,
    to_world,
)
from .shapes import UNIT_BOX, UNIT_SPHERE
from .viser_compat import update_node_props

POINT_COLOR = (150, 150, 150)  # a body's point that is not a joint (a traced point, a plate's corner)
MESH_COLOR = (120, 120, 120)  # the line between a gear pair's two pins
MESH_WIDTH_SHARE = 0.35  # of a bar's width: the gear's line reads as a link of another kind than the bodies


def _locked(method):
    """``method`` under the scene's lock: the animation loop shows frames while a menu choice or a switch of
    mechanism removes and rebuilds the nodes on another thread, and a frame must never see half a rebuild (a
    node already removed, the next drawing not yet built)."""

    @functools.wraps(method)
    def under_lock(self, *args, **kwargs):
        with self._lock:
            return method(self, *args, **kwargs)

    return under_lock


class MechanismScene:
    """Nodes of one mechanism under ``root``; :meth:`build` once per drawing, :meth:`show` every frame (either
    thread: both hold the scene's lock)."""

    def __init__(self, target, root: str = "/linkage", palette: list | None = None) -> None:
        self.target, self.palette = target, palette or BAR_COLORS  # compare mode: one colour per method
        self._lock = threading.RLock()
        self.root = root.rstrip("/")
        self.draw: Drawing | None = None
        self._handles: list = []
        self._bars = None
        self._spheres = None
        self._bar_positions = np.zeros((0, 3), np.float32)
        self._bar_wxyzs = np.zeros((0, 4), np.float32)
        self._sphere_positions = np.zeros((0, 3), np.float32)
        self._widths = np.zeros(0)
        self._guides = None  # the guides' node, and their ends as drawn (each lengthened to its slider's travel)
        self._guide_ends = np.zeros((0, 2, 2))
        # per guide, worked out once a build: its first end, unit direction and the reach [first, last] along it
        self._guide_origin = np.zeros((0, 2))
        self._guide_unit = np.zeros((0, 2))
        self._guide_reach = np.zeros((0, 2))

    @property
    def bars(self):
        """The bars' batched node (None before a build or after :meth:`remove`): what a drag grabs
        (app/drag_start.py)."""
        return self._bars

    @property
    def spheres(self):
        """The points' and centres of mass' batched node (a slider's one-point block is a ball): grabbed too."""
        return self._spheres

    @property
    def reach(self) -> float:
        return self.draw.size if self.draw is not None else 1.0

    @_locked
    def build(self, draw: Drawing, points_xy: np.ndarray, com_xy: np.ndarray) -> None:
        """Create every node for ``draw``, standing at ``points_xy`` (P, 2) and ``com_xy`` (B, 2). The same
        drawing with other sizes (a body resized on its slider) only rescales the bars and moves the parts."""
        if self._same_layout(draw):
            assert self.draw is not None
            # widths and radii stay those of the first build (the guides' lengths too): only the bars' lengths
            self.draw = dataclasses.replace(draw, size=self.draw.size, guides=self.draw.guides)
            scales = self._scales(points_xy)
            if self._bars is not None:
                update_node_props(self._bars, {"batched_scales": scales})
            self.show(points_xy, com_xy)
            return
        self.remove()
        scene = self.target.scene
        self.draw = draw
        width = BAR_WIDTH_FRACTION * draw.size
        common = {"cast_shadow": False, "receive_shadow": False}
        for k, xy in enumerate(draw.ground):
            self._handles.append(scene.add_box(f"{self.root}/ground_{k}", color=GROUND_COLOR,
                                               dimensions=(2.5 * width, 1.5 * width, 2.5 * width),
                                               position=tuple(to_world(xy)), **common))
        self._guide_ends = np.array(draw.guides, dtype=float).reshape(-1, 2, 2)
        self._guide_origin = self._guide_ends[:, 0].copy()
        along = self._guide_ends[:, 1] - self._guide_origin
        length = np.linalg.norm(along, axis=1)
        self._guide_unit = along / length[:, None]
        self._guide_reach = np.stack([np.zeros_like(length), length], axis=1)
        self._guides = None
        if len(draw.guides):
            self._guides = scene.add_line_segments(
                f"{self.root}/guides", points=to_world(self._guide_ends).astype(np.float32), colors=GROUND_COLOR,
                thickness=0.4 * width)
            self._handles.append(self._guides)
        bar_positions, bar_wxyzs, sphere_positions = self._instances(points_xy, com_xy)
        scales = self._scales(points_xy)
        box_vertices, box_faces = UNIT_BOX
        colors = [self.palette[b % len(self.palette)] for b in draw.segment_body] + [MESH_COLOR] * len(draw.meshes)
        if len(bar_positions):
            self._bars = scene.add_batched_meshes_simple(
                f"{self.root}/bars", box_vertices, box_faces, batched_wxyzs=bar_wxyzs,
                batched_positions=bar_positions, batched_scales=scales, batched_colors=instance_colors(colors),
                flat_shading=True, lod="off", **common)
            self._handles.append(self._bars)
        points = len(draw.labels)
        radii = np.full(points + len(com_xy), COM_RADIUS_FRACTION * draw.size, dtype=np.float32)
        radii[:points] = 0.6 * JOINT_RADIUS_FRACTION * draw.size
        radii[draw.joints] = JOINT_RADIUS_FRACTION * draw.size
        sphere_colors = [POINT_COLOR] * points + [COM_COLOR] * len(com_xy)
        for k in draw.joints:
            sphere_colors[k] = JOINT_COLOR
        sphere_vertices, sphere_faces = UNIT_SPHERE
        self._spheres = scene.add_batched_meshes_simple(
            f"{self.root}/spheres", sphere_vertices, sphere_faces,
            batched_wxyzs=np.tile(np.array([1.0, 0.0, 0.0, 0.0], dtype=np.float32), (len(radii), 1)),
            batched_positions=sphere_positions, batched_scales=radii,
            batched_colors=instance_colors(sphere_colors), lod="off", **common)
        self._handles.append(self._spheres)
        self._bar_positions, self._bar_wxyzs, self._sphere_positions = bar_positions, bar_wxyzs, sphere_positions

    def _same_layout(self, draw: Drawing) -> bool:
        old = self.draw
        return (old is not None and self._spheres is not None and old.labels == draw.labels
                and np.array_equal(old.segments, draw.segments) and np.array_equal(old.ground, draw.ground)
                and np.array_equal(old.meshes, draw.meshes)
                and old.guides.shape == draw.guides.shape)

    def _scales(self, points_xy: np.ndarray) -> np.ndarray:
        """Each bar's box: its length along x, the width across (a plate's edges thinner, so its outline reads
        as one body)."""
        assert self.draw is not None
        lengths = self._lengths(points_xy)
        scales = np.full((len(lengths), 3), BAR_WIDTH_FRACTION * self.draw.size, dtype=np.float32)
        scales[:, 0] = np.maximum(lengths, 1e-6)
        draw = self.draw
        plate = np.bincount(draw.segment_body, minlength=int(draw.owner.max(initial=0)) + 1)[draw.segment_body] > 1
        scales[: len(plate)][plate, 1:] *= 0.6
        scales[len(plate):, 1:] *= MESH_WIDTH_SHARE
        return scales

    def _segments(self) -> np.ndarray:
        """Every bar instance's two point indices: the bodies' segments, then the gears' lines."""
        assert self.draw is not None
        return np.concatenate([self.draw.segments, self.draw.meshes.astype(self.draw.segments.dtype)])

    def _lengths(self, points_xy: np.ndarray) -> np.ndarray:
        assert self.draw is not None
        segments = self._segments()
        a, b = points_xy[segments[:, 0]], points_xy[segments[:, 1]]
        return np.hypot(*(b - a).T) if len(a) else np.zeros(0)

    def _instances(self, points_xy: np.ndarray, com_xy: np.ndarray):
        assert self.draw is not None
        points_xy = np.asarray(points_xy, dtype=float)
        segments = self._segments()
        bar_positions, bar_wxyzs = bar_instances(points_xy[segments[:, 0]], points_xy[segments[:, 1]])
        spheres = np.concatenate([points_xy, np.asarray(com_xy, dtype=float)])
        return bar_positions, bar_wxyzs, to_world(spheres).astype(np.float32)

    @_locked
    def resend(self) -> None:
        """Send the pose drawn now again, as a frame would: a browser sees the start pose as moved parts before a
        long first derivation (the pose its scene was built with arrived as the parts' creation)."""
        if self.draw is None or self._spheres is None:
            return
        if self._bars is not None:
            update_node_props(self._bars, {"batched_positions": self._bar_positions,
                                           "batched_wxyzs": self._bar_wxyzs})
        update_node_props(self._spheres, {"batched_positions": self._sphere_positions})

    @_locked
    def show(self, points_xy: np.ndarray, com_xy: np.ndarray) -> None:
        """Move every part to one frame (two messages at most; bodies are rigid, so no bar changes length)."""
        if self.draw is None or self._spheres is None:
            return
        if self._guides is not None:
            self._cover_travel(points_xy)
        bar_positions, bar_wxyzs, sphere_positions = self._instances(points_xy, com_xy)
        if self._bars is not None:
            updates = {}
            if not np.array_equal(bar_positions, self._bar_positions):
                updates["batched_positions"] = self._bar_positions = bar_positions
            if not np.array_equal(bar_wxyzs, self._bar_wxyzs):
                updates["batched_wxyzs"] = self._bar_wxyzs = bar_wxyzs
            if updates:
                update_node_props(self._bars, updates)
        if not np.array_equal(sphere_positions, self._sphere_positions):
            self._sphere_positions = sphere_positions
            update_node_props(self._spheres, {"batched_positions": sphere_positions})

    def _cover_travel(self, points_xy: np.ndarray) -> None:
        """Lengthen a guide whose slider has run past one of its ends, to a little beyond the slider (a piston
        travels further than the sketch's size suggests: the slider-crank's runs past its guide's end). One
        product a frame; one message when a guide grows, none otherwise: a guide only grows, so it settles within
        a cycle."""
        assert self.draw is not None
        at = np.einsum("ij,ij->i", points_xy[self.draw.guide_points] - self._guide_origin, self._guide_unit)
        reach = self._guide_reach
        before, beyond = at < reach[:, 0], at > reach[:, 1]
        if not (before.any() or beyond.any()):
            return
        margin = GUIDE_MARGIN_FRACTION * self.draw.size
        reach = reach.copy()
        reach[before, 0] = at[before] - margin
        reach[beyond, 1] = at[beyond] + margin
        self._guide_reach = reach
        origin, unit = self._guide_origin[:, None, :], self._guide_unit[:, None, :]
        self._guide_ends = origin + reach[:, :, None] * unit
        update_node_props(self._guides, {"points": to_world(self._guide_ends).astype(np.float32)})

    @_locked
    def poses(self) -> dict[str, dict]:
        """Every bar's pose by part name ``bar_k`` (JSON-able): what the snapshot command waits to see in the
        browser (app/snapshot.py, its batched instance by name)."""
        out: dict[str, dict] = {}
        if self.draw is None:
            return out
        for k in range(len(self._bar_positions)):
            out[f"{self.root}/bar_{k + 1}"] = {"position": [float(v) for v in self._bar_positions[k]],
                                               "wxyz": [float(v) for v in self._bar_wxyzs[k]], "visible": True}
        return out

    @_locked
    def parts(self) -> dict[str, dict]:
        """The other parts' positions by name: ``point/BODY.POINT`` (each named point's ball), ``com_k`` (body k's
        centre of mass) and ``ground_k`` (each ground block); a hosted chain's snapshot names them as the chain's
        (app/chain_contract.py ``chain_scene``)."""
        out: dict[str, dict] = {}
        if self.draw is None:
            return out
        labels = self.draw.labels
        for k, position in enumerate(self._sphere_positions):
            name = f"point/{labels[k]}" if k < len(labels) else f"com_{k - len(labels) + 1}"
            out[f"{self.root}/{name}"] = {"position": [float(v) for v in position], "visible": True}
        for k, xy in enumerate(self.draw.ground):
            out[f"{self.root}/ground_{k}"] = {"position": [float(v) for v in to_world(xy)], "visible": True}
        return out

    @_locked
    def instance_of(self, name: str) -> tuple[str, int | None] | None:
        """Where part ``name`` of :meth:`poses` or :meth:`parts` is drawn in the browser: ``(batched node,
        instance)`` or ``(node, None)``; None for a name that is not this scene's. The batch lists the points,
        then the centres, so the instance depends on the drawing."""
        prefix = f"{self.root}/"
        if self.draw is None or not name.startswith(prefix):
            return None
        part = name[len(prefix):]
        labels = self.draw.labels
        kind, _, number = part.partition("_")
        if part.startswith("point/") and part[len("point/"):] in labels:
            return f"{self.root}/spheres", labels.index(part[len("point/"):])
        if number.isdigit() and kind == "bar" and 1 <= int(number) <= len(self._bar_positions):
            return f"{self.root}/bars", int(number) - 1
        if number.isdigit() and kind == "com" and 1 <= int(number) <= len(self._sphere_positions) - len(labels):
            return f"{self.root}/spheres", len(labels) + int(number) - 1
        if number.isdigit() and kind == "ground" and int(number) < len(self.draw.ground):
            return name, None
        return None

    @_locked
    def remove(self) -> None:
        for handle in self._handles:
            quietly(handle.remove, "removing a scene node")
        self._handles = []
        self._bars = self._spheres = self._guides = None
        self.draw = None
