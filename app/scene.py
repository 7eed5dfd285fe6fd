"""What every picture of a linkage shares: the plane-to-world map, colours and sizes, framing.

The physics is planar in x-y with y up; the scene shows it in the vertical x-z plane of viser's world (z up),
seen from -y, so a physics point ``(x, y)`` is drawn at ``(x, 0, y)`` (:func:`to_world`). The scene itself is
:class:`app.mechanism_scene.MechanismScene`, for chains and mechanisms alike; the camera's framing of a reach
or of one instant's pose is here (:func:`camera_pose`, :func:`pose_disc`).
"""

from __future__ import annotations

import math

import numpy as np

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


def mechanism_reach(lengths: np.ndarray, pin: tuple[float, float] | None) -> float:
    """Radius of the disc around O that the mechanism can sweep (its size for framing and widths)."""
    reach = float(np.sum(lengths))
    if pin is not None:
        reach = max(reach, math.hypot(*pin))
    return max(reach, 1e-3)


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
