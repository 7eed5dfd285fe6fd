"""``python -m physics`` ends without the interpreter's teardown (physics/process_exit.py): its exit code, its
output and its exit handlers must be exactly those of an ordinary exit, and a running thread must be waited for."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

CHILD = r"""
import atexit, sys, threading, time
from physics.process_exit import exit_without_teardown
mode = sys.argv[1]
print("printed before the exit", end="")  # no newline: only a flush writes it
atexit.register(lambda: sys.stdout.write(" | exit handler ran"))
if mode == "thread":
    def late():
        time.sleep(0.3)
        sys.stdout.write(" | thread finished")
        sys.stdout.flush()
    threading.Thread(target=late).start()
exit_without_teardown(int(sys.argv[2]))
print("never reached")
"""


def _child(mode: str, code: int) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-c", CHILD, mode, str(code)], capture_output=True, text=True, env=env,
                          timeout=120, cwd=ROOT)


def test_the_exit_code_output_and_exit_handlers_are_kept():
    for code in (0, 2, 3):
        result = _child("plain", code)
        assert result.returncode == code
        assert result.stdout == "printed before the exit | exit handler ran"
        assert result.stderr == ""


def test_a_running_thread_is_waited_for():
    result = _child("thread", 4)
    assert result.returncode == 4
    assert "thread finished" in result.stdout
    assert result.stdout.endswith("exit handler ran")  # the ordinary exit: threads joined, then the handlers


def test_the_command_line_keeps_its_exit_codes_and_its_private_temporary_cache_is_removed(tmp_path):
    """A cache folder others can write is refused for a private temporary one, removed by an exit handler."""
    shared = tmp_path / "shared"
    shared.mkdir()
    shared.chmod(0o777)
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    env = dict(os.environ, LINKAGE_LAB_CACHE=str(shared), TMPDIR=str(scratch),
               LINKAGE_LAB_KEY_DIR=str(tmp_path / "keys"), PYTHONPATH=str(ROOT))
    result = subprocess.run([sys.executable, "-m", "physics", "cache"], capture_output=True, text=True, env=env,
                            timeout=300, cwd=ROOT)
    assert result.returncode == 0, result.stderr
    assert "writable by group or others" in result.stderr
    assert not list(scratch.glob("linkage-lab-cache-*"))  # made during the run, removed at its exit
    bad = subprocess.run([sys.executable, "-m", "physics", "simulate", "--preset", "no-such-preset"],
                         capture_output=True, text=True, env=env, timeout=300, cwd=ROOT)
    assert bad.returncode == 2
    assert bad.stderr.strip().splitlines()[-1].startswith("error: ")
    assert not list(scratch.glob("linkage-lab-cache-*"))
