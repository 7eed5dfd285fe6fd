"""The 3D picture of one mechanism: nodes made once under one root path, moved by :meth:`LinkageScene.show`.

Like viser's ``ViserUrdf``, a :class:`LinkageScene` takes a server or a client as its target, creates its
nodes once and afterwards only moves them; the nodes are rebuilt only when the number of bars or the
closure changes. The physics is planar in x-y with y up; the scene shows it in the vertical x-z plane of
viser's world (z up), seen from -y, so a physics point ``(x, y)`` is drawn at ``(x, 0, y)``.

Node names are stable paths (tests and the snapshot command rely on them)::

    {root}/ground            the fixed pivot O (a small block)
    {root}/pin, {root}/ground_link   pinned chains only: the ground pin H and the ground link O-H
    {root}/bar_k             bar k = 1..n, a box from joint k-1 to joint k
    {root}/joint_k           joint k = 0..n (joint 0 is O, joint n the tip)
    {root}/com_k             centre of mass of bar k
    {root}/trace             the traced point's recent path (see overlays.py)
    {root}/reactions         joint-reaction arrows (dae only, see overlays.py)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .logs import quietly
from .viser_compat import move_node

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


def bar_orientation(start_xy: np.ndarray, end_xy: np.ndarray) -> tuple[float, float, float, float]:
    """Quaternion (w, x, y, z) turning the box's local x axis onto the bar from start to end.

    A rotation by ``phi`` about world y maps x to ``(cos phi, 0, -sin phi)``; the bar direction in the
    world is ``(dx, 0, dy)``, hence ``phi = atan2(-dy, dx)``.
    """
    dx, dy = float(end_xy[0] - start_xy[0]), float(end_xy[1] - start_xy[1])
    phi = math.atan2(-dy, dx) if (dx or dy) else 0.0
    return (math.cos(phi / 2), 0.0, math.sin(phi / 2), 0.0)


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
    """

    def __init__(self, target, root: str = "/linkage", *, opacity: float | None = None, palette=None) -> None:
        self.target = target
        self.root = root.rstrip("/")
        self.opacity = opacity
        self.palette = tuple(palette) if palette is not None else BAR_COLORS
        self.layout: Layout | None = None
        self.lengths = np.zeros(0)
        self.reach = 1.0
        self._bars: list = []
        self._joints: list = []
        self._coms: list = []
        self._ground = None
        self._pin = None
        self._ground_link = None
        self._visible = True

    # ------------------------------------------------------------------ building
    def node_names(self) -> list[str]:
        """Names of the nodes this scene owns right now (for snapshots and tests)."""
        handles = [self._ground, self._pin, self._ground_link, *self._bars, *self._joints, *self._coms]
        return [h.name for h in handles if h is not None]

    def build(self, lengths: np.ndarray, pin: tuple[float, float] | None) -> None:
        """Create (or recreate, when n or the closure changed) every node, sized for ``lengths``."""
        lengths = np.asarray(lengths, dtype=float)
        layout = Layout(n=len(lengths), pinned=pin is not None)
        if layout == self.layout:
            self.resize(lengths, pin)
            return
        self.remove()
        scene = self.target.scene
        self.layout = layout
        self.lengths = lengths.copy()
        self.reach = mechanism_reach(lengths, pin)
        width = BAR_WIDTH_FRACTION * self.reach
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
        for k in range(1, layout.n + 1):
            color = self.palette[(k - 1) % len(self.palette)]
            self._bars.append(
                scene.add_box(
                    f"{self.root}/bar_{k}",
                    color=color,
                    dimensions=(max(lengths[k - 1], 1e-6), width, width),
                    **common,
                )
            )
        for k in range(layout.n + 1):
            self._joints.append(
                scene.add_icosphere(
                    f"{self.root}/joint_{k}", radius=r_joint, color=JOINT_COLOR, subdivisions=2, **common
                )
            )
        for k in range(1, layout.n + 1):
            self._coms.append(
                scene.add_icosphere(f"{self.root}/com_{k}", radius=r_com, color=COM_COLOR, subdivisions=2, **common)
            )
        if not self._visible:
            self.set_visible(False)

    @staticmethod
    def _ground_link_points(pin) -> np.ndarray:
        return to_world(np.array([[[0.0, 0.0], [pin[0], pin[1]]]])).astype(np.float32)

    def resize(self, lengths: np.ndarray, pin: tuple[float, float] | None) -> None:
        """New lengths or pin with the same layout: resize the bars, move the pin; no rebuild."""
        lengths = np.asarray(lengths, dtype=float)
        for k, bar in enumerate(self._bars):
            if lengths[k] != self.lengths[k]:
                bar.dimensions = (max(lengths[k], 1e-6), bar.dimensions[1], bar.dimensions[2])
        self.lengths = lengths.copy()
        if pin is not None and self._pin is not None:
            self._pin.position = tuple(to_world(np.array(pin)))
            self._ground_link.points = self._ground_link_points(pin)

    def remove(self) -> None:
        """Remove every node (before a rebuild, or when the session closes)."""
        for handle in [self._ground, self._pin, self._ground_link, *self._bars, *self._joints, *self._coms]:
            if handle is not None:
                quietly(handle.remove, "removing a scene node")  # a node of a departed client
        self._ground = self._pin = self._ground_link = None
        self._bars, self._joints, self._coms = [], [], []
        self.layout = None

    def set_visible(self, visible: bool) -> None:
        self._visible = visible
        for handle in [self._ground, self._pin, self._ground_link, *self._bars, *self._joints, *self._coms]:
            if handle is not None:
                handle.visible = visible

    # ------------------------------------------------------------------ moving
    def show(self, joints_xy: np.ndarray, com_xy: np.ndarray) -> None:
        """Move every node to one frame: ``joints_xy`` (n+1, 2) with joint 0 = O, ``com_xy`` (n, 2).

        The caller wraps frames in ``target.atomic()`` so a browser applies one frame at once.
        """
        joints_w = to_world(joints_xy).tolist()
        com_w = to_world(com_xy).tolist()
        for k, bar in enumerate(self._bars):
            a, b = joints_w[k], joints_w[k + 1]
            middle = (0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2]))
            move_node(bar, middle, bar_orientation(joints_xy[k], joints_xy[k + 1]))
        for k, joint in enumerate(self._joints):
            if k > 0:  # joint 0 is O and never moves
                move_node(joint, tuple(joints_w[k]), None)
        for k, com in enumerate(self._coms):
            move_node(com, tuple(com_w[k]), None)

    def poses(self) -> dict[str, dict]:
        """Current pose of every node, JSON-able: ``{name: {"position": [...], "wxyz": [...], "visible": bool}}``."""
        out = {}
        handles = [self._ground, self._pin, *self._bars, *self._joints, *self._coms]
        for h in handles:
            if h is None:
                continue
            out[h.name] = {
                "position": [float(v) for v in h.position],
                "wxyz": [float(v) for v in h.wxyz],
                "visible": bool(h.visible),
            }
        return out


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
