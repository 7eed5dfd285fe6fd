"""The server as several processes on one port (app/processes.py): browsers are spread over interpreters,
the session cap holds across them, and no process outlives the server."""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

from app import processes
from app.processes import reserve_port
from app.server import LabServer
from conftest import BrowserStandIn, wait_until

ROOT = Path(__file__).resolve().parents[2]


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def test_browsers_are_spread_over_two_processes_and_each_is_served():
    server = LabServer(port=0, processes=2, warm=False)
    clients = []
    try:
        assert server.siblings is not None and server.siblings.wait_ready(120), server.siblings.failures
        assert len(set(server.pids)) == 2
        clients = [BrowserStandIn(server.url) for _ in range(12)]
        assert wait_until(lambda: server.seats.count == 12, timeout=60), server.seats.count
        for client in clients:
            assert client.wait_for(lambda c: c.bar_updates() >= 10, timeout=60), client.counts.bar_updates()
        # every session now animates; the kernel hashed each connection to one process, so some sessions live in
        # this process and the rest in the sibling (the chance that all twelve land in one is 2 / 2**12)
        assert 0 < len(server.sessions) < 12, len(server.sessions)
        for client in clients:
            client.close()
        clients = []
        assert wait_until(lambda: server.seats.count == 0, timeout=30), server.seats.count
    finally:
        for client in clients:
            client.close()
        pids = server.pids
        server.stop()
    assert wait_until(lambda: not any(_alive(pid) for pid in pids[1:]), timeout=10)


def test_the_session_cap_holds_across_processes():
    server = LabServer(port=0, processes=2, max_sessions=3, warm=False)
    clients = []
    try:
        assert server.siblings.wait_ready(120), server.siblings.failures
        clients = [BrowserStandIn(server.url) for _ in range(7)]
        def full(counts) -> bool:
            return any(title == "Server full" for _, title in counts.notifications)

        assert wait_until(lambda: sum(full(c.counts) for c in clients) == 4, timeout=60)
        assert server.seats.count == 3
        served = [c for c in clients if not full(c.counts)]
        for client in served:
            assert client.wait_for(lambda c: c.bar_updates() >= 5, timeout=60)
    finally:
        for client in clients:
            client.close()
        server.stop()


def test_a_sibling_stops_when_the_first_process_is_killed():
    process = subprocess.Popen([sys.executable, "-m", "app", "--port", "0", "--processes", "2"], cwd=ROOT,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = process.stdout.readline()
        assert "in 2 processes" in line, (line, process.stderr.read() if process.poll() is not None else "")
        children = subprocess.run(["ps", "-ww", "-o", "pid=,args=", "--ppid", str(process.pid)],
                                  capture_output=True, text=True, check=True).stdout
        siblings = [int(m.group(1)) for m in re.finditer(r"^\s*(\d+) .*spawn_main", children, re.MULTILINE)]
        assert len(siblings) == 1, children
        every_child = [int(m.group(1)) for m in re.finditer(r"^\s*(\d+) ", children, re.MULTILINE)]
        os.kill(process.pid, signal.SIGKILL)  # no chance to stop its siblings itself
        process.wait(10)
        assert wait_until(lambda: not any(_alive(pid) for pid in every_child), timeout=15), (
            "a process outlived its server", children)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait(10)


def test_a_port_held_by_anything_else_is_never_shared():
    with socket.socket() as holder:
        holder.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)  # even a holder that would allow sharing
        holder.bind(("127.0.0.1", 0))
        holder.listen()
        port = holder.getsockname()[1]
        assert reserve_port("127.0.0.1", port) != port
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline and reserve_port("127.0.0.1", port) != port:  # freed: it is taken again
        time.sleep(0.1)
    assert reserve_port("127.0.0.1", port) == port


def test_where_ports_cannot_be_shared_one_process_serves(monkeypatch, capsys):
    monkeypatch.setattr(processes, "shares_ports", lambda: False)
    assert processes.default_processes() == 1
    server = LabServer(port=0, processes=2, warm=False)
    try:
        assert server.siblings is None and len(server.pids) == 1
        assert "cannot share a port" in capsys.readouterr().err
    finally:
        server.stop()


def test_by_default_one_process_per_core_and_one_more(monkeypatch):
    monkeypatch.setattr(processes, "shares_ports", lambda: True)
    monkeypatch.setattr(processes.os, "sched_getaffinity", lambda pid: {0, 1})
    assert processes.default_processes() == 3
    monkeypatch.setattr(processes.os, "sched_getaffinity", lambda pid: set(range(64)))
    assert processes.default_processes() == processes.MAX_PROCESSES


def test_a_port_left_in_time_wait_is_served_again():
    """A restart within a minute of Ctrl+C kept moving to the next port: the stopped server's connections
    linger in TIME_WAIT, and the probe refused the port where the server's own socket would bind."""
    listener = socket.socket()
    listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    listener.bind(("127.0.0.1", 0))
    listener.listen()
    port = listener.getsockname()[1]
    client = socket.create_connection(("127.0.0.1", port))
    accepted, _ = listener.accept()
    accepted.close()  # the server side closes first: its end of the connection enters TIME_WAIT
    client.close()
    listener.close()
    assert processes.reserve_port("127.0.0.1", port) == port
    with socket.socket() as holder:  # a port another socket listens on is still refused
        holder.bind(("127.0.0.1", 0))
        holder.listen()
        held = holder.getsockname()[1]
        assert processes.reserve_port("127.0.0.1", held) != held
