"""The server as several processes on one port, so that own sessions do not share one interpreter lock.

Where the time goes (``python -m app.bench load``, docs/reliability.md): with 30 own sessions of the triple
pendulum the server spends about 2 % of its CPU integrating; the rest goes into turning each frame into viser
messages (the player threads) and serialising, compressing and sending them (viser's event-loop thread). All of
it needs the interpreter lock, so one interpreter serves at most about 1000 frames per second whatever the
number of cores, and with a hundred player threads the threads mostly wait for the lock. Moving only the
integration into a pool of workers would leave 98 % of the work where it is.

So the server runs as ``processes`` interpreters instead, each a complete viser server with its own sessions,
all bound to the same port with ``SO_REUSEPORT``: the kernel hands each new connection (page, assets and
websocket alike; every process serves the same page) to one of them. The process started by ``python -m app``
is the first; it starts the others (``multiprocessing`` with *spawn*: nothing of the first's threads is
copied) and stops them when it stops; a sibling whose first process has gone stops itself. The cap on
sessions is one count in shared memory (:class:`Seats`), so ``--max-sessions`` holds across all of them.

The port is reserved by a plain bind before the processes bind it with ``SO_REUSEPORT``: a port already held by
anything (including another Linkage Lab) is skipped, so two servers never share one port by accident.
"""

from __future__ import annotations

import _multiprocessing  # type: ignore[import-not-found]  # sem_unlink: the C module, no stubs
import contextlib
import multiprocessing
import os
import queue
import signal
import socket
import sys
import threading
import time
from multiprocessing import resource_tracker

import websockets.asyncio.server as ws_server

from . import lifetime

# Sibling processes get this long to start and bind (imports, warm-up of the compiled code in the background).
SIBLING_START_TIMEOUT = 120.0
SIBLING_STOP_TIMEOUT = 5.0
MAX_PROCESSES = 16  # more interpreters than this only adds memory (about 200 MB each) on any machine we serve
# A sibling checks this often whether the process that started it is still there.
ORPHAN_CHECK_SECONDS = 1.0

_spawn = multiprocessing.get_context("spawn")
_GROUP_SIGNALS = {signal.SIGINT, signal.SIGHUP}  # what a terminal sends its foreground group
_serve_patch_lock = threading.Lock()


def shares_ports() -> bool:
    """Whether the kernel spreads one port's connections over processes (Linux ``SO_REUSEPORT``; macOS has the
    option but gives every connection to one socket, Windows lacks it)."""
    return sys.platform.startswith("linux") and hasattr(socket, "SO_REUSEPORT")


def default_processes() -> int:
    """One interpreter per core this process may run on, and one more (one where ports cannot be shared).

    Why one more: a server process is bound by its interpreter lock, not by a core. With 100 sessions on two
    cores, two processes used 1.4 cores between them and rendered 20 to 25 frames/s per session; three used 1.6
    cores and rendered 26 to 27 (``python -m app.bench load --clients 100 --processes K``, BENCHMARKS.md)."""
    if not shares_ports():
        return 1
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cores = os.cpu_count() or 1
    return max(1, min(cores + 1, MAX_PROCESSES))


class _LocalCount:
    """An integer and its lock, for a server of one process (no shared memory, no helper process)."""

    def __init__(self) -> None:
        self.value = 0
        self._lock = threading.Lock()

    def get_lock(self) -> threading.Lock:
        return self._lock


class Seats:
    """How many sessions exist across every process of one server.

    ``take(limit)`` claims a seat if fewer than ``limit`` are taken; ``release()`` gives one back. With
    ``shared`` the count lives in shared memory (multiprocessing starts its resource tracker process for it)
    and is handed to the sibling processes; otherwise it is a plain integer."""

    def __init__(self, shared: bool = False) -> None:
        self._value = _spawn.Value("i", 0) if shared else _LocalCount()
        if shared:
            release_if_forced_out(self._value.get_lock())

    def take(self, limit: int) -> bool:
        with self._value.get_lock():
            if self._value.value >= limit:
                return False
            self._value.value += 1
            return True

    def release(self) -> None:
        with self._value.get_lock():
            self._value.value = max(0, self._value.value - 1)

    @property
    def count(self) -> int:
        return int(self._value.value)


