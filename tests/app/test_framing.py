"""Framing: the disc the mechanism can sweep fits the part of the canvas the control panel leaves free."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.camera import PANEL_PX
from app.scene import camera_pose, mechanism_reach, to_world

FOV = math.radians(75.0)


def _project(point, position, look_at, width, height):
    """Pixel coordinates of a world point through a pinhole camera with +z up (as viser's)."""
    forward = (look_at - position) / np.linalg.norm(look_at - position)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    relative = np.asarray(point) - position
    depth = relative @ forward
    half_height = math.tan(FOV / 2) * depth
    half_width = half_height * width / height
    return (0.5 + 0.5 * (relative @ right) / half_width) * width, (0.5 - 0.5 * (relative @ up) / half_height) * height


@pytest.mark.parametrize("width, height", [(1400, 850), (800, 900), (1920, 1080)])
@pytest.mark.parametrize("view", ["3d", "front"])
def test_the_reach_disc_fits_beside_the_panel(width, height, view):
    lengths = np.array([1.0, 1.0, 1.0])
    panel = PANEL_PX / width
    position, look_at = camera_pose(lengths, None, FOV, width / height, panel_fraction=panel, view=view)
    reach = mechanism_reach(lengths, None)
    circle = [to_world(reach * np.array([math.cos(a), math.sin(a)])) for a in np.linspace(0, 2 * math.pi, 72)]
    pixels = np.array([_project(p, position, look_at, width, height) for p in circle])
    free = width - PANEL_PX
    assert pixels[:, 0].min() >= 0 and pixels[:, 0].max() <= free, (pixels[:, 0].min(), pixels[:, 0].max())
    assert pixels[:, 1].min() >= 0 and pixels[:, 1].max() <= height
    centre = _project(to_world(np.zeros(2)), position, look_at, width, height)
    assert centre[0] == pytest.approx(free / 2, rel=0.05)  # centred in the free part, not behind the panel
    if view == "front":
        assert position[2] == pytest.approx(look_at[2])  # straight on: a drawing of the plane of the motion


def test_without_a_panel_the_disc_is_centred_as_before():
    position, look_at = camera_pose(np.array([1.0, 2.0]), None, FOV, 1.5)
    assert look_at[0] == pytest.approx(0.0) and position[0] == pytest.approx(0.0)
