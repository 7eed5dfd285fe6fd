"""Unit meshes for the batched nodes of the scene: a box of side 1 and a sphere of radius 1, built once.

Why our own: viser's ``add_box``/``add_icosphere`` make one node each, and a batched node takes a mesh (vertices
and faces); scaling each instance gives every bar its length and every ball its radius.
"""

from __future__ import annotations

import numpy as np


def unit_box() -> tuple[np.ndarray, np.ndarray]:
    """Vertices (8, 3) of the cube [-0.5, 0.5]^3 and its 12 outward-facing triangles."""
    vertices = np.array(
        [[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)], dtype=np.float32
    )  # index = 4 * (x > 0) + 2 * (y > 0) + (z > 0)
    faces = np.array(
        [
            [0, 1, 3], [0, 3, 2],  # x = -0.5
            [4, 6, 7], [4, 7, 5],  # x = +0.5
            [0, 4, 5], [0, 5, 1],  # y = -0.5
            [2, 3, 7], [2, 7, 6],  # y = +0.5
            [0, 2, 6], [0, 6, 4],  # z = -0.5
            [1, 5, 7], [1, 7, 3],  # z = +0.5
        ],
        dtype=np.uint32,
    )
    return vertices, faces


def unit_sphere(subdivisions: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """An icosphere of radius 1: the icosahedron with each triangle split in four ``subdivisions`` times
    (2: 162 vertices, 320 triangles, as viser's ``add_icosphere(subdivisions=2)``)."""
    t = (1.0 + 5.0**0.5) / 2.0
    vertices = [
        [-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0],
        [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
        [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1],
    ]
    faces = [
        [0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11],
        [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
        [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9],
        [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1],
    ]
    points = [np.array(v, dtype=float) / np.linalg.norm(v) for v in vertices]
    for _ in range(subdivisions):
        middles: dict[tuple[int, int], int] = {}

        def middle(a: int, b: int) -> int:
            key = (min(a, b), max(a, b))
            if key not in middles:
                m = points[a] + points[b]
                points.append(m / np.linalg.norm(m))
                middles[key] = len(points) - 1
            return middles[key]

        split = []
        for a, b, c in faces:
            ab, bc, ca = middle(a, b), middle(b, c), middle(c, a)
            split += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
        faces = split
    return np.array(points, dtype=np.float32), np.array(faces, dtype=np.uint32)


UNIT_BOX = unit_box()
UNIT_SPHERE = unit_sphere()
