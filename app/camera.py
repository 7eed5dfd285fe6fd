"""The camera director: frames the mechanism in each browser, and again when its size or canvas changes.

Why apart from the session: framing depends on the browser (its canvas shape, reported later than the
connection) and on nothing of the simulation but the bar lengths and the pin. It reframes when the reach
changes by more than :data:`~app.scene.REFRAME_TOLERANCE` or a canvas changes shape by more than 5 %
(orbiting alone never reframes).
"""

from __future__ import annotations

import numpy as np

from .logs import quietly
from .scene import REFRAME_TOLERANCE, camera_pose, mechanism_reach

ASPECT_TOLERANCE = 0.05
# The control panel floats over the canvas's right side: viser's "large" width, 24 em of 16 px, plus its margin.
PANEL_PX = 400.0
# Below this canvas width (a phone: viser's mobile layout below Mantine's xs breakpoint, 36 em) the panel is a
# full-width bottom sheet, not beside the canvas: folded it leaves the whole canvas free, opened the canvas shrinks
# to the part above it (static/page.html), so the whole canvas is framed either way.
PANEL_MIN_CANVAS_PX = 576.0
VIEWS = ("3d", "front")


class CameraDirector:
    """Cameras of one session's browser (``target`` a client) or of every browser (``shared``, the server)."""

    def __init__(self, target, shared: bool) -> None:
        self.target = target
        self.shared = shared
        self.closed = False
        self.framed_reach: float | None = None
        self.framed_aspect: dict[int, float] = {}  # id(camera) -> aspect it was framed for
        self.framed_panel: dict[int, float] = {}  # id(camera) -> panel fraction it was framed for
        self._watched: set[int] = set()
        self._lengths = np.ones(1)
        self._pin: tuple[float, float] | None = None
        self.view = "3d"
        # False when the control panel is hidden (headless pictures): the whole canvas is free
        self.reserve_panel = True
        # (centre_xy, radius) to frame instead of the whole reach (a picture of one instant: pose_disc)
        self.disc: tuple[np.ndarray, float] | None = None

    def set_view(self, view: str) -> None:
        """Front (the plane of the motion as a drawing) or 3D (slightly from above); every camera reframed."""
        if view not in VIEWS:
            raise ValueError(f"view = {view!r}: allowed {', '.join(VIEWS)}")
        self.view = view
        self.framed_aspect.clear()
        self.frame(self._lengths, self._pin, force=True)

    def frame(self, lengths, pin, force: bool = False, client=None) -> None:
        """Point the camera(s) at the mechanism; only when its size changed noticeably unless ``force``.
        ``client``: only that browser's camera (a browser joining a shared session)."""
        self._lengths, self._pin = np.asarray(lengths, dtype=float), pin
        reach = mechanism_reach(self._lengths, pin)
        unchanged = self.framed_reach is not None and abs(reach / self.framed_reach - 1.0) < REFRAME_TOLERANCE
        if client is None and not force and unchanged:
            return
        if client is not None:
            cameras = [client.camera]
        elif self.shared:
            self.framed_reach = reach
            position, look_at = camera_pose(self._lengths, pin, view=self.view, disc=self.disc)

            def initial() -> None:  # what a browser that connects later starts with
                self.target.initial_camera.position = tuple(position)
                self.target.initial_camera.look_at = tuple(look_at)
                self.target.initial_camera.up = (0.0, 0.0, 1.0)

            quietly(initial, "setting the initial camera")
            cameras = [c.camera for c in self.target.get_clients().values()]
        else:
            self.framed_reach = reach
            cameras = [self.target.camera]
        for camera in cameras:
            self._watch_canvas(camera)
            aspect = _aspect(camera)
            if aspect is not None:  # None: the browser has not reported its canvas yet; framed when it does
                self.frame_one(camera, aspect)

    def frame_one(self, camera, aspect: float) -> None:
        self.framed_aspect[id(camera)] = aspect
        self.framed_panel[id(camera)] = panel_fraction(camera) if self.reserve_panel else 0.0
        position, look_at = camera_pose(self._lengths, self._pin, aspect=aspect,
                                        panel_fraction=panel_fraction(camera) if self.reserve_panel else 0.0,
                                        view=self.view, disc=self.disc)

        def move() -> None:
            with self.target.atomic():
                camera.up_direction = (0.0, 0.0, 1.0)
                camera.position = tuple(position)
                camera.look_at = tuple(look_at)

        quietly(move, "moving a camera")  # the browser may have gone meanwhile

    def _watch_canvas(self, camera) -> None:
        """Frame a browser's camera again when its canvas is first reported or changes shape (the layout
        settling beside the control panel, a window resized): a canvas narrower than it is tall must still
        show the whole mechanism."""
        key = id(camera)
        if key in self._watched:
            return
        self._watched.add(key)

        def on_camera(reported) -> None:
            if self.closed:
                return
            aspect = _aspect(reported)
            framed = self.framed_aspect.get(key)
            share = panel_fraction(reported) if self.reserve_panel else 0.0
            panel_moved = abs(share - self.framed_panel.get(key, 0.0)) > ASPECT_TOLERANCE / 2
            if aspect is not None and (framed is None or abs(aspect / framed - 1.0) > ASPECT_TOLERANCE or panel_moved):
                self.frame_one(reported, aspect)

        camera.on_update(on_camera)


def panel_fraction(camera) -> float:
    """The share of this browser's canvas width the control panel covers (0 on a narrow canvas or before the
    browser reported its size)."""
    try:
        width = float(camera.image_width)
    except (AttributeError, TypeError, ValueError, AssertionError):
        return 0.0
    return PANEL_PX / width if width >= PANEL_MIN_CANVAS_PX else 0.0


def _aspect(camera) -> float | None:
    """The canvas aspect a browser reported, or None before its first report (viser raises then)."""
    try:
        return float(camera.aspect)
    except (AttributeError, TypeError, ValueError, AssertionError):
        return None
