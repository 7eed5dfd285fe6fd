"""Measurements of the app behind BENCHMARKS.md: start-up, slider-to-motion latency, CPU, load.

``python -m app.bench all`` prints one JSON object; ``start``, ``latency``, ``cpu``, ``load`` and ``cycles`` run one
part.
Browsers are stood in for by websocket clients speaking viser's protocol (:mod:`app.wsclient`), which count
the pose updates they receive. Nothing here is a test: tests/app assert, this measures.

* start: ``python -m app --port 0`` as a subprocess, from launch to the printed URL, to the start pose a client
  receives (drawn before any simulation) and to the first simulated pose (animation running); with the
  derivation cache warm (the current one) and cold (an empty temporary one).
* browser-start: the same launch, with real Chromium (Debian's, headless, software WebGL) loading the page as
  soon as the URL is printed: from launch to the loading screen painted, to the session's panel (the loading
  screen gone) and to motion shown (the status line reads ``t = ... s (playing)`` with t > 0); warm cache.
* latency: in-process server, one client, session paused; an initial-angle slider is set on the server
  (``handle.value = ...``, the browser's path) and the time to (a) the first pose of the new start queued by
  the server and (b) that pose arriving at the client is recorded; also (a) for a mass slider while playing.
* cpu: the server as a subprocess (one process) animating ``--preset`` (the triple pendulum by default; any
  general mechanism, e.g. ``jansen-leg``) for one client; CPU time of that process over wall time (1.00 = one
  core), the same for its child processes (a general mechanism's workers, app/mechanism_workers.py), and the
  frames per second the client received (60: the motion keeps up with real time).
* load: in-process server (with ``--processes K``, this process and K - 1 siblings on the same port:
  app/processes.py), N clients in a subprocess (``python -m app.wsclient``; ``--client-processes J`` splits them
  over J subprocesses) for S seconds, some leaving early;
  server CPU (every server process, and each one), resident memory over time (summed over the server's
  processes), sessions left, frames per second per client.
* design-drag: in-process, one session per preset (``crank-rocker``, ``jansen-leg``) opened as a design in the
  Design tab (app/design_view.py), a ground pivot grabbed and moved along a small circle: the server-side time
  of each move, from the drag event to the re-assembled mechanism, its full-cycle coupler curve and the scene's
  nodes sent (issue 27's 50 ms target). Not part of ``all``.
* cycles: in-process server with ``--processes K``; ``--cycles C`` times, N clients (a subprocess) join, stay
  ``--cycle-seconds`` and leave; after each cycle, once every session has closed, the resident memory of every
  server process (issue 23: the last cycle's within 10 % of the first's). Not part of ``all``.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent


def _rss_mb(pid: int | None = None) -> float:
    path = f"/proc/{pid or os.getpid()}/status"
    with open(path) as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def _cpu_seconds(pid: int) -> float:
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    ticks = os.sysconf("SC_CLK_TCK")
    return (int(fields[11]) + int(fields[12])) / ticks  # utime + stime


def child_processes(pid: int | None = None) -> list[int]:
    """Live child processes of ``pid`` (this process by default; zombies left out): a server's siblings and a
    mechanism session's worker processes (app/mechanism_workers.py). The tests of sessions' lifetime use it."""
    pid = pid or os.getpid()
    out = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid and fields[0] != "Z":
            out.append(int(entry))
    return out


def _children_cpu_seconds(pids: list[int]) -> float:
    total = 0.0
    for pid in pids:
        try:
            total += _cpu_seconds(pid)
        except OSError:  # it left: its time is no longer in /proc
            continue
    return total


def _own_cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _start_server(extra: list[str], env: dict) -> tuple[subprocess.Popen, str, float]:
    started = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-m", "app", "--port", "0", *extra],
        cwd=ROOT,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None
    line = proc.stdout.readline()
    match = re.search(r"(http://\S+)", line)
    if not match:
        proc.kill()
        raise RuntimeError(f"the server did not print its URL: {line!r} {proc.stderr.read() if proc.stderr else ''}")
    return proc, match.group(1), time.perf_counter() - started


def measure_start(cold: bool) -> dict:
    from .wsclient import BackgroundClient, moves_positions

    env = dict(os.environ)
    tmp = None
    if cold:
        tmp = tempfile.TemporaryDirectory(prefix="linkage-lab-cold-")
        env["LINKAGE_LAB_CACHE"] = tmp.name
    launched = time.perf_counter()
    proc, url, url_seconds = _start_server([], env)
    client = BackgroundClient(url)
    try:
        # the page first shows the mechanism at rest at its start (drawn from kinematics, before any
        # simulation); animation has begun when bar 1 has been moved a second time
        ok = client.wait_for(lambda c: c.bar_updates() >= 2, timeout=900)
        watched = list(client.counts.watched)
        positions = [(t, m) for t, m in watched if moves_positions(m)]
        return {
            "cache": "cold" if cold else "warm",
            "url_printed_s": round(url_seconds, 3),
            "start_pose_s": round(positions[0][0] - launched, 3) if positions else None,
            "first_pose_s": round(positions[1][0] - launched, 3) if ok and len(positions) > 1 else None,
        }
    finally:
        client.close()
        proc.terminate()
        proc.wait(10)
        if tmp is not None:
            tmp.cleanup()


PLAYING = re.compile(r"t = ([0-9.]+) s \(playing\)")


def measure_browser_start() -> dict:
    """Launch to what a person sees in a real browser (warm cache); see the module docstring."""
    from . import snapshot

    sync_playwright = snapshot.import_playwright()
    with sync_playwright() as playwright:
        browser = snapshot.launch_chromium(playwright)  # before the launch: a browser already open, as in class
        try:
            launched = time.perf_counter()
            proc, url, url_seconds = _start_server([], dict(os.environ))
            try:
                port = int(url.rsplit(":", 1)[1].strip("/"))
                page = browser.new_context(viewport=snapshot.VIEWPORT).new_page()
                page.goto(snapshot.page_url(port), wait_until="commit")  # not "load": the screen paints before
                page.wait_for_selector(f"#{snapshot.LOADING_SCREEN_ID}", state="attached")
                painted = time.perf_counter() - launched
                snapshot.wait_for_panel(page)
                panel = time.perf_counter() - launched
                motion = None
                deadline = time.perf_counter() + 120
                while time.perf_counter() < deadline:
                    match = PLAYING.search(page.inner_text("body"))
                    if match and float(match.group(1)) > 0:
                        motion = time.perf_counter() - launched
                        break
                    time.sleep(0.02)
                page.context.close()
            finally:
                proc.terminate()
                proc.wait(10)
        finally:
            browser.close()
    return {"url_printed_s": round(url_seconds, 3), "loading_screen_painted_s": round(painted, 3),
            "panel_shown_s": round(panel, 3), "motion_shown_s": round(motion, 3) if motion else None}


def measure_latency(samples: int = 40) -> dict:
    """Median and worst slider-to-pose latencies, in milliseconds."""
    from .server import LabServer
    from .session import Session
    from .wsclient import BackgroundClient

    server = LabServer(port=0)
    client = BackgroundClient(server.url)
    try:
        session = server.wait_for_sessions(1, timeout=600)[0]
        assert isinstance(session, Session) and session.chain is not None, "the benchmark drives a chain"
        session.player.wait_idle(600)
        angle = session._knob_handles["theta1"]  # the start's first angle and bar 1's mass, by their --set names
        mass = session._knob_handles["m1"]
        queued, received = [], []
        session.pause()
        time.sleep(0.3)
        for i in range(samples):
            seen = len(client.counts.watched)
            t0 = time.perf_counter()
            angle.value = 80.0 + (i % 2) * 20.0  # a new start: the first pose differs from the last one
            if not client.wait_for(lambda c: len(c.watched) > seen, timeout=10):
                continue
            arrival = next(t for t, _ in list(client.counts.watched)[seen:] if t >= t0)
            queued.append(session.player.last_restart_shown - t0)
            received.append(arrival - t0)
            time.sleep(0.05)
        session.play()
        time.sleep(0.5)
        playing = []
        for i in range(samples):
            shown_before = session.player.last_restart_shown
            t0 = time.perf_counter()
            mass.value = 1.0 + 0.5 * (i % 2)  # the motion goes on from the displayed state with the new mass
            deadline = time.perf_counter() + 10
            while session.player.last_restart_shown == shown_before and time.perf_counter() < deadline:
                time.sleep(0.0005)
            if session.player.last_restart_shown != shown_before:
                playing.append(session.player.last_restart_shown - t0 + 1.0 / 60.0)  # + the next frame
            time.sleep(0.1)

        def stats(values):
            values = [1e3 * v for v in values]
            return {
                "median_ms": round(statistics.median(values), 2) if values else None,
                "p90_ms": round(sorted(values)[int(0.9 * (len(values) - 1))], 2) if values else None,
                "max_ms": round(max(values), 2) if values else None,
                "n": len(values),
            }

        return {
            "angle_slider_to_pose_queued": stats(queued),
            "angle_slider_to_pose_received": stats(received),
            "mass_slider_to_first_new_frame_queued": stats(playing),
        }
    finally:
        client.close()
        server.stop()


def measure_cpu(seconds: float = 20.0, preset: str = "triple-a") -> dict:
    from .wsclient import BackgroundClient

    proc, url, _ = _start_server(["--preset", preset, "--processes", "1"], dict(os.environ))
    client = BackgroundClient(url)
    try:
        client.wait_for(lambda c: c.bar_updates() >= 30, timeout=600)
        time.sleep(1.0)
        frames0 = client.counts.bar_updates()
        workers = child_processes(proc.pid)
        cpu0, wall0, worker0 = _cpu_seconds(proc.pid), time.perf_counter(), _children_cpu_seconds(workers)
        time.sleep(seconds)
        cpu1, wall1, worker1 = _cpu_seconds(proc.pid), time.perf_counter(), _children_cpu_seconds(workers)
        frames1 = client.counts.bar_updates()
        return {
            "preset": preset,
            "seconds": seconds,
            "server_cpu_cores": round((cpu1 - cpu0) / (wall1 - wall0), 3),
            # a general mechanism's chunks are computed by worker processes (app/mechanism_workers.py)
            "worker_processes": len(workers),
            "worker_cpu_cores": round((worker1 - worker0) / (wall1 - wall0), 3),
            "client_fps": round((frames1 - frames0) / (wall1 - wall0), 1),
            "server_rss_mb": round(_rss_mb(proc.pid), 1),
        }
    finally:
        client.close()
        proc.terminate()
        proc.wait(10)


def _slope(points: list[tuple[float, float]]) -> float | None:
    """Least-squares slope of (seconds, MB) points, in MB per minute."""
    if len(points) < 3:
        return None
    ts = [t for t, _ in points]
    ys = [y for _, y in points]
    t_mean, y_mean = statistics.fmean(ts), statistics.fmean(ys)
    denominator = sum((t - t_mean) ** 2 for t in ts)
    if denominator == 0:
        return None
    return round(60.0 * sum((t - t_mean) * (y - y_mean) for t, y in points) / denominator, 3)


def _server_cpu_seconds(pids: list[int]) -> list[float]:
    """CPU seconds of each server process; this one's from getrusage (its own threads only)."""
    return [_own_cpu_seconds() if pid == os.getpid() else _cpu_seconds(pid) for pid in pids]


