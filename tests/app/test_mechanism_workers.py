"""A general mechanism's chunks are computed in worker processes, never in the server's interpreter.

Position analysis, projection and reactions are numpy and Python, and the tree formulations are derived by
sympy on first use: in the server they would hold the interpreter lock and take frames from every other
session. The test runs a server in a fresh interpreter, plays the slider-crank with Lagrange's and
Newton-Euler's tree formulations, and checks that the server never imported sympy or the formulations while
the workers did the work; then that a worker that dies is reported and replaced.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from app.mechanism_workers import WorkerPool
from physics import LinkageError
from physics.mechanism import MECHANISM_PRESETS
from physics.mechanism.simulate import simulate_mechanism

ROOT = Path(__file__).resolve().parents[2]

# the scripts' wait for the session's display to move on ``seconds`` of simulated time (two minutes at most)
MOVED = """def moved(seconds):
    start = session.player.display_time
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and session.player.display_time < start + seconds:
        time.sleep(0.02)
    return session.player.display_time >= start + seconds"""

SCRIPT = """
import json, sys, time
from app.server import LabServer
from app.wsclient import BackgroundClient
server = LabServer(port=0, warm=False, preset="slider-crank")
client = BackgroundClient(server.url)
(session,) = server.wait_for_sessions(1)
MOVED
ok = moved(0.3)
for method in ("lagrange", "newton_euler"):
    session.guard(lambda: session.set_method(method))
    session.player.wait_idle(60)
    ok = ok and moved(0.3) and session.player.runs[0].spec.settings.method == method
workers = [w.process.pid for w in __import__("app.mechanism_workers", fromlist=["POOL"]).POOL.workers]
print(json.dumps({"moved": ok, "notice": session.notices.text, "workers": len(workers),
                  "sympy": "sympy" in sys.modules,
                  "formulations": any(name.startswith(("physics.mechanism.symbolic", "physics.mechanism.engine"))
                                      for name in sys.modules)}))
client.close()
server.stop()
""".replace("MOVED", MOVED)


def test_the_server_never_derives_or_integrates_a_mechanism_itself():
    done = subprocess.run([sys.executable, "-c", SCRIPT], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result == {"moved": True, "notice": None, "workers": 1, "sympy": False, "formulations": False}, (
        result, done.stderr[-2000:])


def test_a_worker_computes_what_the_server_would_and_a_dead_one_is_reported_and_replaced():
    pool = WorkerPool(count=1)
    try:
        worker = pool.acquire()
        assert worker is not None
        mechanism = MECHANISM_PRESETS["slider-crank"]()
        here = simulate_mechanism(mechanism, 0.2, 13, method="lagrange")
        there = worker.run(mechanism, 0.2, 13, None, None, 0.0, "lagrange", "projection")
        assert np.array_equal(here.q, there.q) and np.array_equal(here.reaction_rows, there.reaction_rows)  # bit for bit
        with pytest.raises(LinkageError, match="method = 'euler'"):
            worker.run(mechanism, 0.2, 13, None, None, 0.0, "euler", "projection")  # refused, the worker goes on
        assert worker.alive
        worker.process.kill()
        worker.process.wait(10)
        with pytest.raises(LinkageError, match="worker process stopped"):
            worker.run(mechanism, 0.2, 13, None, None, 0.0, "dae", "projection")
        pool.release(worker)
        fresh = pool.acquire()
        assert fresh is not worker and fresh is not None and fresh.alive
        assert len(fresh.run(mechanism, 0.2, 13, None, None, 0.0, "dae", "projection").t) == 13
    finally:
        pool.stop()
    assert not pool.workers


HOSTED = """
import json, sys, time
from app.server import LabServer
from app.wsclient import BackgroundClient
server = LabServer(port=0, warm=False, preset="chain", links=7)
client = BackgroundClient(server.url)
(session,) = server.wait_for_sessions(1)
MOVED
ok = moved(0.3)
for method in ("newton_euler", "lagrange"):
    session.guard(lambda: session.set("method", method))
    session.player.wait_idle(120)
    ok = ok and moved(0.3) and session.player.runs[0].spec.settings.method == method
print(json.dumps({"moved": ok, "notice": session.notices.text, "hosted": session.chain is not None,
                  "in_server": session.player.runs[0].spec.runner is None, "sympy": "sympy" in sys.modules}))
client.close()
server.stop()
""".replace("MOVED", MOVED)


def test_a_hosted_chain_runs_here_but_is_never_derived_here(tmp_path):
    """A chain's chunks are compiled code run in the server's interpreter (no process hop per edit), but a
    structure never derived is derived by the session's worker: the server never imports sympy. A cache folder of
    its own makes every derivation a first one."""
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    env = {**__import__("os").environ, "LINKAGE_LAB_CACHE": str(cache)}
    done = subprocess.run([sys.executable, "-c", HOSTED], cwd=ROOT, capture_output=True, text=True, timeout=600,
                          env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result == {"moved": True, "notice": None, "hosted": True, "in_server": True, "sympy": False}, (
        result, done.stderr[-2000:])
