"""A general mechanism's chunks computed in worker processes, off the server's interpreter.

Why: a chain's chunk is compiled code that releases nothing but costs little; a general mechanism's chunk is
numpy and Python (position analysis, projection, reactions: about a fifth of a core for the Jansen leg), and
its tree formulations are derived by sympy on first use (0.3 to 1.1 s holding the interpreter lock). In the
server's interpreter that work would take frames from every other browser's session; here the player's thread
only waits on a pipe (the lock released) while a worker process computes.

Each session is given one worker for its lifetime (the least used), so the derivations a worker caches serve
that session's later chunks; a worker is a spawned process with a pipe, started on first use, at most
:func:`worker_count` per server process. A worker that dies is replaced, and the chunk that was lost is
reported as the run's failure (one notice; Reset goes on with a new worker).
"""

from __future__ import annotations

import dataclasses
import functools
import os
import signal
import socket
import subprocess
import sys
import threading
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from physics import LinkageError, Trajectory
from physics.mechanism import Mechanism

MAX_WORKERS = 4
WORKERS_ENV = "LINKAGE_LAB_MECHANISM_WORKERS"  # 0: compute in the server's interpreter (debugging)


def worker_count() -> int:
    """Workers per server process: one per core, at most MAX_WORKERS (``LINKAGE_LAB_MECHANISM_WORKERS``)."""
    wanted = os.environ.get(WORKERS_ENV)
    if wanted is not None and wanted.strip().isdigit():
        return min(int(wanted), MAX_WORKERS)
    return max(1, min(os.cpu_count() or 1, MAX_WORKERS))


# ---------------------------------------------------------------------------------------------- in the worker
@functools.lru_cache(maxsize=32)
def _mechanism(description: str) -> Mechanism:
    return Mechanism.model_validate_json(description)


def _chunk(description: str, t_end: float, samples: int, q0, qdot0, t_start: float, method: str,
           stabilization: str, rtol: float = 1e-10, integrator: str = "DOP853", step: float | None = None,
           baumgarte: tuple[float, float] | None = None, max_steps: int | None = None,
           continuing: bool = False, coordinates: str = "maximal", rotations: str = "relative") -> Trajectory:
    from physics.mechanism.simulate import simulate_mechanism  # noqa: PLC0415 - the worker's own import

    from .mechanism_runs import run_settings  # noqa: PLC0415 - as above

    settings = run_settings(t_end, samples, method, stabilization, rtol, integrator, step, baumgarte, max_steps)
    run = simulate_mechanism(_mechanism(description), t_end, samples, q0=q0, qdot0=qdot0, t_start=t_start,
                             settings=settings, continuing=continuing, coordinates=coordinates, rotations=rotations)
    # Sent without its condition, which pickling would compute for every sample (Trajectory.__getstate__): the
    # server measures it at the one sample its status line shows (app.mechanism_runs.MechanismSpec.condition_at)
    return dataclasses.replace(run, condition=np.zeros(0))


def _serve(connection) -> None:
    """The worker's loop: a request is the arguments of :func:`_chunk`; the answer ``(ok, run or error)``."""
    while True:
        try:
            request = connection.recv()
        except (EOFError, OSError):
            return
        if request is None:
            return
        try:
            answer: tuple[bool, Any] = (True, _chunk(*request))
        except LinkageError as error:
            answer = (False, LinkageError(str(error)))
        except Exception as error:  # the worker's boundary: the server reports it, the worker goes on
            answer = (False, RuntimeError(f"{type(error).__name__}: {error}"))
        try:
            connection.send(answer)
        except (OSError, ValueError):
            return


