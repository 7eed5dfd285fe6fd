"""The 3D picture of one mechanism: nodes made once under one root path, moved by :meth:`LinkageScene.show`.

Like viser's ``ViserUrdf``, a :class:`LinkageScene` takes a server or a client as its target, creates its
nodes once and afterwards only moves them; the nodes are rebuilt only when the number of bars or the
closure changes. The physics is planar in x-y with y up; the scene shows it in the vertical x-z plane of
viser's world (z up), seen from -y, so a physics point ``(x, y)`` is drawn at ``(x, 0, y)``.

Node names are stable paths (tests and the snapshot command rely on them)::

    {root}/ground            the fixed pivot O (a small block)
    {root}/pin, {root}/ground_link   pinned chains only: the ground pin H and the ground link O-H
    {root}/bars              the bars, one batched box mesh: instance k-1 is bar k, from joint k-1 to joint k
    {root}/spheres           the joints and centres of mass, one batched sphere mesh: instance 2k is joint k
                             (k = 0..n; joint 0 is O, joint n the tip), instance 2k-1 the centre of mass of bar k

Each bar, joint and centre of mass also has a part name, ``{root}/bar_k``, ``{root}/joint_k`` and
``{root}/com_k``: :meth:`LinkageScene.poses` reports the parts under those names, and the browser helpers of
``app/snapshot.py`` find a part's instance in its batched node by that name (:func:`part_instance`).
    {root}/trace             the traced point's recent path (see overlays.py)
    {root}/reactions         joint-reaction arrows (dae only, see overlays.py)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .logs import quietly
from .shapes import UNIT_BOX, UNIT_SPHERE
from .viser_compat import update_node_props

# Bar colours, one per bar index (cycled); saturated so a screenshot test can find the links.
BAR_COLORS = (
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (23, 190, 207),
)
JOINT_COLOR = (60, 60, 60)
COM_COLOR = (250, 250, 250)
GROUND_COLOR = (90, 90, 90)
PIN_COLOR = (120, 120, 120)

# Sizes relative to the mechanism's reach, so a 0.1 m chain and a 10 m chain look alike.
BAR_WIDTH_FRACTION = 0.035
JOINT_RADIUS_FRACTION = 0.028
COM_RADIUS_FRACTION = 0.02
# Below this relative change of the reach the camera is left alone (no jumps while dragging a slider).
REFRAME_TOLERANCE = 0.15


def to_world(xy: np.ndarray) -> np.ndarray:
    """Physics plane (x, y) -> viser world (x, 0, y). Shape (..., 2) -> (..., 3)."""
    xy = np.asarray(xy, dtype=float)
    out = np.zeros(xy.shape[:-1] + (3,))
    out[..., 0] = xy[..., 0]
    out[..., 2] = xy[..., 1]
    return out


def instance_colors(colors) -> np.ndarray:
    """(N, 3) uint8 instance colours that show as the sRGB ``colors`` given: viser's batched meshes take
    instance colours as linear values (a node's own ``color`` is sRGB), so without this conversion the bars
    came out paler than viser's own boxes of the same colour (measured in Chromium on the same lit face: the
    blue bar (31, 119, 180) drew as (63, 132, 169) where ``add_box`` drew (0, 73, 136); with it, (0, 73, 136))."""
    srgb = np.asarray(colors, dtype=float) / 255.0
    linear = np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)
    return np.round(255.0 * linear).astype(np.uint8)


def part_instance(name: str) -> tuple[str, int | None]:
    """Where a part is drawn: ``(node name, instance index)`` for a bar, joint or centre of mass of a
    :class:`LinkageScene` (``/linkage/bar_2`` -> ``("/linkage/bars", 1)``), ``(name, None)`` for any other node."""
    root, _, part = name.rpartition("/")
    kind, _, number = part.partition("_")
    if not number.isdigit():
        return name, None
    k = int(number)
    if kind == "bar" and k >= 1:
        return f"{root}/bars", k - 1
    if kind == "joint":
        return f"{root}/spheres", 2 * k
    if kind == "com" and k >= 1:
        return f"{root}/spheres", 2 * k - 1
    return name, None


def bar_instances(starts_xy: np.ndarray, ends_xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Batched positions and orientations (float32) of unit boxes drawn from ``starts_xy`` to ``ends_xy``
    (each (k, 2), physics plane): the box's x axis along the bar, centred between the ends."""
    starts_xy, ends_xy = np.asarray(starts_xy, dtype=float), np.asarray(ends_xy, dtype=float)
    middle = 0.5 * (starts_xy + ends_xy)
    delta = ends_xy - starts_xy
    # a rotation by phi about world y maps the box's x axis to (cos phi, 0, -sin phi); the bar runs along
    # (dx, 0, dy) in the world, hence phi = atan2(-dy, dx) (0 for a bar of zero length)
    half_phi = 0.5 * np.arctan2(-delta[:, 1], delta[:, 0])
    positions = np.zeros((len(middle), 3), np.float32)
    positions[:, 0], positions[:, 2] = middle[:, 0], middle[:, 1]
    wxyzs = np.zeros((len(middle), 4), np.float32)
    wxyzs[:, 0], wxyzs[:, 2] = np.cos(half_phi), np.sin(half_phi)
    return positions, wxyzs


