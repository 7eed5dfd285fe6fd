"""Rapid changes coalesce, and a session leaves nothing behind.

A burst of edits is applied as its last value: superseded restarts are dropped, a build in a worker process
for a mechanism no longer wanted is killed, and the session animates again within a second of the last edit.
After twenty browsers have come and gone, the server holds as many threads and child processes as before and
its memory is back within 10 % (docs/reliability.md, "Load and lifetime").
"""

from __future__ import annotations

import gc
import json
import os
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

from app.bench import child_processes
from app.player import Player, RunSpec
from app.server import LabServer
from conftest import BrowserStandIn, wait_until
from physics import Settings, get_preset, simulate
from physics.kernels.disk_cache import kernels_folder
from physics.mechanism import analyse

ROOT = Path(__file__).resolve().parents[2]
# After the last edit of a burst, with the code built, the motion goes on: a quiet machine takes a fraction of a
# second (printed by the tests), a loaded one longer. What is asserted is that it resumes on the last request
# with nothing queued behind it, not how fast (tests assert counts and content, never a wall-clock budget).
RESUME_TIMEOUT = 60.0


def _rss_mb() -> float:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def _resumed_within(session, seconds: float) -> float | None:
    """Seconds until the session shows its latest request and its displayed time moves; None if not."""
    started = time.monotonic()
    if not session.player.wait_idle(seconds):
        return None
    t0 = session.player.display_time
    while time.monotonic() - started < seconds:
        if session.player.display_time > t0 and session.player.playing:
            return time.monotonic() - started
        time.sleep(0.005)
    return None


def test_a_burst_of_edits_is_applied_as_its_last_value_and_resumes(connect):
    _, session = connect()
    methods = ["newton_euler", "lagrange", "dae"]
    integrators = ["RK45", "DOP853"]
    for method in methods:  # built once, so the burst measures coalescing, not compiling
        session.guard(lambda m=method: session.set("method", m))
        assert session.player.wait_idle(300)
    edits = 0
    for i in range(100):
        session.guard(lambda i=i: session.set("method", methods[i % 3]))
        session.guard(lambda i=i: session.set("integrator", integrators[i % 2]))
        edits += 2
        time.sleep(0.02)
    for i in range(40):
        session.guard(lambda i=i: session.set_compare(i % 2 == 0))
        edits += 1
        time.sleep(0.02)
    # the end of the burst back to back, faster than a restart installs: the player takes only the newest
    restarts_before = session.player.generation
    for i in range(150):
        session.guard(lambda i=i: session.set("method", methods[i % 3]))
        session.guard(lambda i=i: session.set("integrator", integrators[i % 2]))
    session.guard(lambda: session.set_compare(False))
    session.guard(lambda: session.set("method", "dae"))
    session.guard(lambda: session.set("integrator", "RK45"))
    back_to_back = 303
    resumed = _resumed_within(session, RESUME_TIMEOUT)
    assert resumed is not None, "the session did not resume after the last edit"
    assert session.player.error is None and session.notice is None, (session.player.error, session.notice)
    assert (session.params.method, session.params.integrator, session.compare) == ("dae", "RK45", False)
    assert [run.spec.settings.method for run in session.player.runs] == ["dae"]
    assert session.player.runs[0].spec.settings.integrator == "RK45"
    installed = session.player.generation - restarts_before
    print(f"\nburst: {edits} edits 20 ms apart, then {back_to_back} back to back of which {installed} were "
          f"installed; resumed {1e3 * resumed:.0f} ms after the last")