# ---------------------------------------------------------------------------------------------- in the server
class Worker:
    """One worker process and its pipe; :meth:`run` is called from player threads (one request at a time).

    A subprocess (``python -m app.mechanism_workers FD``) joined by a socket pair, not a multiprocessing child:
    the server's sibling processes are daemonic, and those may not have multiprocessing children."""

    def __init__(self) -> None:
        mine, theirs = socket.socketpair()
        self.process = subprocess.Popen(
            [sys.executable, "-m", "app.mechanism_workers", str(theirs.fileno()), str(os.getpid())],
            pass_fds=(theirs.fileno(),), stdin=subprocess.DEVNULL)
        theirs.close()
        self._connection = Connection(mine.detach())
        self._lock = threading.Lock()
        self.users = 0

    @property
    def alive(self) -> bool:
        return self.process.poll() is None

    def run(self, mechanism: Mechanism, t_end: float, samples: int, q0, qdot0, t_start: float, method: str,
            stabilization: str, rtol: float = 1e-10, integrator: str = "DOP853",
            step: float | None = None, baumgarte: tuple[float, float] | None = None,
            max_steps: int | None = None, continuing: bool = False, coordinates: str = "maximal",
            rotations: str = "relative") -> Trajectory:
        request = (mechanism.model_dump_json(), float(t_end), int(samples),
                   None if q0 is None else np.asarray(q0, dtype=float),
                   None if qdot0 is None else np.asarray(qdot0, dtype=float), float(t_start), method, stabilization,
                   float(rtol), integrator, None if step is None else float(step),
                   None if baumgarte is None else (float(baumgarte[0]), float(baumgarte[1])),
                   None if max_steps is None else int(max_steps), bool(continuing), str(coordinates), str(rotations))
        with self._lock:
            try:
                self._connection.send(request)
                ok, value = self._connection.recv()
            except (EOFError, OSError, BrokenPipeError):
                raise LinkageError("the simulation's worker process stopped; press Reset to go on with a new "
                                   "one") from None
        if ok:
            return value
        raise value

    def stop(self) -> None:
        self.ask_to_stop()
        self.wait_stopped()

    def ask_to_stop(self) -> None:
        """Ask it to finish after its chunk in hand, without waiting (a pool asks all, then waits)."""
        try:
            with self._lock:
                self._connection.send(None)  # asks it to finish
        except (OSError, ValueError):  # its end is closed: it has finished already, the wait below returns
            self.process.poll()

    def wait_stopped(self) -> None:
        """Wait for it to finish (2 s), else kill it."""
        try:
            self.process.wait(2.0)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait(2.0)
        self._connection.close()


class WorkerPool:
    """Workers of one server process, started on first use; each session holds one (:meth:`acquire`)."""

    def __init__(self, count: int | None = None) -> None:
        self.count = worker_count() if count is None else count
        self._lock = threading.Lock()
        self.workers: list[Worker] = []

    def acquire(self) -> Worker | None:
        """The least used live worker (a new one while fewer than ``count`` run); None: compute in-process."""
        if self.count <= 0:
            return None
        with self._lock:
            for worker in [w for w in self.workers if not w.alive]:  # replace the dead
                self.workers.remove(worker)
            if len(self.workers) < self.count and all(w.users > 0 for w in self.workers):
                self.workers.append(Worker())
            worker = min(self.workers, key=lambda w: w.users)
            worker.users += 1
            return worker

    def release(self, worker: Worker | None) -> None:
        if worker is None:
            return
        with self._lock:
            worker.users = max(0, worker.users - 1)

    def stop(self) -> None:
        with self._lock:
            workers, self.workers = self.workers, []
        for worker in workers:  # all asked first: each may finish a chunk, and one after another they took seconds
            worker.ask_to_stop()
        for worker in workers:
            worker.wait_stopped()

    def stop_idle(self) -> None:
        """Stop the workers no session holds (a command that served its one session is done with them)."""
        with self._lock:
            idle = [w for w in self.workers if w.users == 0]
            self.workers = [w for w in self.workers if w.users > 0]
        for worker in idle:
            worker.stop()


POOL = WorkerPool()


if __name__ == "__main__":  # a worker: serve the server process that started it, on the socket it passed
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl+C reaches the whole group: the server decides
    signal.signal(signal.SIGHUP, signal.SIG_IGN)  # so does a closed terminal
    if len(sys.argv) > 2:
        # a worker ends with its server, even one killed in the middle of a chunk (the socket's end is seen
        # only between chunks). Not the kernel's PR_SET_PDEATHSIG: its "parent" is the player thread that
        # started the worker, which ends with its session while the worker serves others.
        from app.lifetime import watch_parent  # noqa: PLC0415 - the worker's own import

        watch_parent(int(sys.argv[2]))
    _serve(Connection(int(sys.argv[1])))
