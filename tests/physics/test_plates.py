"""Ternary plates of the presets (physics/mechanism/presets.py): mass, centre of mass and inertia from one stated
model, each checked against a numerical integration over the plate (the frame's edges, or the lamina's area)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from physics.mechanism import MECHANISM_PRESETS
from physics.mechanism.presets import AREAL_DENSITY, LINEAR_DENSITY, PLATE_MODEL, plate

CORNERS = {"P": (0.1, -0.2), "Q": (0.7, 0.05), "R": (0.25, 0.55)}


def frame_by_sampling(corners, per_edge=20_000):
    """Point masses at the midpoints of small pieces of each edge (midpoint rule), weighted by their length."""
    xy = list(corners.values())
    points, weights = [], []
    for p, q in zip(xy, xy[1:] + xy[:1]):
        p, q = np.array(p), np.array(q)
        fractions = (np.arange(per_edge) + 0.5) / per_edge
        points.append(p + fractions[:, None] * (q - p))
        weights.append(np.full(per_edge, LINEAR_DENSITY * np.linalg.norm(q - p) / per_edge))
    return np.vstack(points), np.concatenate(weights)


def lamina_by_sampling(corners, n=600):
    """The triangle cut into n^2 small similar triangles, a point mass of AREAL_DENSITY times its area at each
    centroid (exact for the mass and centre, second order for the inertia)."""
    a, b, c = (np.array(v) for v in corners.values())
    area = abs((b - a)[0] * (c - a)[1] - (b - a)[1] * (c - a)[0]) / 2
    points = []
    for i in range(n):
        for j in range(n - i):
            up = a + (b - a) * (i + 1 / 3) / n + (c - a) * (j + 1 / 3) / n  # upward small triangle
            points.append(up)
            if j < n - i - 1:
                points.append(a + (b - a) * (i + 2 / 3) / n + (c - a) * (j + 2 / 3) / n)  # downward one
    points = np.array(points)
    return points, np.full(len(points), AREAL_DENSITY * area / n**2)


@pytest.mark.parametrize("model, sampler", [("frame", frame_by_sampling), ("lamina", lamina_by_sampling)])
def test_plate_inertia_against_numerical_integration(model, sampler):
    body = plate("p", CORNERS, model=model)
    points, weights = sampler(CORNERS)
    mass = weights.sum()
    centre = weights @ points / mass
    inertia = weights @ np.sum((points - centre) ** 2, axis=1)
    assert body.mass == pytest.approx(mass, rel=1e-12)
    assert body.com == pytest.approx(tuple(centre), abs=1e-12)
    assert body.inertia == pytest.approx(inertia, rel=1e-5)


def test_the_two_models_differ_as_physics_says():
    """Same corners: a frame keeps its mass on the rim, so per kilogram it is harder to turn than a lamina."""
    frame, lamina = plate("p", CORNERS, "frame"), plate("p", CORNERS, "lamina")
    assert frame.inertia / frame.mass > 1.5 * lamina.inertia / lamina.mass


def test_an_unknown_model_is_refused_in_one_line():
    with pytest.raises(ValueError, match=r"plate model = 'solid': allowed frame, lamina"):
        plate("p", CORNERS, model="solid")


PRESET_PLATES = {"watt-six-bar": "rocker", "stephenson-six-bar": "coupler", "jansen-leg": ("triangle", "foot")}


def test_the_presets_plates_follow_the_default_model():
    """The presets' plates are plates of PLATE_MODEL (frame: mass = perimeter x line density, as before)."""
    for preset, names in PRESET_PLATES.items():
        bodies = {body.name: body for body in MECHANISM_PRESETS[preset]().bodies}
        for name in (names,) if isinstance(names, str) else names:
            body = bodies[name]
            expected = plate(name, body.points, PLATE_MODEL)
            assert (body.mass, body.com, body.inertia) == (expected.mass, expected.com, expected.inertia)
            corners = list(body.points.values())
            perimeter = sum(math.dist(p, q) for p, q in zip(corners, corners[1:] + corners[:1]))
            assert body.mass == pytest.approx(LINEAR_DENSITY * perimeter)
