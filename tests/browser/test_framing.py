"""In real Chromium: the mechanism is framed in the part of the canvas the control panel leaves free, in the 3D
and the front view, at a lecture-hall size and at a narrow window."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app import snapshot as snap
from app.scene import mechanism_reach

from .conftest import wait_until

pytestmark = pytest.mark.browser


def _reach_circle_on_page(app, session) -> np.ndarray:
    """Page pixels of the disc the mechanism can sweep (world x-z plane, under the scene's root)."""
    lengths = np.array(session.setup.L, dtype=float)
    reach = mechanism_reach(lengths, session.setup.pin)
    points = [[reach * math.cos(a), 0.0, reach * math.sin(a)] for a in np.linspace(0, 2 * math.pi, 36)]
    return np.array(snap.project_world_points(app.page, "/linkage", points))


@pytest.mark.parametrize("viewport", [{"width": 1400, "height": 850}, {"width": 800, "height": 900}])
def test_the_whole_reach_is_beside_the_panel_in_both_views(start_lab, viewport):
    lab = start_lab(preset="single")
    app = lab.open_page(viewport=viewport)
    session = app.session
    panel = app.panel_box()
    assert panel is not None
    for view in ("3d", "front"):
        session.set_camera_view(view)

        def framed() -> bool:
            circle = _reach_circle_on_page(app, session)
            return bool(circle[:, 0].max() <= panel["x"] + 1 and circle[:, 0].min() >= -1
                        and circle[:, 1].min() >= -1 and circle[:, 1].max() <= viewport["height"] + 1)

        wait_until(framed, message=f"the reach disc beside the panel in the {view} view at {viewport}")