def measure_load(clients: int = 30, seconds: float = 60.0, early: int = 5, early_seconds: float = 20.0,
                 shared: bool = False, processes: int = 1, client_processes: int = 1) -> dict:
    """Server in this process (and its siblings), ``clients`` websocket clients in a subprocess; see the
    module docstring."""
    from .server import LabServer

    server = LabServer(port=0, max_sessions=min(clients + 5, 100), shared=shared, processes=processes)
    samples: list[dict[str, Any]] = []
    try:
        if server._warm_thread is not None:
            server._warm_thread.join(600)
        if server.siblings is not None and not server.siblings.wait_ready():
            raise RuntimeError(f"server processes failed to start: {server.siblings.failures}")
        pids = server.pids
        time.sleep(1.0)  # the siblings' own warm-up (loading compiled code) is under way in the background
        rss_before = sum(_rss_mb(pid) for pid in pids)
        # the clients split over ``client_processes`` load generators (one Python process decodes about 5000
        # frames/s, fewer than 100 viewers of a --shared session receive at 60 frames/s)
        shares = [clients // client_processes + (k < clients % client_processes) for k in range(client_processes)]
        early_shares = [early // client_processes + (k < early % client_processes) for k in range(client_processes)]
        procs = [
            subprocess.Popen(
                [sys.executable, "-m", "app.wsclient", server.url, "--clients", str(share), "--seconds",
                 str(seconds), "--early", str(early_share), "--early-seconds", str(early_seconds)],
                cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            )
            for share, early_share in zip(shares, early_shares) if share
        ]
        started = time.perf_counter()
        cpu0 = _server_cpu_seconds(pids)
        stop = threading.Event()

        def sample() -> None:
            while not stop.wait(1.0):
                sessions = list(server.sessions.values())
                if server.shared_session is not None:
                    sessions.append(server.shared_session)
                runs = [run for s in sessions for run in s.player.runs]
                ring_bytes = float(sum(run.ring.nbytes for run in runs))
                # the part of the rings written so far: their pages become resident as they fill (2 minutes)
                filled_bytes = sum(run.ring.nbytes * len(run.ring) / run.ring.capacity for run in runs)
                if server.shared_session is None and sessions:  # siblings' sessions hold rings of the same size
                    ring_bytes *= server.seats.count / len(sessions)
                    filled_bytes *= server.seats.count / len(sessions)
                samples.append({
                    "t": round(time.perf_counter() - started, 1),
                    "ring_mb": round(ring_bytes / 1e6, 1),
                    "ring_filled_mb": round(filled_bytes / 1e6, 2),
                    "rss_mb": round(sum(_rss_mb(pid) for pid in pids), 1),
                    "sessions": server.seats.count if server.shared_session is None else 0,
                    "cpu_s": round(sum(_server_cpu_seconds(pids)) - sum(cpu0), 2),
                    "frames_rendered": {s.id: s.frames_sent for s in sessions},
                })

        sampler = threading.Thread(target=sample, daemon=True)
        sampler.start()
        children0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        outputs = [proc.communicate(timeout=seconds + 300) for proc in procs]
        wall = time.perf_counter() - started
        cpu_each = [b - a for a, b in zip(cpu0, _server_cpu_seconds(pids))]
        cpu = sum(cpu_each)
        children1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        client_cpu = (children1.ru_utime + children1.ru_stime) - (children0.ru_utime + children0.ru_stime)
        stop.set()
        sampler.join(2)
        time.sleep(1.0)
        for proc, (_, err) in zip(procs, outputs):
            if proc.returncode != 0:
                raise RuntimeError(f"load clients failed: {err[-2000:]}")
        per_client = [client for out, _ in outputs for client in json.loads(out)["per_client"]]
        # frames received per second while receiving (first to last pose: excludes connecting)
        fps = [c["bar_updates"] / c["pose_span"] if c["pose_span"] > 0 else 0.0 for c in per_client]
        full = [c for c in per_client if c["duration"] == seconds]
        after_early = [s for s in samples if early_seconds + 3 <= s["t"] <= seconds - 3]
        # frames the server rendered per session per second, over the steady middle of the run
        steady = [s for s in samples if 10 <= s["t"] <= seconds - 2]
        render_fps = []
        if len(steady) >= 2:
            a, b = steady[0], steady[-1]
            for sid in set(a["frames_rendered"]) & set(b["frames_rendered"]):
                render_fps.append((b["frames_rendered"][sid] - a["frames_rendered"][sid]) / (b["t"] - a["t"]))
        warm = [s for s in samples if 10 <= s["t"] <= seconds]
        steady_rss = [s for s in samples if 10 <= s["t"] <= min(seconds, early_seconds if early else seconds) - 1]
        return {
            "clients": clients,
            "shared": shared,
            "seconds": seconds,
            "early_leavers": early,
            "processes": len(pids),
            "client_processes": len(procs),
            "server_cpu_cores": round(cpu / wall, 3),
            "server_cpu_cores_per_process": [round(c / wall, 3) for c in cpu_each],
            "client_process_cpu_cores": round(client_cpu / wall, 3),
            "fps_per_client": {
                "min": round(min(fps), 1),
                "median": round(statistics.median(fps), 1),
                "max": round(max(fps), 1),
            },
            "server_frames_per_session_per_s": {
                "min": round(min(render_fps), 1) if render_fps else None,
                "median": round(statistics.median(render_fps), 1) if render_fps else None,
            },
            "pose_span_min_s": round(min(c["pose_span"] for c in full), 2) if full else None,
            "rss_mb": {
                "before": round(rss_before, 1),
                "at_10s": warm[0]["rss_mb"] if warm else None,
                "peak": max(s["rss_mb"] for s in samples) if samples else None,
                "end": samples[-1]["rss_mb"] if samples else None,
                "ring_buffers_peak": max(s["ring_mb"] for s in samples) if samples else None,
                # growth per minute while every client stays, and the same less the samples stored meanwhile
                # (bounded by the rings' capacity): what would be a leak
                "slope_mb_per_min": _slope([(s["t"], s["rss_mb"]) for s in steady_rss]),
                "slope_beyond_stored_samples_mb_per_min": _slope(
                    [(s["t"], s["rss_mb"] - s["ring_filled_mb"]) for s in steady_rss]),
            },
            "sessions_after_early_leave": min(s["sessions"] for s in after_early) if after_early else None,
            "sessions_peak": max(s["sessions"] for s in samples) if samples else None,
            "sessions_at_end": server.seats.count,
            "shared_session": server.shared_session is not None,
            "per_client": per_client,
            "samples": samples,
        }
    finally:
        server.stop()


SETTLE_SECONDS = 3.0  # after the last session closed: a sibling's trimmer collects and trims 0.5 s after it


def measure_cycles(clients: int = 50, cycles: int = 6, processes: int = 3, seconds: float = 10.0) -> dict:
    """Server memory over cycles of ``clients`` browsers joining and leaving together (issue 23's figure).

    In-process server (and its siblings) as in :func:`measure_load`; each cycle, ``clients`` websocket clients in
    a subprocess (``python -m app.wsclient``) stay ``seconds`` and leave; once every session of every process has
    closed (the shared seat count is 0) and SETTLE_SECONDS have passed, the resident memory of every server
    process is read. One line per cycle goes to stderr as it is measured."""
    from .server import LabServer

    server = LabServer(port=0, max_sessions=min(clients + 5, 100), processes=processes)
    try:
        if server._warm_thread is not None:
            server._warm_thread.join(600)
        if server.siblings is not None and not server.siblings.wait_ready():
            raise RuntimeError(f"server processes failed to start: {server.siblings.failures}")
        pids = server.pids
        time.sleep(SETTLE_SECONDS)  # the siblings' own warm-up (loading compiled code) is under way meanwhile
        fresh = [round(_rss_mb(pid), 1) for pid in pids]
        print(f"fresh: {sum(fresh):.1f} MB {fresh}", file=sys.stderr, flush=True)
        after: list[list[float]] = []
        received: list[int] = []
        for cycle in range(1, cycles + 1):
            done = subprocess.run(
                [sys.executable, "-m", "app.wsclient", server.url, "--clients", str(clients), "--seconds",
                 str(seconds)],
                cwd=ROOT, capture_output=True, text=True, timeout=seconds + 600, check=False,
            )
            if done.returncode != 0:
                raise RuntimeError(f"cycle {cycle}: the clients failed: {done.stderr[-2000:]}")
            per_client = json.loads(done.stdout)["per_client"]
            received.append(sum(1 for c in per_client if c["bar_updates"] > 0))
            deadline = time.monotonic() + 120
            while server.seats.count and time.monotonic() < deadline:
                time.sleep(0.05)
            trimmer = getattr(server, "trimmer", None)  # absent from servers older than app/memory.py
            if trimmer is not None:
                trimmer.wait_settled(60)
            time.sleep(SETTLE_SECONDS)
            after.append([round(_rss_mb(pid), 1) for pid in pids])
            print(f"cycle {cycle}: {sum(after[-1]):.1f} MB {after[-1]}; {received[-1]} of {clients} clients "
                  f"received frames; sessions left {server.seats.count}", file=sys.stderr, flush=True)
        totals = [round(sum(each), 1) for each in after]
        return {
            "clients": clients,
            "cycles": cycles,
            "processes": len(pids),
            "seconds_per_cycle": seconds,
            "clients_with_frames": received,
            "rss_mb": {
                "fresh": round(sum(fresh), 1),
                "after_cycle": totals,
                "per_process_fresh": fresh,
                "per_process_after_cycle": after,
            },
            # the target of docs/reliability.md: the last cycle within 10 % of the first
            "last_over_first": round(totals[-1] / totals[0], 3) if totals else None,
            "sessions_at_end": server.seats.count,
        }
    finally:
        server.stop()


def measure_design_drag(presets: tuple[str, ...] = ("crank-rocker", "jansen-leg"), moves: int = 41) -> dict:
    """Server-side time of a design's point dragged in the Design tab: each ``handle("update", ...)`` call does
    what a browser's drag message does (re-assemble on the branch, coupler curve, nodes sent)."""
    import math

    import numpy as np
    import viser

    from .design_view import extent_of, handles_of
    from .scene import to_world
    from .session import MECHANISM_PRESETS, Session

    out: dict = {}
    for preset in presets:
        server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
        session = Session(server, MECHANISM_PRESETS[preset](), label=preset, shared=True, autoplay=False)
        try:
            session.player.wait_idle(120)
            view = session.design_view
            view.set_designing(True)
            design = view.start_from_preset()
            if design is None:
                raise RuntimeError(f"{preset}: could not be opened as a design")
            if design.trace is None:  # a traced point: the curve is part of what each move draws
                view.set_trace(f"{design.bodies[-1].name}.{design.bodies[-1].points[-1][0]}")
            handles = [reference for reference, _ in handles_of(view.design)]
            # the ground pivot the model's bench drags (physics/studies/design_bench.py): the first one no motor
            # turns about
            motor_pins = {driver.joint for driver in view.design.drivers}
            driven = {ref for joint in view.design.joints if joint.name in motor_pins for ref in (joint.a, joint.b)}
            grabbed = next(k for k, reference in enumerate(handles)
                           if reference.startswith("ground.") and reference not in driven)
            centre = np.array(view.design.point(handles[grabbed]), dtype=float)
            radius = 0.01 * extent_of(view.design)
            view.grid = None  # every move a new position (a grid would repeat some)
            view.handle("start", grabbed, to_world(centre))
            times, drawn_before = [], view.drags_applied
            for k in range(moves):
                angle = 2.0 * math.pi * k / moves
                target = centre + radius * np.array([math.cos(angle) - 1.0, math.sin(angle)])
                began = time.perf_counter()
                view.handle("update", grabbed, to_world(target))
                times.append(time.perf_counter() - began)
            view.handle("end", grabbed, to_world(centre))
            curve = view.curve
            out[preset] = {
                "moves": moves, "redrawn": view.drags_applied - drawn_before,
                "grabbed": handles[grabbed], "curve_points": 0 if curve is None else int(len(curve)),
                "median_ms": round(1e3 * statistics.median(times), 2),
                "p90_ms": round(1e3 * sorted(times)[int(0.9 * (len(times) - 1))], 2),
                "max_ms": round(1e3 * max(times), 2),
                "load_average": round(os.getloadavg()[0], 2),
            }
        finally:
            session.close(clean=True)
            server.stop()
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m app.bench", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("part", choices=["all", "start", "browser-start", "latency", "cpu", "load", "cycles",
                                                  "design-drag"], nargs="?", default="all")
    parser.add_argument("--clients", type=int, default=30)
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--shared", action="store_true")
    parser.add_argument("--processes", type=int, default=1, help="server processes for the load part")
    parser.add_argument("--early", type=int, default=5, help="clients of the load part that leave after 20 s")
    parser.add_argument("--client-processes", type=int, default=1,
                        help="load generators the clients of the load part are split over")
    parser.add_argument("--no-cold", action="store_true", help="skip the cold-cache start (it derives everything)")
    parser.add_argument("--cycles", type=int, default=6, help="join-and-leave cycles of the cycles part")
    parser.add_argument("--cycle-seconds", type=float, default=10.0,
                        help="seconds the clients of the cycles part stay in each cycle")
    parser.add_argument("--preset", default="triple-a",
                        help="mechanism of the cpu part (a chain preset or a general mechanism, e.g. jansen-leg)")
    args = parser.parse_args(argv)
    if args.part == "cycles":
        for name, value, low, high in (("--clients", args.clients, 1, 100), ("--cycles", args.cycles, 1, 100),
                                       ("--cycle-seconds", args.cycle_seconds, 1.0, 600.0),
                                       ("--processes", args.processes, 1, 16)):
            if not low <= value <= high:  # NaN fails both comparisons
                print(f"python -m app.bench cycles: {name} {value}: allowed range {low} <= {name[2:]} <= {high}",
                      file=sys.stderr)
                return 2
    out: dict = {}
    if args.part in ("all", "start"):
        runs = [measure_start(cold=False) for _ in range(3)]
        out["start_warm"] = {
            "runs": runs,
            "median_first_pose_s": statistics.median(r["first_pose_s"] for r in runs if r["first_pose_s"]),
        }
        if not args.no_cold:
            out["start_cold"] = measure_start(cold=True)
    if args.part == "browser-start":  # not in "all": it needs Chromium and playwright (the snapshot extra)
        runs = [measure_browser_start() for _ in range(3)]
        out["browser_start_warm"] = {
            "runs": runs,
            "median_motion_shown_s": statistics.median(r["motion_shown_s"] for r in runs if r["motion_shown_s"]),
        }
    if args.part in ("all", "latency"):
        out["latency"] = measure_latency()
    if args.part in ("all", "cpu"):
        out["cpu"] = measure_cpu(preset=args.preset)
    if args.part in ("all", "load"):
        load = measure_load(args.clients, args.seconds, early=args.early, shared=args.shared,
                            processes=args.processes, client_processes=args.client_processes)
        load.pop("per_client")
        load.pop("samples")
        out["load"] = load
    if args.part == "design-drag":  # not in "all": the Design tab's drag, server side
        out["design_drag"] = measure_design_drag()
    if args.part == "cycles":  # not in "all": it measures memory over minutes of joining and leaving
        out["cycles"] = measure_cycles(args.clients, args.cycles, args.processes, seconds=args.cycle_seconds)
    print(json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
