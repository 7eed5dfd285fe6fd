"""Reaction arrows never carry a non-finite point to the browser (the long control run warned of NaN arrows:
``inf * 0`` from a stopped run's last sample)."""

from __future__ import annotations

import warnings

import numpy as np

from app.overlays import ReactionArrows


class _Scene:
    def __init__(self) -> None:
        self.points = None

    def add_arrows(self, name, points, **kw):
        self.points = points

        class Handle:
            visible = True

            def remove(self) -> None:
                pass

        handle = Handle()
        handle.points = points
        return handle


def test_a_non_finite_force_is_drawn_as_no_arrow_and_the_finite_ones_as_they_are():
    scene = _Scene()
    arrows = ReactionArrows(scene, "/r")
    joints = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    forces = np.array([[1.0, 2.0], [np.inf, 0.0], [np.nan, 1.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no RuntimeWarning either
        arrows.update(joints, forces, 0.5, 0.01)
    points = np.asarray(scene.points)
    assert np.isfinite(points).all()
    assert np.allclose(points[1, 0], points[1, 1]) and np.allclose(points[2, 0], points[2, 1])  # no arrow
    assert not np.allclose(points[0, 0], points[0, 1])  # the finite force keeps its arrow
