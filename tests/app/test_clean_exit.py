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

from conftest import BrowserStandIn, end_group, wait_until

ROOT = Path(__file__).resolve().parents[2]
START_TIMEOUT = 180.0  # s: an empty cache compiles first
EXIT_TIMEOUT = 30.0  # s: the stop itself is cut short after 8 s (app/lifetime.py); generous under load


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="process groups and SO_REUSEPORT siblings")
@pytest.mark.parametrize("processes", [["--processes", "1"], []], ids=["one-process", "default-processes"])
@pytest.mark.parametrize("preset", [[], ["--preset", "crank-rocker"]], ids=["chain", "mechanism"])
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=lambda s: s.name)
def test_a_signal_to_the_group_ends_the_server_without_warnings(sig, preset, processes, tmp_path):
    command = _start([*processes, *preset], tmp_path)  # its own group, as a terminal's foreground job
    client = None
    try:
        line = command.stdout.readline()  # the first line says where it serves (blocks until then)
        assert "serving at http://" in line, (line, command.stderr.read() if command.poll() is not None else "")
        url = line.split("serving at ")[1].split()[0]
        client = BrowserStandIn(url)
        assert wait_until(lambda: client.counts.bar_updates() >= 3, timeout=START_TIMEOUT), "no frames arrived"
        os.killpg(command.pid, sig)
        err = _ended(command, sig.name)
        assert "leaked" not in err, err[-3000:]
        assert "Traceback" not in err, err[-3000:]
        assert command.returncode == 0, (command.returncode, err[-3000:])
    finally:
        end_group(command, client)


def _start(args: list[str], tmp_path) -> subprocess.Popen:
    env = {**os.environ, "LINKAGE_LAB_CACHE": str(tmp_path / "cache"), "PYTHONPATH": str(ROOT)}
    return subprocess.Popen([sys.executable, "-m", "app", "--port", "0", *args], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)


def _ended(command: subprocess.Popen, what: str) -> str:
    try:
        return command.communicate(timeout=EXIT_TIMEOUT)[1]
    except subprocess.TimeoutExpired:
        pytest.fail(f"still running {EXIT_TIMEOUT:.0f} s after {what}")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="process groups and SO_REUSEPORT siblings")
def test_ctrl_c_while_the_sibling_processes_still_start_prints_no_traceback(tmp_path):
    """The first process serves before its siblings have started; a Ctrl+C at once reached siblings still
    importing (spawn), before they ignore it: a KeyboardInterrupt traceback from each on the terminal."""
    command = _start(["--processes", "3"], tmp_path)
    try:
        line = command.stdout.readline()
        assert "serving at http://" in line, (line, command.stderr.read() if command.poll() is not None else "")
        # as soon as both siblings run Python (multiprocessing's spawn_main), while they import
        assert wait_until(lambda: len(_spawned_children(command.pid)) == 2, timeout=START_TIMEOUT, interval=0.005)
        os.killpg(command.pid, signal.SIGINT)
        err = _ended(command, "SIGINT")
        assert command.returncode == 0, (command.returncode, err[-3000:])
        assert "Traceback" not in err, err[-3000:]
        assert "leaked" not in err, err[-3000:]
    finally:
        end_group(command)


def _spawned_children(pid: int) -> list[int]:
    """The children of ``pid`` that run multiprocessing's spawn bootstrap (the sibling server processes)."""
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                parent = int(f.read().rsplit(")", 1)[1].split()[1])
            with open(f"/proc/{entry}/cmdline", "rb") as f:
                spawned = b"spawn_main" in f.read()
        except (OSError, IndexError, ValueError):
            continue
        if parent == pid and spawned:
            found.append(int(entry))
    return found


# The first process's shared objects as a server of several processes has them (the seat count and the siblings'
# start queue: four named semaphores), and a stop that hangs; GRACE is the grace period of app/lifetime.py.
_STOP_THAT_HANGS = """
import sys, threading
from app import lifetime, processes

lifetime.end_on_signals(grace=float(sys.argv[1]))
seats = processes.Seats(shared=True)
siblings = processes.start_siblings(0, 0, {}, seats)
said = []


def ready():  # said from within the wait, where a signal only sets the flag it polls
    if not said:
        said.append(print("ready", flush=True))
    return True


lifetime.wait_for_stop(0.01, keep_going=ready)
print("stopping", flush=True)
threading.Event().wait()
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="named semaphores of multiprocessing")
@pytest.mark.parametrize("how", ["grace-timer", "second-signal"])
def test_a_forced_exit_leaks_no_semaphore(how):
    """A stop cut short by the grace timer, or a second Ctrl+C, ends the process with ``os._exit``
    (app/lifetime.py), which skips the exit handlers where multiprocessing unlinks its semaphores: the resource
    tracker then said "There appear to be 4 leaked semaphore objects to clean up at shutdown"."""
    grace = "0.5" if how == "grace-timer" else "600"
    proc = subprocess.Popen([sys.executable, "-c", _STOP_THAT_HANGS, grace], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
    try:
        assert proc.stdout.readline().strip() == "ready", proc.stderr.read() if proc.poll() is not None else ""
        os.kill(proc.pid, signal.SIGINT)
        if how == "second-signal":
            assert proc.stdout.readline().strip() == "stopping"  # the first one was handled
            os.kill(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=EXIT_TIMEOUT)  # stderr's end: the resource tracker has ended too
        assert proc.returncode == 128 + signal.SIGINT, (proc.returncode, err[-3000:])  # a forced exit
        assert "leaked" not in err, err[-3000:]
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(30)


def test_a_release_that_fails_at_a_forced_exit_is_one_line_and_the_process_still_ends():
    code = ("from app import lifetime\n"
            "lifetime.before_forced_exit(lambda: 1 / 0)\n"
            "lifetime.force_exit(3)\n")
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert done.returncode == 3
    assert done.stderr == "linkage-lab: at exit, a release failed: ZeroDivisionError: division by zero\n"
