"""A chunk's drawing takes every named point's path in one batched pass (``BodyPoints.paths``): the same numbers,
bit for bit, as the point-by-point ``path`` it replaced, for every mechanism preset and a chain."""

from __future__ import annotations

import numpy as np
import pytest

from physics.chain_presets import get_preset
from physics.mechanism import MECHANISM_PRESETS
from physics.mechanism.chains import chain_mechanism
from physics.mechanism.run_table import body_points

MECHANISMS = {**{name: build for name, build in MECHANISM_PRESETS.items()},
              **{name: (lambda name=name: chain_mechanism(get_preset(name).chain, get_preset(name).theta0))
                 for name in ("triple-a", "four-bar")}}


@pytest.mark.parametrize("name", sorted(MECHANISMS))
def test_every_points_path_in_one_pass_is_each_points_own(name):
    mechanism = MECHANISMS[name]()
    paths = body_points(mechanism)
    q = np.random.default_rng(7).uniform(-5.0, 5.0, (23, 3 * len(mechanism.bodies)))
    for count in {len(paths.names), max(1, len(paths.names) - 1), 1}:  # with and without the ground's points
        one_by_one = np.stack([paths.path(q, k) for k in range(count)], axis=1)
        assert np.array_equal(paths.paths(q, count), one_by_one), count
