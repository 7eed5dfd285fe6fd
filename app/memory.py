"""Memory that closed sessions freed goes back to the system, so a server's size follows its audience.

What was kept (measured with ``tracemalloc`` and ``gc.get_objects()`` over cycles of 25 browsers joining and
leaving an in-process server): no Python object of a closed session survives a full garbage collection, but
until one runs a closed session stays whole: its controls, viser handles, images and sample rings (about 2.5 MB
of Python allocations each) hang in reference cycles, and Python's collector reaches its oldest generation
only now and then. And what was freed stays resident: each player thread allocates in one of glibc's
per-thread arenas, and glibc gives an arena's pages back to the system only from the top of its heap, so freed
blocks under a live one stay. A server grew 16 % over six cycles (273 MB after the first, 317 MB after the
sixth) with the same Python objects alive after each.

So: a player drops its rings when its thread ends (app/player.py), and after sessions close
:class:`Trimmer` runs a full collection and then glibc's ``malloc_trim(0)``, which returns the free pages of
every arena. Measured alternatives: ``malloc_trim`` alone after each cycle (with the test's own collection)
kept the server within 3 % of its first cycle; ``MALLOC_ARENA_MAX=2`` instead (fewer arenas; it has to be in
the environment before the process starts any thread, so it cannot be set from the app's code for its own
process) left it at +13 % and makes every player thread share two heaps' locks. The collection takes about
0.1 s and the trim a few milliseconds; both run on the trimmer's own thread once departures have settled, so a
class leaving at once costs one of each, not one per browser.

Outside glibc (macOS, musl) there is no ``malloc_trim``: only the collection runs, and those allocators
return memory their own way.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import gc
import sys
import threading
import time
import weakref
from typing import Callable

from .logs import log_once

# Departures arrive over a fraction of a second when a class closes its tabs: wait this long after the last
# one before trimming (a later departure restarts the wait, up to MAX_TRIM_DELAY_SECONDS in all).
TRIM_SETTLE_SECONDS = 0.5
MAX_TRIM_DELAY_SECONDS = 5.0


def _find_malloc_trim() -> Callable[[int], int] | None:
    if not sys.platform.startswith("linux"):
        return None
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        trim = libc.malloc_trim  # glibc only
    except (OSError, AttributeError):
        return None
    trim.argtypes = [ctypes.c_size_t]
    trim.restype = ctypes.c_int
    return trim


_MALLOC_TRIM = _find_malloc_trim()


def can_release() -> bool:
    """Whether this process's allocator can be asked to return freed memory (glibc's ``malloc_trim``)."""
    return _MALLOC_TRIM is not None


def release_freed_memory() -> bool:
    """Return the free pages of every malloc arena to the system now; True when any memory was released."""
    if _MALLOC_TRIM is None:
        return False
    return bool(_MALLOC_TRIM(0))


FINISH_WAIT_SECONDS = 30.0  # the longest a trim waits for closed sessions' threads to end, and for them to go
RECOLLECT_FIRST_SECONDS = 0.05  # a closed session still held after a collection: the first wait before the next
RECOLLECT_MAX_SECONDS = 1.0  # the waits double up to this (each collection walks the whole heap)


class Trimmer:
    """Collects and trims (:func:`release_freed_memory`) a moment after sessions close.

    ``request()`` is called by whoever closed a session (any thread; it never blocks); the work runs on this
    object's own daemon thread, started on the first request, once no request has come for ``settle`` seconds
    (at most ``max_delay`` after the first of a wave). ``trims`` counts the trims done; ``settled()`` says
    whether every request so far has been followed by one (tests and the benchmark wait on it)."""

    def __init__(self, settle: float = TRIM_SETTLE_SECONDS, max_delay: float = MAX_TRIM_DELAY_SECONDS) -> None:
        self.settle = settle
        self.max_delay = max_delay
        self.trims = 0
        self._requests = 0  # requests so far
        self._covered = 0  # requests made before the latest trim began
        self._requested = threading.Event()
        self._stopping = False
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self._finishing: list[threading.Thread] = []  # closed sessions' threads the next trim waits for
        self._closed: list[weakref.ref] = []  # the closed sessions the next trim sees gone

    def request(self, finishing: threading.Thread | None = None, closed: object = None) -> None:
        """A session closed; ``finishing``: a thread of it still running (its player's, stopped but not yet
        ended: a chunk waits for a busy worker), which the trim waits for (at most FINISH_WAIT_SECONDS) before it
        collects, or the session's objects it still holds would stay until the next full collection.
        ``closed``: the session itself. Its closer may still hold it when the trim collects (the thread that
        called this runs on: viser's disconnect callback, its pool's work item holding the client, whose
        controls' callbacks hold the session), and what the collection could not free then would wait in its
        cycles for the next full collection: the trim collects again (waits doubling, within
        FINISH_WAIT_SECONDS in all) until every such session is gone, and only then counts as done."""
        with self._lock:
            if self._stopping:
                return
            if finishing is not None and finishing.is_alive():
                self._finishing.append(finishing)
            if closed is not None:
                self._closed.append(weakref.ref(closed))
            self._requests += 1
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="memory-trim", daemon=True)
                self._thread.start()
        self._requested.set()

    def settled(self) -> bool:
        with self._lock:
            return self._covered == self._requests

    def wait_settled(self, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while not self.settled():
            if time.monotonic() >= deadline:
                return False
            time.sleep(0.02)
        return True

    def _run(self) -> None:
        while True:
            self._requested.wait()
            if self._stopping:
                return
            waited = 0.0
            self._requested.clear()
            while waited < self.max_delay:  # a wave of departures: wait until it has settled
                if not self._requested.wait(self.settle):
                    break
                if self._stopping:
                    return
                self._requested.clear()
                waited += self.settle
            with self._lock:
                covered = self._requests
                finishing, self._finishing = self._finishing, []
                closed, self._closed = self._closed, []
            deadline = time.monotonic() + FINISH_WAIT_SECONDS
            for thread in finishing:  # what they hold is garbage only once they end
                thread.join(max(0.0, deadline - time.monotonic()))
            self._collect(closed, deadline)
            release_freed_memory()
            with self._lock:
                self._covered = covered
                self.trims += 1

    def _collect(self, closed: list[weakref.ref], deadline: float) -> None:
        """A full collection (a closed session's objects hang in reference cycles until one), again after
        doubling waits while a ``closed`` session is still there (its closer had not let go), until ``deadline``."""
        gc.collect()
        wait = RECOLLECT_FIRST_SECONDS
        while not self._stopping and any(ref() is not None for ref in closed):
            if time.monotonic() + wait > deadline:  # something keeps them: say so once, a leak to look for
                held = sum(ref() is not None for ref in closed)
                log_once("memory:closed sessions held", "%d closed session(s) still held after the memory trim's "
                         "collections; their memory stays until whatever holds them lets go", held)
                return
            time.sleep(wait)
            wait = min(2 * wait, RECOLLECT_MAX_SECONDS)
            gc.collect()

    def stop(self) -> None:
        with self._lock:
            self._stopping = True
            thread = self._thread
        self._requested.set()
        if thread is not None and thread is not threading.current_thread():
            thread.join(2.0)