def release_if_forced_out(*locks) -> None:
    """Unlink these multiprocessing locks' named semaphores if the process is ended by
    :func:`app.lifetime.force_exit` (a second Ctrl+C, a stop cut short after the grace period).

    Why: multiprocessing unlinks them, and tells its resource tracker so, in the interpreter's exit handlers,
    which ``os._exit`` skips: the tracker then printed "There appear to be 4 leaked semaphore objects to clean
    up at shutdown" (the seat count's lock and the sibling queue's three) and unlinked them itself. A name
    already unlinked (the exit handlers ran first) is left alone: the tracker no longer knows it."""
    names = [lock._semlock.name for lock in locks if getattr(getattr(lock, "_semlock", None), "name", None)]

    def release() -> None:
        for name in names:
            try:
                _multiprocessing.sem_unlink(name)
            except OSError:
                continue
            resource_tracker.unregister(name, "semaphore")

    if names:
        lifetime.before_forced_exit(release)


def reserve_port(host: str, port: int) -> int:
    """The first port from ``port`` on that nothing on this machine holds (a plain bind succeeds), for the
    processes to share with ``SO_REUSEPORT``; ``port = 0`` picks a free one. Mirrors viser's own search."""
    family = socket.getaddrinfo(host, 0, type=socket.SOCK_STREAM)[0][0]
    for candidate in ([0] if port == 0 else range(port, min(port + 1000, 65536))):
        with socket.socket(family, socket.SOCK_STREAM) as probe:
            # as the server's own listening socket does (asyncio sets it): a port whose last connections are
            # in TIME_WAIT after a stop is free to serve again, so a restart keeps the address an open tab
            # knows; a port another socket listens on still refuses the bind
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            try:
                probe.bind((host, candidate))
            except OSError:
                continue
            return probe.getsockname()[1]
    raise OSError(f"no free port from {port} on {host}")


@contextlib.contextmanager
def reuse_port_binding():
    """While a viser server is being constructed (it binds before its constructor returns), make its
    websockets server bind with ``SO_REUSEPORT``. viser has no option for it; its call is
    ``websockets.asyncio.server.serve(...)``, whose extra keywords go to ``loop.create_server``."""
    with _serve_patch_lock:
        original = ws_server.serve

        def serve(*args, **kwargs):
            kwargs["reuse_port"] = True
            return original(*args, **kwargs)

        ws_server.serve = serve  # type: ignore[misc,assignment]  # viser calls websockets' serve by this name
        try:
            yield
        finally:
            ws_server.serve = original  # type: ignore[misc]


class Siblings:
    """The processes a first server started: ``pids``, ``wait_ready()``, ``stop()``.

    The first process serves at once; each sibling joins the port when it has started (a second or two), and
    the kernel hands it connections from then on. A sibling that fails to start is reported on stderr and
    the others serve on."""

    def __init__(self, processes: list, ready) -> None:
        self._processes = processes
        self._ready_queue = ready
        self.ready = 0
        self.failures: list[str] = []
        self._all_reported = threading.Event()
        self._stopping = threading.Event()
        self._watcher = threading.Thread(target=self._collect, name="sibling-start", daemon=True)
        self._watcher.start()

    def _collect(self) -> None:
        deadline = time.monotonic() + SIBLING_START_TIMEOUT
        reported = 0
        try:
            while reported < len(self._processes) and not self._stopping.is_set():
                try:
                    status = self._ready_queue.get(timeout=0.2)
                except queue.Empty:
                    if time.monotonic() < deadline:
                        continue
                    status = f"did not start within {SIBLING_START_TIMEOUT:.0f} s"
                reported += 1
                if status == "ok":
                    self.ready += 1
                else:
                    self.failures.append(status)
                    print(f"linkage-lab: a server process could not start ({status}); the others serve on",
                          file=sys.stderr)
        finally:
            self._all_reported.set()

    def wait_ready(self, timeout: float = SIBLING_START_TIMEOUT) -> bool:
        """True once every sibling serves."""
        return self._all_reported.wait(timeout) and self.ready == len(self._processes)

    @property
    def pids(self) -> list[int]:
        return [p.pid for p in self._processes if p.pid is not None]

    def alive(self) -> int:
        return sum(p.is_alive() for p in self._processes)

    def ask_to_stop(self) -> None:
        """Send each sibling SIGTERM without waiting: the first process closes its own sessions meanwhile, so
        that the whole stop fits in the grace period of app/lifetime.py (issue 26: a lone SIGINT to the first
        of three processes, its sessions and the siblings' stopped one after the other, took longer)."""
        self._stopping.set()
        for process in self._processes:
            if process.is_alive():
                process.terminate()

    def stop(self) -> None:
        self.ask_to_stop()
        self._watcher.join(2.0)
        deadline = time.monotonic() + SIBLING_STOP_TIMEOUT
        for process in self._processes:
            process.join(max(0.0, deadline - time.monotonic()))
            if process.is_alive():
                process.kill()
                process.join(1.0)
        for process in self._processes:
            process.close()
        self._processes = []
        self._ready_queue.close()
        self._ready_queue.join_thread()


