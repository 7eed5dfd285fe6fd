"""A slider's guide in the app's 3D picture (app/mechanism_scene.py) covers the slider's travel: drawn first from
the sketch's size, it grows along its own line as far as the slider runs, and no further. Before, the
slider-crank's piston ran off the end of its guide at every turn."""

from __future__ import annotations

import numpy as np
import pytest
import viser

from app.mechanism_runs import GUIDE_MARGIN_FRACTION, centres_at, drawing, points_at
from app.mechanism_scene import MechanismScene
from app.scene import to_world
from physics.mechanism import MECHANISM_PRESETS
from physics.mechanism.assembly import assemble
from physics.mechanism.simulate import simulate_mechanism


@pytest.fixture(scope="module")
def server():
    target = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield target
    target.stop()


def _fractions(ends: np.ndarray, sliding: np.ndarray) -> np.ndarray:
    """Where each sliding point projects on its guide: 0 at its first end, 1 at its second."""
    along = ends[:, 1] - ends[:, 0]
    return np.einsum("ij,ij->i", sliding - ends[:, 0], along) / np.einsum("ij,ij->i", along, along)


def _across(ends: np.ndarray, point: np.ndarray) -> float:
    """Distance of ``point`` from the line of the single guide ``ends`` (2, 2)."""
    along = (ends[1] - ends[0]) / np.linalg.norm(ends[1] - ends[0])
    offset = point - ends[0]
    return float(abs(offset[0] * along[1] - offset[1] * along[0]))


def test_the_slider_cranks_guide_grows_to_the_pistons_travel_and_no_further(server):
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    draw = drawing(mechanism)
    index = {label: k for k, label in enumerate(draw.labels)}
    assert draw.guide_points.tolist() == [index["piston.B"]]
    first = draw.guides.copy()
    run = simulate_mechanism(mechanism, 2.0, 201)
    travel = np.array([points_at(draw, pose)[draw.guide_points] for pose in run.q])  # (T, 1, 2)
    outside = np.array([_fractions(first, sliding) for sliding in travel])
    assert (outside > 1.0).any() or (outside < 0.0).any(), "the preset no longer runs past its first guide"
    sketch = points_at(draw, assemble(mechanism).q)[draw.guide_points]
    assert 0.0 <= _fractions(first, sketch).min() and _fractions(first, sketch).max() <= 1.0  # drawn on it

    scene = MechanismScene(server)
    q = assemble(mechanism).q
    scene.build(draw, points_at(draw, q), centres_at(q))
    for pose in run.q:
        scene.show(points_at(draw, pose), centres_at(pose))
    ends = scene._guide_ends
    inside = np.array([_fractions(ends, sliding) for sliding in travel])
    assert inside.min() >= 0.0 and inside.max() <= 1.0  # every place the piston was lies on its guide
    for end in ends[0]:  # still the same line: only lengthened
        assert _across(first[0], end) < 1e-12
    margin = GUIDE_MARGIN_FRACTION * draw.size
    length = np.linalg.norm(ends[0, 1] - ends[0, 0])
    reach = inside[:, 0] * length  # distances along the guide from its first end
    # an end the piston passed sits at most one margin beyond its farthest place; one it never passed stayed
    for k, passed in ((0, (outside < 0.0).any()), (1, (outside > 1.0).any())):
        if passed:
            beyond = reach.min() if k == 0 else length - reach.max()
            assert 0.0 <= beyond <= margin * (1 + 1e-9)
        else:
            assert np.array_equal(ends[0, k], first[0, k])
    shown = np.asarray(scene._guides._impl.props.points)  # what the browser was sent
    assert np.allclose(shown, to_world(ends).astype(np.float32))
    scene.remove()


def test_a_frame_within_the_guide_leaves_it_as_it_is(server):
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    draw = drawing(mechanism)
    scene = MechanismScene(server)
    q = assemble(mechanism).q
    scene.build(draw, points_at(draw, q), centres_at(q))
    before = scene._guide_ends
    scene.show(points_at(draw, q), centres_at(q))  # the sketch's own pose: the piston on its first guide
    assert scene._guide_ends is before
    scene.remove()


def test_a_mechanism_without_a_slider_on_the_ground_has_no_guide(server):
    mechanism = MECHANISM_PRESETS["crank-rocker"]()
    draw = drawing(mechanism)
    assert draw.guides.shape == (0, 2, 2) and draw.guide_points.shape == (0,)
    scene = MechanismScene(server)
    q = assemble(mechanism).q
    scene.build(draw, points_at(draw, q), centres_at(q))
    scene.show(points_at(draw, q), centres_at(q))
    assert scene._guides is None
    scene.remove()
