"""Fixtures for the app tests: an in-process server on a free loopback port, and websocket stand-ins for browsers.

A stand-in speaks viser's protocol (app/wsclient.py): it connects, sends the camera message a
browser sends, and counts what the server pushes. Each stand-in gets its own session, found by the client
id that appeared when it connected.
"""

from __future__ import annotations

import os
import signal
import sys
import tempfile
import time
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
os.environ.setdefault("LINKAGE_LAB_CACHE", tempfile.mkdtemp(prefix="linkage-lab-app-tests-"))

from app.server import LabServer
from app.wsclient import BackgroundClient  # noqa: E402


def pytest_configure(config):
    config.addinivalue_line(
        "markers", "load: the 60 s load test with 30 websocket clients (deselect with -m 'not load')"
    )


class BrowserStandIn(BackgroundClient):
    """A websocket client standing in for a browser (app/wsclient.py)."""


def wait_until(predicate, timeout: float = 120.0, interval: float = 0.02) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(interval)
    return False


def end_group(command, *clients) -> None:
    """A test's ``finally``: close its websocket clients, then kill the command's whole process group (started
    with ``start_new_session=True``) if the command still runs, so that a failed test leaves no server behind."""
    for client in clients:
        if client is not None:
            client.close()
    if command.poll() is None:
        os.killpg(command.pid, signal.SIGKILL)
        command.wait(10)


@pytest.fixture(scope="module")
def in_process():
    """A module's sessions without worker processes: their chunks run in this interpreter, so the systems a test
    inspects are the ones loaded here (app/mechanism_workers.py)."""
    from app import mechanism_workers  # noqa: PLC0415 - the app's pool, only for the modules that ask

    saved = mechanism_workers.POOL.count
    mechanism_workers.POOL.count = 0
    yield
    mechanism_workers.POOL.count = saved


@pytest.fixture(scope="module")
def lab():
    server = LabServer(port=0, warm=False)
    yield server
    server.stop()


def lab_of(preset: str):
    """A module's own server starting with ``preset`` (a mechanism's tests): ``my_lab = lab_of("slider-crank")``
    at module level, then ``connect(my_lab)`` in a test."""

    @pytest.fixture(scope="module")
    def preset_lab():
        server = LabServer(port=0, warm=False, preset=preset)
        yield server
        server.stop()

    return preset_lab


@pytest.fixture
def connect(lab):
    """``connect()`` -> (stand-in, session): a new browser and the session the server made for it."""
    opened: list[BrowserStandIn] = []

    def _connect(server=None):
        server = server or lab
        before = set(server.sessions)
        client = BrowserStandIn(server.url)
        opened.append(client)
        assert wait_until(lambda: set(server.sessions) - before, timeout=30), "no session was created"
        (client_id,) = set(server.sessions) - before
        session = server.sessions[client_id]
        assert session.player.wait_idle(60), "the first start was not shown"
        return client, session

    yield _connect
    for client in opened:
        client.close()
