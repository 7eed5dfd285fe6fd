"""``Trajectory.of_chain`` (a chain's run made without the dataclass's ``__init__``: every run takes it) gives the
object ``Trajectory(...)`` gives for the same fields: the same attributes, of the same types, shapes and bits,
the defaults included, for an open chain (empty tip reaction and constraint) and a pinned one."""

from __future__ import annotations

import numpy as np
import pytest

from physics.simulate.trajectory import Trajectory


def _fields(count: int, n: int, pinned: bool, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    width = 2 if pinned else 0
    return {
        "method": "lagrange", "integrator": "RK45", "t": rng.random(count), "trace_xy": rng.random((count, 2)),
        "kinetic": rng.random(count), "potential": rng.random(count), "energy": rng.random(count),
        "condition": rng.random(count), "theta": rng.random((count, n)), "omega": rng.random((count, n)),
        "joints": rng.random((count, n + 1, 2)), "tip_xy": rng.random((count, 2)),
        "reactions": rng.random((count, n, 2)), "tip_reaction": rng.random((count, width)),
        "constraint_xy": rng.random((count, width)), "constraint_velocity": rng.random((count, width)),
        "joint_reactions": rng.random((count, n, 2)), "trace_is_explicit": bool(seed % 2),
    }


def _state(run: Trajectory) -> dict:
    out = {}
    for name, value in run.__dict__.items():
        if isinstance(value, np.ndarray):
            out[name] = ("array", value.dtype.str, value.shape, value.tobytes())
        else:
            out[name] = (type(value).__name__, repr(value))
    return out


@pytest.mark.parametrize("pinned", [False, True])
@pytest.mark.parametrize("count, n", [(1, 1), (7, 3), (201, 10)])
def test_of_chain_is_the_dataclass_init(count, n, pinned):
    fields = _fields(count, n, pinned, seed=count + n)
    made = Trajectory.of_chain(**fields)
    built = Trajectory(**fields)
    assert list(made.__dict__) == list(built.__dict__)  # the same entries, set in the same order
    assert _state(made) == _state(built)
    assert made.condition.tobytes() == built.condition.tobytes()
    assert made.reaction_rows.shape == built.reaction_rows.shape == (count, 0)
    assert made.q.shape == built.q.shape == (count, 0)
