"""Load: 30 websocket clients, each with its own animating session, on one server process for 60 s; a
hundred over two processes (app/processes.py); ten playing sessions whose memory must stay flat.

Run by default (about 3 minutes in all); deselect with ``-m "not load"``. ``LINKAGE_LAB_LOAD_SECONDS``
shortens the first.
The clients run in a subprocess (``python -m app.wsclient``), so the CPU measured is the server's alone.
Figures are printed (``-s``) for BENCHMARKS.md; ``python -m app.bench load`` prints the same.

These tests assert what does not depend on how fast the machine is: every client is served (a count of frames
that any working server delivers many times over, on a loaded machine too), sessions are made and freed, memory
stays bounded, viewers of one session are served alike. Frame rates are throughput, measured by the benchmark
(``python -m app.bench load``, BENCHMARKS.md), not asserted here: a shared two-core machine at a load average
of 15 rendered too few frames for the floors these tests once had.
"""

from __future__ import annotations

import json
import os

import pytest

from app.bench import measure_load

CLIENTS = 30
SECONDS = float(os.environ.get("LINKAGE_LAB_LOAD_SECONDS", "60"))
EARLY = 5  # clients that leave a third of the way through: their sessions must be freed
# frames (pose updates) every client must receive during its stay: served at all, and on through its stay
MIN_FRAMES = 30


@pytest.mark.load
def test_thirty_clients_each_keep_receiving_poses_and_memory_stays_bounded():
    early_seconds = SECONDS / 3
    result = measure_load(clients=CLIENTS, seconds=SECONDS, early=EARLY, early_seconds=early_seconds)
    summary = {k: v for k, v in result.items() if k not in ("per_client", "samples")}
    print("\nload:", json.dumps(summary))
    per_client = result["per_client"]
    assert len(per_client) == CLIENTS
    for i, client in enumerate(per_client):
        # served, and kept receiving pose updates over most of its stay
        assert client["bar_updates"] >= MIN_FRAMES, (i, client)
        assert client["pose_span"] >= client["duration"] / 2, (i, client)
    assert result["sessions_peak"] == CLIENTS
    assert result["sessions_after_early_leave"] == CLIENTS - EARLY  # a client that leaves frees its session
    assert result["sessions_at_end"] == 0
    rss = result["rss_mb"]
    # bounded: after the sessions exist, memory grows at most by the sessions' preallocated ring buffers
    # (their pages are touched as they fill, over the first two minutes), plus a margin; not with run time
    assert rss["end"] - rss["at_10s"] < rss["ring_buffers_peak"] + 25.0, rss


CLASSROOM = 100
CLASSROOM_SECONDS = 30.0


@pytest.mark.load
def test_a_hundred_clients_over_two_processes_are_each_served_and_freed():
    result = measure_load(clients=CLASSROOM, seconds=CLASSROOM_SECONDS, early=0, early_seconds=CLASSROOM_SECONDS,
                          processes=2)
    summary = {k: v for k, v in result.items() if k not in ("per_client", "samples")}
    print("\nclassroom:", json.dumps(summary))
    assert result["processes"] == 2 and min(result["server_cpu_cores_per_process"]) > 0.05  # both served
    per_client = result["per_client"]
    assert len(per_client) == CLASSROOM
    for i, client in enumerate(per_client):
        assert client["bar_updates"] >= MIN_FRAMES, (i, client)
        assert client["pose_span"] >= client["duration"] / 2, (i, client)
    assert result["sessions_peak"] == CLASSROOM  # every client got a session, in one process or the other
    assert result["sessions_at_end"] == 0


PLAYING = 10
PLAYING_SECONDS = 50.0
# growth of resident memory beyond the samples stored meanwhile (which the rings bound), over the run after
# the first 10 s; a session that kept anything per frame would grow by megabytes per minute
MAX_SLOPE_MB_PER_MIN = 3.0


@pytest.mark.load
def test_ten_playing_sessions_keep_memory_flat():
    result = measure_load(clients=PLAYING, seconds=PLAYING_SECONDS, early=0, early_seconds=PLAYING_SECONDS)
    rss = result["rss_mb"]
    print("\nplaying:", json.dumps({"fps_per_client": result["fps_per_client"], "rss_mb": rss}))
    for i, client in enumerate(result["per_client"]):
        assert client["bar_updates"] >= MIN_FRAMES, (i, client)
    assert rss["slope_beyond_stored_samples_mb_per_min"] is not None
    assert rss["slope_beyond_stored_samples_mb_per_min"] < MAX_SLOPE_MB_PER_MIN, rss


VIEWERS = 100
VIEWER_SECONDS = 20.0
# viewers of one session are served alike: the one served least receives at least this share of the frames the
# median viewer received (before every frame was flushed, viser's sender dozed after each window and some
# viewers received about two frames in three). Against the median, not the viewer served most: under two busy
# loops and five other jobs (load average 16) the least received 39, the median about 46 and one viewer 93; a
# viewer served better than the rest is the load generator's own scheduling (each client reads as fast as its
# process gets a core), not the server starving anyone, and the test must hold on a loaded machine (issue 23).
MIN_FAIR_SHARE = 0.5


@pytest.mark.load
def test_every_viewer_of_a_shared_session_is_served_alike():
    result = measure_load(clients=VIEWERS, seconds=VIEWER_SECONDS, early=0, early_seconds=VIEWER_SECONDS,
                          shared=True)
    rendered = result["server_frames_per_session_per_s"]["median"]
    print("\nviewers:", json.dumps({"fps_per_client": result["fps_per_client"], "rendered": rendered}))
    assert rendered is not None and rendered > 0
    received = [client["bar_updates"] for client in result["per_client"]]
    assert len(received) == VIEWERS
    assert min(received) >= MIN_FRAMES, received
    assert min(received) >= MIN_FAIR_SHARE * sorted(received)[len(received) // 2], sorted(received)
