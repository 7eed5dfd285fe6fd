"""A new mechanism's first process stays lean: the sweep through a turn follows the poses assembly would give
(without building the constraints at every pose), and the mechanism command loads no picture library."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from physics.errors import LinkageError
from physics.mechanism import MECHANISM_PRESETS, Mechanism
from physics.mechanism.assembly import assemble
from physics.mechanism.validation import SWEEP_POSES_PER_TURN, _Follower

CHILD = r"""
import contextlib, io, json, sys
from physics.cli import main
with contextlib.redirect_stdout(io.StringIO()):
    code = main(["mechanism", "--preset", "crank-rocker", "--t-end", "0.2"])
print(json.dumps({"code": code, "modules": sorted(sys.modules)}))
"""


def _fully_driven() -> list[str]:
    return [name for name, make in MECHANISM_PRESETS.items() if assemble(make()).mobility == 0]


@pytest.mark.parametrize("name", _fully_driven())
def test_the_sweep_follows_the_poses_assembly_gives_to_the_bit(name):
    mechanism = MECHANISM_PRESETS[name]()
    follow = _Follower(mechanism)
    q_assembled = q_followed = assemble(mechanism).q
    period = 2.0 * math.pi / min(abs(d.speed) for d in mechanism.drivers if d.speed)
    for t in np.linspace(0.0, period, SWEEP_POSES_PER_TURN + 1)[1:]:
        q_assembled = assemble(mechanism, q_assembled, float(t)).q
        q_followed = follow(q_followed, float(t))
        assert q_followed is not None
        assert np.array_equal(q_followed, q_assembled), (name, t)


def test_the_sweep_gives_way_to_assembly_exactly_where_assembly_refuses():
    document = MECHANISM_PRESETS["crank-rocker"]().model_dump(mode="json")
    for body in document["bodies"]:
        if body["name"] in ("crank", "coupler"):
            body["points"]["A"] = [0.0, 0.25]  # a crank too long to turn: the loop cannot close part of the turn
    mechanism = Mechanism.model_validate(document)
    follow = _Follower(mechanism)
    q = assemble(mechanism).q
    period = 2.0 * math.pi / abs(mechanism.drivers[0].speed)
    refused = False
    for t in np.linspace(0.0, period, SWEEP_POSES_PER_TURN + 1)[1:]:
        followed = follow(q, float(t))
        try:
            q = assemble(mechanism, q, float(t)).q
        except LinkageError:
            assert followed is None
            refused = True
            break
        assert followed is not None and np.array_equal(followed, q)
    assert refused


def test_the_mechanism_command_loads_no_picture_library():
    result = subprocess.run([sys.executable, "-c", CHILD], capture_output=True, text=True, timeout=600, check=True)
    report = json.loads(result.stdout.strip().splitlines()[-1])
    assert report["code"] == 0
    assert "PIL" not in set(report["modules"])
