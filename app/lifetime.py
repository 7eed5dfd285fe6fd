"""No process of the app outlives the command that started it, whichever signal ends that command.

Why: ``python -m app`` starts server processes (app/processes.py) and mechanism workers
(app/mechanism_workers.py). Without handlers, SIGTERM (``kill``, systemd, ``docker stop``) and SIGHUP (a closed
terminal) end the first process at once, and what it started stays behind holding the port or a core; as
PID 1 in a container a process without a handler does not even end on SIGTERM. So:

* the command turns SIGTERM and SIGHUP into what Ctrl+C already is (:func:`end_on_signals`): the server stops
  its sessions, siblings and workers, and a stop that hangs is cut short after a grace period;
* every child asks the kernel to end it when its parent ends (:func:`die_with_parent`, Linux
  ``PR_SET_PDEATHSIG``), and checks its parent itself as well (:func:`watch_parent`), so that even a
  ``kill -9`` of the command leaves nothing serving.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import os
import signal
import sys
import threading
import time
from collections.abc import Callable

ENDING_SIGNALS = (signal.SIGTERM, signal.SIGINT, signal.SIGHUP)
STOP_GRACE_SECONDS = 8.0  # a stop that takes longer (a hung session) is cut short; the children end with us
PARENT_CHECK_SECONDS = 0.5
_PR_SET_PDEATHSIG = 1


def die_with_parent(sig: int = signal.SIGTERM, parent: int | None = None) -> bool:
    """Ask the kernel to send ``sig`` to this process when the thread that started it ends (Linux only; False
    elsewhere). ``parent``: the pid that started us; if it has already gone, end now (the race the kernel
    cannot cover). Call it in a child started from a thread that lives as long as its process (the main
    thread): the kernel's "parent" is that thread, not the process."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        ok = libc.prctl(_PR_SET_PDEATHSIG, int(sig), 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False
    if parent is not None and os.getppid() != parent:
        os._exit(0)
    return ok


def watch_parent(parent: int, interval: float = PARENT_CHECK_SECONDS) -> threading.Thread:
    """A daemon thread that ends this process (``os._exit``) once ``parent`` is no longer its parent: a child
    whose parent was killed is adopted by init (or a subreaper) and would otherwise go on serving."""

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(interval)
        os._exit(0)

    thread = threading.Thread(target=watch, name="parent-watch", daemon=True)
    thread.start()
    return thread


_stop_requested = threading.Event()
_raise_on_signal = True  # False while :func:`wait_for_stop` waits: the signal only sets the flag it polls
_before_forced_exit: list[Callable[[], None]] = []


def stopping() -> bool:
    """Whether an ending signal has arrived (:func:`end_on_signals`): work that fails now (a build worker that
    got the terminal's Ctrl+C too) is the stop, not a fault to report or redo."""
    return _stop_requested.is_set()


def before_forced_exit(release: Callable[[], None]) -> None:
    """Have ``release()`` run when :func:`force_exit` ends the process, which skips the interpreter's exit
    handlers. For what outlives the process unless released: multiprocessing's named semaphores
    (app/processes.py), whose resource tracker otherwise warns "There appear to be N leaked semaphore objects"
    at a second Ctrl+C or a stop cut short. ``release`` must be quick and may not wait on a lock a hung thread
    could hold."""
    _before_forced_exit.append(release)


def force_exit(code: int) -> None:
    """End the process at once with ``code`` (``os._exit``: a hung stop cannot hold it), after the releases
    registered with :func:`before_forced_exit`."""
    for release in list(_before_forced_exit):
        try:
            release()
        except Exception as error:  # noqa: BLE001 - ending anyway: a release that fails must not keep us alive
            # one line straight to the file descriptor: no logging lock a hung thread could hold
            with contextlib.suppress(OSError):
                os.write(2, f"linkage-lab: at exit, a release failed: {type(error).__name__}: {error}\n".encode())
    os._exit(code)


def end_on_signals(grace: float = STOP_GRACE_SECONDS, signals: tuple[int, ...] = ENDING_SIGNALS) -> None:
    """In the command's main thread: SIGTERM and SIGHUP end it as Ctrl+C does, and once any of them arrived, the
    process ends within ``grace`` seconds whatever the stop is doing (its children end with it:
    :func:`die_with_parent`). A second signal ends it at once.

    While the command starts, a signal is a ``KeyboardInterrupt`` (so what was started is stopped); while it
    serves (:func:`wait_for_stop`) it only sets a flag. Why: Python runs the handler in the main thread between
    any two bytecodes, also inside a garbage collector's weakref callback (importlib's module locks have one),
    where an exception is printed as "Exception ignored ... Traceback" and swallowed: the server then served on
    until the grace timer killed it (exit 129, seen once in CI on SIGHUP)."""
    state = {"ending": False}

    def handler(signum, frame) -> None:
        if state["ending"]:
            force_exit(128 + signum)
        state["ending"] = True
        _stop_requested.set()
        timer = threading.Timer(grace, lambda: force_exit(128 + signum))
        timer.daemon = True
        timer.start()
        if _raise_on_signal:
            raise KeyboardInterrupt

    for sig in signals:
        signal.signal(sig, handler)


def wait_for_stop(interval: float, keep_going: Callable[[], bool] = lambda: True) -> bool:
    """Block the main thread until an ending signal arrived (True) or ``keep_going()`` turns false (False),
    checking every ``interval`` s: short waits, since a signal the kernel delivers to another thread (a player,
    viser's loop) runs its handler only when the main thread wakes. A signal arriving now sets a flag instead of
    raising (:func:`end_on_signals`), so it cannot be lost in whatever the main thread happens to run."""
    global _raise_on_signal
    _raise_on_signal = False
    try:
        while not _stop_requested.is_set():
            if not keep_going():
                return False
            _stop_requested.wait(interval)
        return True
    finally:
        _raise_on_signal = True