def test_a_burst_of_mechanism_switches_ends_on_the_last_and_resumes(connect):
    _, session = connect()
    mechanisms = ["single", "double", "four-bar", "triple-a"]
    for name in mechanisms:  # built once (in a worker on a cold cache), so the burst measures coalescing
        session.guard(lambda n=name: session.set_mechanism(n))
        assert session.player.wait_idle(300), name
    for i in range(32):  # each switch rebuilds the scene and the controls
        session.guard(lambda i=i: session.set_mechanism(mechanisms[i % 4]))
        time.sleep(0.05)
    session.guard(lambda: session.set_mechanism("four-bar"))
    resumed = _resumed_within(session, RESUME_TIMEOUT)
    assert resumed is not None, "the session did not resume after the last switch"
    assert session.player.error is None and session.notice is None, (session.player.error, session.notice)
    run_mechanism = session.player.runs[0].spec.chain  # the run's model: the hosted four-bar, its loop closed
    assert session.params.preset == "four-bar" and session.params.pinned
    assert run_mechanism.name == "four-bar" and analyse(run_mechanism).loops
    assert sorted(session.scene.poses()) == [f"/linkage/bar_{k}" for k in (1, 2, 3)]  # three bars drawn
    print(f"\nmechanisms: 33 switches 50 ms apart; resumed {1e3 * resumed:.0f} ms after the last")


def test_superseded_preparations_are_cancelled_not_queued():
    """A prepare (a build, on a cold cache) that a newer request supersedes stops at once; only the newest
    request's prepare runs to its end, and the player then shows it.

    The builds here last until the test releases them, after the last request: what is asserted are the counts
    and the order, never how long anything took (a loaded machine stretches every sleep)."""
    preset = get_preset("triple-a")
    release = threading.Event()
    started, finished, cancelled = [], [], []
    player = None

    def slow_prepare(spec, theta0, omega0):  # as app/warm.py's build does: polls whether it is still wanted
        started.append(spec.label)
        while True:
            if player.superseded():
                cancelled.append(spec.label)
                raise RuntimeError("cancelled")
            if release.is_set():
                break
            time.sleep(0.005)
        finished.append(spec.label)

    player = Player(
        simulate=simulate,
        make_settings=lambda s, horizon, samples: s.model_copy(update={"t_end": horizon, "samples": samples}),
        on_frame=lambda frame: None,
        on_failure=lambda message: None,
        prepare=slow_prepare,
    )
    try:
        for i in range(30):
            spec = RunSpec(f"edit-{i}", preset.chain, Settings(method="lagrange"))
            player.restart([spec], 0.0, [(preset.theta0, preset.omega0)], keep_history=False, play=True)
            time.sleep(0.03)
        release.set()
        assert player.wait_idle(60)
        assert [run.spec.label for run in player.runs] == ["edit-29"]
        assert finished == ["edit-29"], finished  # no superseded prepare ran to its end
        assert 1 <= len(started) <= 30 and started[-1] == "edit-29"
        assert cancelled == started[:-1]  # every superseded prepare that had started stopped itself
    finally:
        player.stop()


CANCEL_SCRIPT = """
import json, os, sys, threading, time
from app import warm
from physics import code_missing
stop = threading.Event()
outcome = {}
def build():
    try:
        outcome["built"] = warm.build_outside("dae", 4, False, "RK45", stop.is_set)
    except warm.Cancelled:
        outcome["cancelled_at"] = time.monotonic()
thread = threading.Thread(target=build)
thread.start()
def children():
    out = []
    for e in os.listdir("/proc"):
        if e.isdigit():
            try:
                fields = open(f"/proc/{e}/stat").read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == os.getpid() and fields[0] != "Z":
                out.append(int(e))
    return out
deadline = time.monotonic() + 30
while not children() and time.monotonic() < deadline:
    time.sleep(0.01)
worker_seen = bool(children())
time.sleep(0.5)  # the worker is importing sympy and deriving
stop.set()
asked = time.monotonic()
thread.join(10)
result = {"worker_seen": worker_seen, "cancelled": "cancelled_at" in outcome,
          "seconds": outcome.get("cancelled_at", 1e9) - asked, "children_after": len(children()),
          "generated_after_cancel": not code_missing("dae", 4, False)}
result["built_again"] = warm.build_outside("dae", 4, False, "RK45")
result["generated"] = not code_missing("dae", 4, False)
print(json.dumps(result))
"""


