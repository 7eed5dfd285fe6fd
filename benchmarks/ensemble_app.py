"""The app's ensemble mode under load: N perturbed triple pendulums simulated and drawn in real time.

    python -m benchmarks.ensemble_app [--counts 100,1000] [--seconds 10] [--json]

For each N the server runs in its own process (so its CPU time is its own), one websocket client stands in for a
browser (app/wsclient.py), the ensemble is switched on with N copies of seed case A and played. Measured over
``--seconds`` after a warm-up: ensemble frames the client received per second (each frame one update of the
ensemble's line-segment node), the server process's CPU use in cores (from /proc), and the server's time per
ensemble frame (advance + segments + send, timed inside the server, median and 95th percentile).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

ENSEMBLE_NODE = "/ensemble/links"


def _serve(count: int) -> int:
    """Child process: a server; on the first session, ensemble on and play; on stdin "stop", print timings."""
    from app.server import LabServer

    server = LabServer(port=0, warm=False)
    print(server.url, flush=True)
    session = server.wait_for_sessions(1, timeout=120)[0]
    analysis = session.analysis
    timings: list[float] = []
    on_frame = analysis.on_frame

    def timed(t, restarted):
        start = time.perf_counter()
        on_frame(t, restarted)
        if analysis.ensemble_node is not None:
            timings.append(time.perf_counter() - start)

    analysis.on_frame = timed
    session.guard(lambda: session.set_ensemble(True, count))
    session.play()
    print("ready", flush=True)
    for line in sys.stdin:
        if line.strip() == "mark":
            timings.clear()
            print("marked", flush=True)
        elif line.strip() == "stop":
            break
    print(json.dumps({"frame_seconds": timings, "alive": int(analysis.ensemble.alive.sum()) if analysis.ensemble
                      else 0}), flush=True)
    server.stop()
    return 0


def _cpu_seconds(pid: int) -> float:
    with open(f"/proc/{pid}/stat") as handle:
        fields = handle.read().rsplit(")", 1)[1].split()
    ticks = os.sysconf("SC_CLK_TCK")
    return (int(fields[11]) + int(fields[12])) / ticks  # utime + stime


def measure(count: int, seconds: float) -> dict:
    from app.wsclient import BackgroundClient, Counts

    class EnsembleCounts(Counts):
        def __init__(self):
            super().__init__()
            self.ensemble_times: list[float] = []

        def add(self, messages, nbytes):
            super().add(messages, nbytes)
            now = time.perf_counter()
            for message in messages:
                if message.get("name") == ENSEMBLE_NODE:
                    self.ensemble_times.append(now)

    child = subprocess.Popen([sys.executable, "-m", "benchmarks.ensemble_app", "--serve", str(count)],
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        url = child.stdout.readline().strip()
        counts = EnsembleCounts()
        client = BackgroundClient(url, counts)
        if child.stdout.readline().strip() != "ready":
            raise RuntimeError("the server did not start the ensemble")
        deadline = time.perf_counter() + 180
        while len(counts.ensemble_times) < 30 and time.perf_counter() < deadline:  # built, compiled, playing
            time.sleep(0.05)
        time.sleep(1.0)
        child.stdin.write("mark\n")
        child.stdin.flush()
        child.stdout.readline()
        cpu0, t0 = _cpu_seconds(child.pid), time.perf_counter()
        received0 = len(counts.ensemble_times)
        time.sleep(seconds)
        cpu1, t1 = _cpu_seconds(child.pid), time.perf_counter()
        received1 = len(counts.ensemble_times)
        child.stdin.write("stop\n")
        child.stdin.flush()
        report = json.loads(child.stdout.readline())
        client.close()
    finally:
        child.kill()
        child.wait()
    frames = sorted(report["frame_seconds"])
    return {
        "count": count,
        "seconds": t1 - t0,
        "frames_per_second_received": (received1 - received0) / (t1 - t0),
        "server_cores": (cpu1 - cpu0) / (t1 - t0),
        "frame_ms_median": 1e3 * statistics.median(frames) if frames else None,
        "frame_ms_p95": 1e3 * frames[int(0.95 * (len(frames) - 1))] if frames else None,
        "copies_alive": report["alive"],
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.ensemble_app", description=__doc__.split("\n")[0])
    parser.add_argument("--counts", default="100,1000")
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--serve", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.serve:
        return _serve(args.serve)
    rows = [measure(int(c), args.seconds) for c in args.counts.split(",")]
    if args.json:
        print(json.dumps({"machine_load": os.getloadavg(), "rows": rows}, indent=1))
        return 0
    print(f"load average {os.getloadavg()[0]:.2f}")
    print("| copies | frames/s received | server cores | server ms per frame (median / p95) | alive |")
    print("| --- | --- | --- | --- | --- |")
    for r in rows:
        print(f"| {r['count']} | {r['frames_per_second_received']:.1f} | {r['server_cores']:.2f} | "
              f"{r['frame_ms_median']:.2f} / {r['frame_ms_p95']:.2f} | {r['copies_alive']} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
