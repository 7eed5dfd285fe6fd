"""Ctrl+C (SIGINT to the whole process group, as a terminal sends it) and SIGTERM end ``python -m app`` cleanly.

tests/app/test_signals.py checks that no process is left behind; it sends the signal to the command only and
did not look for the multiprocessing resource tracker's "leaked semaphore objects" warning, which the tracker
prints (on the shared stderr) when the command ends without releasing the shared seat count and the siblings'
start queue. Here the whole group gets the signal, as from a terminal, with a browser stand-in connected, in an
empty cache folder; the exit must be orderly: exit code 0, no traceback, no resource tracker warning.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import BrowserStandIn, wait_until

ROOT = Path(__file__).resolve().parents[2]
START_TIMEOUT = 180.0  # s: an empty cache compiles first
EXIT_TIMEOUT = 30.0  # s: the stop itself is cut short after 8 s (app/lifetime.py); generous under load


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="process groups and SO_REUSEPORT siblings")
@pytest.mark.parametrize("processes", [["--processes", "1"], []], ids=["one-process", "default-processes"])
@pytest.mark.parametrize("preset", [[], ["--preset", "crank-rocker"]], ids=["chain", "mechanism"])
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=lambda s: s.name)
def test_a_signal_to_the_group_ends_the_server_without_warnings(sig, preset, processes, tmp_path):
    env = {**os.environ, "LINKAGE_LAB_CACHE": str(tmp_path / "cache"), "PYTHONPATH": str(ROOT)}
    command = subprocess.Popen([sys.executable, "-m", "app", "--port", "0", *processes, *preset], cwd=ROOT, env=env,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               start_new_session=True)  # its own group, as a terminal's foreground job
    client = None
    try:
        line = command.stdout.readline()  # the first line says where it serves (blocks until then)
        assert "serving at http://" in line, (line, command.stderr.read() if command.poll() is not None else "")
        url = line.split("serving at ")[1].split()[0]
        client = BrowserStandIn(url)
        assert wait_until(lambda: client.counts.bar_updates() >= 3, timeout=START_TIMEOUT), "no frames arrived"
        os.killpg(command.pid, sig)
        try:
            _, err = command.communicate(timeout=EXIT_TIMEOUT)
        except subprocess.TimeoutExpired:
            pytest.fail(f"still running {EXIT_TIMEOUT:.0f} s after {sig.name}")
        assert "leaked" not in err, err[-3000:]
        assert "Traceback" not in err, err[-3000:]
        assert command.returncode == 0, (command.returncode, err[-3000:])
    finally:
        if client is not None:
            client.close()
        if command.poll() is None:
            os.killpg(command.pid, signal.SIGKILL)
            command.wait(10)