def start_siblings(count: int, port: int, options: dict, seats: Seats) -> Siblings:
    """Start ``count`` more server processes on ``port``; returns at once (see :class:`Siblings`)."""
    ready = _spawn.Queue()
    release_if_forced_out(*(getattr(ready, lock, None) for lock in ("_rlock", "_wlock", "_sem")))
    processes = [
        _spawn.Process(target=_sibling_main, args=(port, options, seats, os.getpid(), ready),
                       name=f"linkage-lab-{i + 2}", daemon=True)
        for i in range(count)
    ]
    # Ctrl+C and a closed terminal reach the whole group, also a sibling still importing (its traceback went
    # to the terminal): started with them blocked (the mask is inherited), a sibling unblocks them once ignored
    masking = hasattr(signal, "pthread_sigmask")
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, _GROUP_SIGNALS) if masking else set()
    try:
        for process in processes:
            process.start()
    finally:
        if masking:
            signal.pthread_sigmask(signal.SIG_SETMASK, previous)
    return Siblings(processes, ready)


def _sibling_main(port: int, options: dict, seats: Seats, parent: int, ready) -> None:
    """One more server process: serve until the first process stops it (SIGTERM) or goes away (the kernel's
    SIGTERM when its starting thread ends, app/lifetime.py, or the check below every second)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl+C reaches the whole group: the first process decides
    signal.signal(signal.SIGHUP, signal.SIG_IGN)  # so does a closed terminal
    if hasattr(signal, "pthread_sigmask"):  # blocked while it started (start_siblings): now ignored instead
        signal.pthread_sigmask(signal.SIG_UNBLOCK, _GROUP_SIGNALS)
    lifetime.end_on_signals(signals=(signal.SIGTERM,))  # stop the sessions and workers, then end
    lifetime.die_with_parent(signal.SIGTERM, parent)
    try:
        from .server import LabServer  # noqa: PLC0415 - app.server imports this module: a cycle otherwise

        server = LabServer(port=port, processes=1, seats=seats, reuse_port=True, **options)
        if server.port != port:  # viser moved on: the shared port was not ours to join
            server.stop()
            raise OSError(f"bound {server.port} instead of {port}")
    except KeyboardInterrupt:  # stopped while starting: nothing served yet, nothing to close
        # a half-built server's threads (viser's) would hold the process until the first one kills it (5 s)
        os._exit(0)
    except Exception as error:  # reported to the first process, which serves on
        ready.put(f"{type(error).__name__}: {error}")
        return
    ready.put("ok")
    try:  # until SIGTERM (app/lifetime.py: the first process asks) or the first process has gone
        lifetime.wait_for_stop(ORPHAN_CHECK_SECONDS, keep_going=lambda: os.getppid() == parent)
    except KeyboardInterrupt:  # SIGINT with its default handler (ignored above, unless a test changed it)
        pass
    finally:
        server.stop()
        from .mechanism_workers import POOL  # noqa: PLC0415 - imported by the server already

        POOL.stop()
        sys.stdout.flush()
