"""Load: 30 websocket clients, each with its own animating session, on one server for 60 s.

Run by default (about 70 s); deselect with ``-m "not load"``. ``LINKAGE_LAB_LOAD_SECONDS`` shortens it.
The clients run in a subprocess (``python -m app.wsclient``), so the CPU measured is the server's alone.
Figures are printed (``-s``) for BENCHMARKS.md; ``python -m app.bench load`` prints the same.
"""

from __future__ import annotations

import json
import os

import pytest

CLIENTS = 30
SECONDS = float(os.environ.get("LINKAGE_LAB_LOAD_SECONDS", "60"))
EARLY = 5  # clients that leave a third of the way through: their sessions must be freed
MIN_FPS = 10.0  # every client must keep receiving pose updates, at least this many frames per second


@pytest.mark.load
def test_thirty_clients_each_keep_receiving_poses_and_memory_stays_bounded():
    from app.bench import measure_load

    early_seconds = SECONDS / 3
    result = measure_load(clients=CLIENTS, seconds=SECONDS, early=EARLY, early_seconds=early_seconds)
    summary = {k: v for k, v in result.items() if k not in ("per_client", "samples")}
    print("\nload:", json.dumps(summary))
    per_client = result["per_client"]
    assert len(per_client) == CLIENTS
    for i, client in enumerate(per_client):
        # kept receiving pose updates until it left: from its first pose to nearly the end of its stay
        assert client["pose_span"] >= client["duration"] - 5.0, (i, client)
        assert client["bar_updates"] / client["pose_span"] >= MIN_FPS, (i, client)
    assert result["sessions_peak"] == CLIENTS
    assert result["sessions_after_early_leave"] == CLIENTS - EARLY  # a client that leaves frees its session
    assert result["sessions_at_end"] == 0
    rss = result["rss_mb"]
    # bounded: after the sessions exist, memory grows at most by the sessions' preallocated ring buffers
    # (their pages are touched as they fill, over the first two minutes), plus a margin; not with run time
    assert rss["end"] - rss["at_10s"] < rss["ring_buffers_peak"] + 25.0, rss