@dataclass(frozen=True)
class Layout:
    """What decides the set of nodes: rebuild only when this changes."""

    n: int
    pinned: bool


def mechanism_reach(lengths: np.ndarray, pin: tuple[float, float] | None) -> float:
    """Radius of the disc around O that the mechanism can sweep (its size for framing and widths)."""
    reach = float(np.sum(lengths))
    if pin is not None:
        reach = max(reach, math.hypot(*pin))
    return max(reach, 1e-3)


class LinkageScene:
    """Nodes of one mechanism under ``root``; ``build`` once per layout, ``show`` every frame.

    ``target`` is a ``viser.ViserServer`` (shared scene) or a ``viser.ClientHandle`` (one browser).
    ``opacity`` < 1 draws a translucent mechanism (compare mode); ``palette`` overrides the bar colours.

    Why batched nodes: a frame's cost on the server is almost all in viser's message path, per message. The
    bars are one batched box mesh and the joints and centres of mass one batched sphere mesh, so a frame is
    two messages (bars: positions and orientations together; spheres: positions) whatever the number of bars,
    where one node per part took 4n messages.
    """

    def __init__(self, target, root: str = "/linkage", *, opacity: float | None = None, palette=None) -> None:
        self.target = target
        self.root = root.rstrip("/")
        self.opacity = opacity
        self.palette = tuple(palette) if palette is not None else BAR_COLORS
        self.layout: Layout | None = None
        self.lengths = np.zeros(0)
        self.reach = 1.0
        self._width = 0.0
        self._bars = None  # batched box mesh, instance k-1 = bar k
        self._spheres = None  # batched sphere mesh, instance 2k = joint k, 2k-1 = centre of mass of bar k
        self._ground = None
        self._pin = None
        self._ground_link = None
        self._visible = True
        # what the browser was last sent (float32, as viser sends it)
        self._bar_positions = np.zeros((0, 3), np.float32)
        self._bar_wxyzs = np.zeros((0, 4), np.float32)
        self._sphere_positions = np.zeros((0, 3), np.float32)

    # ------------------------------------------------------------------ building
    def node_names(self) -> list[str]:
        """Names of the parts this scene draws right now (for snapshots and tests): the static nodes and, for
        each bar, joint and centre of mass, its part name (an instance of a batched node, see the module)."""
        return list(self.poses())

    @property
    def batched_nodes(self) -> dict[str, object]:
        """The two batched handles by kind (``bars``, ``spheres``); empty before :meth:`build`."""
        return {} if self._bars is None else {"bars": self._bars, "spheres": self._spheres}

    def build(self, lengths: np.ndarray, pin: tuple[float, float] | None) -> None:
        """Create (or recreate, when n or the closure changed) every node, sized for ``lengths``."""
        lengths = np.asarray(lengths, dtype=float)
        layout = Layout(n=len(lengths), pinned=pin is not None)
        if layout == self.layout:
            self.resize(lengths, pin)
            return
        self.remove()
        scene = self.target.scene
        n = layout.n
        self.layout = layout
        self.lengths = lengths.copy()
        self.reach = mechanism_reach(lengths, pin)
        width = self._width = BAR_WIDTH_FRACTION * self.reach
        r_joint = JOINT_RADIUS_FRACTION * self.reach
        r_com = COM_RADIUS_FRACTION * self.reach
        common = {"opacity": self.opacity, "cast_shadow": False, "receive_shadow": False}
        self._ground = scene.add_box(
            f"{self.root}/ground", color=GROUND_COLOR, dimensions=(2.5 * width, 1.5 * width, 2.5 * width), **common
        )
        if layout.pinned:
            self._pin = scene.add_box(
                f"{self.root}/pin",
                color=PIN_COLOR,
                dimensions=(2.5 * width, 1.5 * width, 2.5 * width),
                position=tuple(to_world(np.array(pin))),
                **common,
            )
            self._ground_link = scene.add_line_segments(
                f"{self.root}/ground_link",
                points=self._ground_link_points(pin),
                colors=GROUND_COLOR,
                thickness=0.5 * width,
            )
        # start pose: the chain hanging straight down (the first show() moves it at once)
        joints_xy = np.zeros((n + 1, 2))
        joints_xy[1:, 1] = -np.cumsum(lengths)
        com_xy = 0.5 * (joints_xy[:-1] + joints_xy[1:])
        bar_positions, bar_wxyzs, sphere_positions = self._instances(joints_xy, com_xy)
        box_vertices, box_faces = UNIT_BOX
        self._bars = scene.add_batched_meshes_simple(
            f"{self.root}/bars",
            box_vertices,
            box_faces,
            batched_wxyzs=bar_wxyzs,
            batched_positions=bar_positions,
            batched_scales=self._bar_scales(lengths),
            batched_colors=instance_colors([self.palette[k % len(self.palette)] for k in range(n)]),
            flat_shading=True,  # as viser's add_box: a box's 8 shared corners would otherwise smooth its faces
            lod="off",
            **common,
        )
        sphere_vertices, sphere_faces = UNIT_SPHERE
        radii = np.full(2 * n + 1, r_joint, dtype=np.float32)
        radii[1::2] = r_com
        colors = instance_colors([COM_COLOR if i % 2 else JOINT_COLOR for i in range(2 * n + 1)])
        self._spheres = scene.add_batched_meshes_simple(
            f"{self.root}/spheres",
            sphere_vertices,
            sphere_faces,
            batched_wxyzs=np.tile(np.array([1.0, 0.0, 0.0, 0.0], dtype=np.float32), (2 * n + 1, 1)),
            batched_positions=sphere_positions,
            batched_scales=radii,
            batched_colors=colors,
            lod="off",
            **common,
        )
        self._bar_positions, self._bar_wxyzs, self._sphere_positions = bar_positions, bar_wxyzs, sphere_positions
        if not self._visible:
            self.set_visible(False)

    def _bar_scales(self, lengths: np.ndarray) -> np.ndarray:
        scales = np.full((len(lengths), 3), self._width, dtype=np.float32)
        scales[:, 0] = np.maximum(lengths, 1e-6)
        return scales

    @staticmethod
    def _ground_link_points(pin) -> np.ndarray:
        return to_world(np.array([[[0.0, 0.0], [pin[0], pin[1]]]])).astype(np.float32)

    def resize(self, lengths: np.ndarray, pin: tuple[float, float] | None) -> None:
        """New lengths or pin with the same layout: resize the bars, move the pin; no rebuild."""
        lengths = np.asarray(lengths, dtype=float)
        if self._bars is not None and not np.array_equal(lengths, self.lengths):
            self._bars.batched_scales = self._bar_scales(lengths)
        self.lengths = lengths.copy()
        if pin is not None and self._pin is not None:
            self._pin.position = tuple(to_world(np.array(pin)))
            self._ground_link.points = self._ground_link_points(pin)

    def _handles(self) -> list:
        return [h for h in (self._ground, self._pin, self._ground_link, self._bars, self._spheres) if h is not None]

    def remove(self) -> None:
        """Remove every node (before a rebuild, or when the session closes)."""
        for handle in self._handles():
            quietly(handle.remove, "removing a scene node")  # a node of a departed client
        self._ground = self._pin = self._ground_link = self._bars = self._spheres = None
        self.layout = None

    def set_visible(self, visible: bool) -> None:
        self._visible = visible
        for handle in self._handles():
            handle.visible = visible

    @property
    def visible(self) -> bool:
        return self._visible

    # ------------------------------------------------------------------ moving
    @staticmethod
    def _instances(joints_xy: np.ndarray, com_xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Batched positions and orientations (float32) of the bars and spheres for one frame."""
        joints_xy = np.asarray(joints_xy, dtype=float)
        n = len(joints_xy) - 1
        bar_positions, bar_wxyzs = bar_instances(joints_xy[:-1], joints_xy[1:])
        sphere_positions = np.zeros((2 * n + 1, 3), np.float32)
        sphere_positions[0::2, 0], sphere_positions[0::2, 2] = joints_xy[:, 0], joints_xy[:, 1]
        sphere_positions[1::2, 0], sphere_positions[1::2, 2] = com_xy[:, 0], com_xy[:, 1]
        return bar_positions, bar_wxyzs, sphere_positions

    def show(self, joints_xy: np.ndarray, com_xy: np.ndarray) -> None:
        """Move every part to one frame: ``joints_xy`` (n+1, 2) with joint 0 = O, ``com_xy`` (n, 2).

        Two messages at most (none for a part that did not move). The caller wraps frames in
        ``target.atomic()`` so a browser applies one frame at once.
        """
        if self._bars is None:
            return
        bar_positions, bar_wxyzs, sphere_positions = self._instances(joints_xy, np.asarray(com_xy, dtype=float))
        bars = {}
        if not np.array_equal(bar_positions, self._bar_positions):
            bars["batched_positions"] = self._bar_positions = bar_positions
        if not np.array_equal(bar_wxyzs, self._bar_wxyzs):
            bars["batched_wxyzs"] = self._bar_wxyzs = bar_wxyzs
        if bars:
            update_node_props(self._bars, bars)
        if not np.array_equal(sphere_positions, self._sphere_positions):
            self._sphere_positions = sphere_positions
            update_node_props(self._spheres, {"batched_positions": sphere_positions})

    def poses(self) -> dict[str, dict]:
        """Current pose of every part, JSON-able: ``{name: {"position": [...], "wxyz": [...], "visible": bool}}``,
        one entry per static node and per bar (``bar_k``), joint (``joint_k``) and centre of mass (``com_k``)."""
        out: dict[str, dict] = {}
        for h in (self._ground, self._pin):
            if h is not None:
                out[h.name] = {
                    "position": [float(v) for v in h.position],
                    "wxyz": [float(v) for v in h.wxyz],
                    "visible": bool(h.visible),
                }
        if self._bars is None:
            return out
        n = len(self._bar_positions)
        for k in range(1, n + 1):
            out[f"{self.root}/bar_{k}"] = {
                "position": [float(v) for v in self._bar_positions[k - 1]],
                "wxyz": [float(v) for v in self._bar_wxyzs[k - 1]],
                "visible": self._visible,
            }
        for k in range(n + 1):
            out[f"{self.root}/joint_{k}"] = self._sphere_pose(2 * k)
        for k in range(1, n + 1):
            out[f"{self.root}/com_{k}"] = self._sphere_pose(2 * k - 1)
        return out

    def _sphere_pose(self, index: int) -> dict:
        return {
            "position": [float(v) for v in self._sphere_positions[index]],
            "wxyz": [1.0, 0.0, 0.0, 0.0],
            "visible": self._visible,
        }


def pose_disc(points_xy: np.ndarray, margin: float = 1.35) -> tuple[np.ndarray, float]:
    """The smallest centred box's disc around ``points_xy`` (joints and ground points at one instant), with a
    margin: what a picture of that instant frames."""
    points = np.asarray(points_xy, dtype=float).reshape(-1, 2)
    low, high = points.min(axis=0), points.max(axis=0)
    center = 0.5 * (low + high)
    return center, margin * max(float(np.max(np.linalg.norm(points - center, axis=1))), 0.05)


def camera_pose(lengths: np.ndarray, pin, fov: float = math.radians(75.0), aspect: float = 1.5,
                panel_fraction: float = 0.0, view: str = "3d",
                disc: tuple[np.ndarray, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Camera position and look-at point (world) that frame the disc the mechanism can sweep.

    Seen from -y, slightly from above (``view="3d"``) or straight on (``view="front"``: the plane of the motion
    as a drawing), so the vertical plane of the motion faces the viewer. ``fov`` is the vertical field of view.
    ``panel_fraction``: the share of the canvas width the control panel covers on the right; the disc is fitted
    into, and centred in, the part left free. On a canvas narrower than it is tall the camera backs off so the
    disc also fits across. ``disc``: ``(centre_xy, radius)`` to frame instead (a picture of one instant frames
    the mechanism as it stands there, :func:`pose_disc`).
    """
    reach = mechanism_reach(lengths, pin)
    center_xy = np.zeros(2)
    if pin is not None:
        center_xy = 0.5 * np.array(pin, dtype=float)
    if disc is not None:
        center_xy, reach = np.asarray(disc[0], dtype=float), max(float(disc[1]), 1e-3)
    aspect = aspect if math.isfinite(aspect) and aspect > 0.05 else 1.5
    panel_fraction = min(max(panel_fraction, 0.0), 0.6) if math.isfinite(panel_fraction) else 0.0
    free_aspect = aspect * (1.0 - panel_fraction)  # free width over height
    half_height = math.tan(0.5 * fov)
    # a little room around the disc; more from above, where the near half of the disc looks larger
    margin = 1.05 if view == "front" else 1.15
    distance = margin * reach / half_height * max(1.0, 1.0 / free_aspect)
    # shift the view right by half the panel, so the disc sits in the middle of the free part
    shift = panel_fraction * aspect * half_height * distance
    look_at = to_world(center_xy) + np.array([shift, 0.0, 0.0])
    lift = 0.0 if view == "front" else 0.12 * distance
    position = look_at + np.array([0.0, -distance, lift])
    return position, look_at
