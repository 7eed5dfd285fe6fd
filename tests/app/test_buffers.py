"""The trajectory ring (app/buffers.py): what a reader gets back is what was appended, in time order, across the
wrap-around of the storage."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from app.buffers import ThinnedSeries, TrajectoryRing


def _chunk(t0: int, m: int) -> dict[str, np.ndarray]:
    t = np.arange(t0, t0 + m, dtype=float)
    return {"t": t, "trace_xy": np.stack([t, -t], axis=1)}


@settings(max_examples=60, deadline=None, derandomize=True)
@given(
    capacity=st.integers(2, 40),
    chunks=st.lists(st.integers(1, 50), min_size=1, max_size=8),
    i0=st.integers(-5, 60),
    span=st.integers(0, 60),
)
def test_series_equals_the_window_and_the_samples_appended(capacity, chunks, i0, span):
    ring = TrajectoryRing(n=2, pinned=False, capacity=capacity, dt=1.0)
    total = 0
    for m in chunks:
        ring.append(_chunk(total, m))
        total += m
    i1 = i0 + span
    series = ring.series("trace_xy", i0, i1)
    assert np.array_equal(series, ring.window(i0, i1, names=["trace_xy"])["trace_xy"])
    first = total - len(ring)  # the oldest sample kept
    expected = [[k, -k] for k in range(first + max(i0, 0), first + min(i1, len(ring) - 1) + 1)]
    assert np.array_equal(series, np.array(expected, dtype=float).reshape(-1, 2))


@settings(max_examples=40, deadline=None, derandomize=True)
@given(capacity=st.sampled_from([4, 6, 16, 64]), appended=st.integers(1, 3000))
def test_a_thinned_series_is_bounded_even_and_ends_at_the_newest_point(capacity, appended):
    series = ThinnedSeries(capacity)
    for k in range(appended):
        series.append(float(k), float(10 * k))
    t, y = series.arrays()
    assert len(series) <= capacity and len(t) <= capacity + 1
    assert t[0] == 0.0 and t[-1] == appended - 1  # the whole life, up to the present
    assert np.array_equal(y, 10 * t)
    kept = t[: len(series)]
    steps = np.diff(kept)
    assert np.all(steps == steps[0]) if len(steps) else True  # evenly thinned
    assert len(steps) == 0 or steps[0] <= 2 * max(1.0, appended / capacity)  # no thinner than needed
    series.clear()
    series.append(5.0, 1.0)
    assert [a.tolist() for a in series.arrays()] == [[5.0], [1.0]]
