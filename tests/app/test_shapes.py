"""The unit meshes of the batched scene nodes: closed, outward-facing, the right size."""

import numpy as np
import pytest

from app.scene import instance_colors
from app.shapes import unit_box, unit_sphere


def _signed_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    a, b, c = (vertices[faces[:, i]].astype(float) for i in range(3))
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def _closed(faces: np.ndarray) -> bool:
    edges: dict[tuple[int, int], int] = {}
    for tri in faces:
        for i in range(3):
            a, b = int(tri[i]), int(tri[(i + 1) % 3])
            edges[(a, b)] = edges.get((a, b), 0) + 1
    # every directed edge once, and its reverse once: a closed, consistently oriented surface
    return all(count == 1 and edges.get((b, a)) == 1 for (a, b), count in edges.items())


def test_unit_box_is_a_closed_outward_cube_of_volume_one():
    vertices, faces = unit_box()
    assert np.abs(vertices).max() == 0.5
    assert _closed(faces)
    assert _signed_volume(vertices, faces) == pytest.approx(1.0)  # positive: the faces point outwards


@pytest.mark.parametrize("subdivisions, n_vertices, n_faces", [(0, 12, 20), (1, 42, 80), (2, 162, 320)])
def test_unit_sphere_is_a_closed_outward_sphere_of_radius_one(subdivisions, n_vertices, n_faces):
    vertices, faces = unit_sphere(subdivisions)
    assert vertices.shape == (n_vertices, 3) and faces.shape == (n_faces, 3)
    assert np.allclose(np.linalg.norm(vertices, axis=1), 1.0, atol=1e-6)
    assert _closed(faces)
    volume = _signed_volume(vertices, faces)
    assert 0.6 * 4 / 3 * np.pi < volume < 4 / 3 * np.pi  # inscribed polyhedron, outward faces


def test_instance_colours_are_the_linear_values_of_the_srgb_palette():
    assert instance_colors([(0, 0, 0), (255, 255, 255)]).tolist() == [[0, 0, 0], [255, 255, 255]]
    # sRGB 50 % grey is 21.4 % linear light; the dark end is linear (x / 12.92)
    assert instance_colors([(128, 128, 128), (10, 10, 10)]).tolist() == [[55, 55, 55], [1, 1, 1]]