def test_a_build_no_longer_wanted_is_killed_and_the_next_one_succeeds(tmp_path):
    preset = get_preset("chain", links=2)  # the integrator kernels compile once: bring them along
    simulate(preset.chain, preset.theta0, preset.omega0, Settings(method="dae", integrator="RK45", t_end=0.01))
    cache = tmp_path / "cache"
    shutil.copytree(kernels_folder(), cache / "numba" / kernels_folder().name)
    os.chmod(cache, 0o700)
    done = subprocess.run([sys.executable, "-c", CANCEL_SCRIPT], cwd=ROOT, capture_output=True, text=True,
                          timeout=300, env=dict(os.environ, LINKAGE_LAB_CACHE=str(cache)), check=False)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["worker_seen"] and result["cancelled"], result
    assert result["seconds"] < 0.5, result  # killed, not waited for
    assert result["children_after"] == 0, result
    assert result["generated_after_cancel"] is False, result
    assert result["built_again"] is True and result["generated"] is True, result


def _settled() -> tuple[int, int, float]:
    gc.collect()
    time.sleep(0.5)
    return threading.active_count(), len(child_processes()), _rss_mb()


def leaves_nothing_behind(cycle, label: str, warm_up: int = 2, cycles: int = 20) -> None:
    """After ``warm_up`` cycles (code loaded, caches and pools filled: not a leak), ``cycles`` more connect and
    disconnect cycles leave as many threads and child processes as before and resident memory within 10 %."""
    for _ in range(warm_up):
        cycle()
    threads0, children0, rss0 = _settled()
    for _ in range(cycles):
        cycle()
    assert wait_until(lambda: threading.active_count() <= threads0, timeout=10), (
        threading.active_count(), threads0, [t.name for t in threading.enumerate()])
    threads1, children1, rss1 = _settled()
    print(f"\n{label}: threads {threads0} -> {threads1}, child processes {children0} -> {children1}, "
          f"RSS {rss0:.1f} -> {rss1:.1f} MB after {cycles} connect/disconnect cycles")
    assert threads1 <= threads0
    assert children1 <= children0
    assert rss1 <= 1.10 * rss0, (rss0, rss1)


def test_twenty_browsers_come_and_go_and_leave_no_thread_process_or_memory_behind():
    server = LabServer(port=0, warm=False)
    try:

        def cycle() -> None:
            client = BrowserStandIn(server.url)
            assert wait_until(lambda: len(server.sessions) == 1, timeout=60)
            assert client.wait_for(lambda c: c.bar_updates() >= 20, timeout=60)
            session = next(iter(server.sessions.values()))
            session.guard(lambda: session.set("method", "dae"))
            session.guard(lambda: session.set_compare(True))  # every run, thread and buffer a session can make
            poses = sum(client.counts.pose_updates.values())
            assert client.wait_for(lambda c: sum(c.pose_updates.values()) >= poses + 100, timeout=60)
            assert len(session.player.runs) == 4  # the three methods and the converged reference run
            client.close()
            assert wait_until(lambda: not server.sessions and server.seats.count == 0, timeout=30)

        leaves_nothing_behind(cycle, "lifetime")  # the first cycles load code, fill caches and pools
    finally:
        server.stop()


def test_twenty_mechanism_browsers_come_and_go_and_leave_no_thread_process_or_memory_behind():
    """The same for general mechanisms (app/session.py): their worker processes are a pool of at most
    one per core, kept for the next session, so the count of child processes does not grow either."""
    server = LabServer(port=0, warm=False, preset="slider-crank")
    try:

        def cycle() -> None:
            client = BrowserStandIn(server.url)
            assert wait_until(lambda: len(server.sessions) == 1, timeout=60)
            assert client.wait_for(lambda c: c.bar_updates() >= 20, timeout=60)
            session = next(iter(server.sessions.values()))
            session.guard(lambda: session.set_method("lagrange"))
            session.guard(lambda: session.set_reactions(True))
            poses = sum(client.counts.pose_updates.values())
            assert client.wait_for(lambda c: sum(c.pose_updates.values()) >= poses + 60, timeout=60)
            client.close()
            assert wait_until(lambda: not server.sessions and server.seats.count == 0, timeout=30)

        leaves_nothing_behind(cycle, "mechanism lifetime")  # the first cycles start the workers
    finally:
        server.stop()
