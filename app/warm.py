"""Loading compiled equations once per process, and warming up before the first browser arrives.

``physics.load_run_systems`` returns ready code from the disk cache (or derives and compiles it on a miss): the
chain written as a mechanism on the general engine, as every run takes it; the first simulation in a process
also loads numba's cached machine code. Both take a noticeable fraction of a second warm and a few seconds cold
(half a minute on an installation's very first run, which compiles the integrators), so the server starts them
in a background thread at launch, before it even imports viser, and sessions that need the same system wait for
that load instead of repeating it.
Imports only physics (no viser), so ``python -m app`` can start warming first.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import threading
import time
from typing import Callable

import physics

from . import lifetime
from .logs import log_once
from .parameters import SessionParameters

# A build in a worker process that takes longer than this is left to finish in the server instead.
PREBUILD_TIMEOUT_SECONDS = 600.0
# How often a waiting build looks whether it is still wanted (a newer edit cancels it): well under the second
# within which a session resumes after its last edit.
CANCEL_POLL_SECONDS = 0.05


class Cancelled(Exception):
    """A build or warm-up nobody wants any more (the session has a newer request): its worker was killed."""

# (method, links, pinned) of the structures whose systems are loaded
_loaded: set[tuple[str, int, bool]] = set()
_locks: dict[tuple, threading.Lock] = {}
_guard = threading.Lock()


def is_loaded(method: str, n: int, pinned: bool) -> bool:
    with _guard:
        return (method, n, pinned) in _loaded


def _once(done: set, key: tuple, action: Callable[[], object]) -> None:
    """Run ``action`` once per ``key`` in this process; concurrent callers for the same key wait for it."""
    with _guard:
        if key in done:
            return
        lock = _locks.setdefault(key, threading.Lock())
    with lock:
        with _guard:
            if key in done:
                return
        action()
        with _guard:
            done.add(key)


def _not_cancelled() -> bool:
    return False


def ensure_loaded(chain, method: str, damping: float = 0.0) -> None:
    """Load (or derive) the compiled systems a run of ``method`` on such a chain reads, once per structure
    (physics.load_run_systems: the chain written as a mechanism); concurrent callers for the same systems wait
    for it."""
    _once(_loaded, (method, chain.n, chain.pinned),
          lambda: physics.load_run_systems(chain, method, damping))


_ready: set[tuple] = set()


def _ready_key(chain, settings) -> tuple:
    return (settings.method, chain.n, chain.pinned, settings.integrator, settings.backend)


def is_ready(chain, settings) -> bool:
    with _guard:
        return _ready_key(chain, settings) in _ready


def ensure_ready(chain, settings, theta0, omega0, cancelled: Callable[[], bool] = _not_cancelled) -> None:
    """Loaded code *and* one short simulation done with this method and integrator in this process: numba
    compiles (cold cache) or loads (warm) its integrators on their first call, which is the slow part.

    ``cancelled()`` turning true while a worker builds kills the worker and raises :class:`Cancelled` (a burst
    of edits builds only what the last one needs); nothing is marked ready then."""

    def warm() -> None:
        build_outside(settings.method, chain.n, chain.pinned, settings.integrator, cancelled)
        if cancelled():
            raise Cancelled(f"{settings.method}, {chain.n} bars: no longer wanted")
        ensure_loaded(chain, settings.method, settings.damping)
        try:
            physics.simulate(chain, theta0, omega0, settings.model_copy(update={"t_end": 0.02, "samples": 2}))
        except ValueError as error:  # an invalid start: the session's own run reports it with a notice
            log_once(f"warm:{type(error).__name__}", "warming skipped one start: %s", error)

    _once(_ready, _ready_key(chain, settings), warm)


def build_outside(method: str, n: int, pinned: bool, integrator: str,
                  cancelled: Callable[[], bool] = _not_cancelled) -> bool:
    """Derive and compile a mechanism the cache lacks in a worker process (physics/codegen/prebuild_worker.py), so
    the server's interpreter (and every other session's animation) never waits on sympy or numba's compiler.
    True if a worker built it; False if nothing was missing or the worker failed (the caller then builds
    in-process, as before: slower for the others, still correct). When ``cancelled()`` turns true the worker
    is killed at once (the cache's atomic writes leave no half file) and :class:`Cancelled` is raised."""
    if not physics.code_missing(method, n, pinned):
        return False
    command = [sys.executable, "-m", "physics.codegen.prebuild_worker", method, str(int(n)),
               "pinned" if pinned else "open", integrator]
    errors = tempfile.TemporaryFile(mode="w+")  # a file, not a pipe: a chatty worker never blocks on it
    try:
        worker = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=errors, text=True,
                                  env=dict(os.environ))
    except OSError as error:
        errors.close()
        print(f"linkage-lab: worker build failed ({error}); building in the server", file=sys.stderr)
        return False
    deadline = time.monotonic() + PREBUILD_TIMEOUT_SECONDS
    try:
        while True:
            try:
                worker.wait(CANCEL_POLL_SECONDS)
                break
            except subprocess.TimeoutExpired:  # still building: see whether it is still wanted
                still_building = True
            if still_building and cancelled():
                raise Cancelled(f"{method}, {n} bars: build no longer wanted")
            if time.monotonic() > deadline:
                print(f"linkage-lab: worker build took over {PREBUILD_TIMEOUT_SECONDS:.0f} s; building in the "
                      "server", file=sys.stderr)
                return False
    finally:
        if worker.poll() is None:
            worker.kill()
        worker.wait()
        errors.seek(0)
        stderr = errors.read()
        errors.close()
    if worker.returncode != 0:
        if lifetime.stopping():  # the terminal's Ctrl+C reached the worker too: the server stops, builds nothing
            raise Cancelled(f"{method}, {n} bars: the server is stopping")
        reason = (stderr.strip().splitlines() or [f"exit {worker.returncode}"])[-1]
        print(f"linkage-lab: worker build failed ({reason}); building in the server", file=sys.stderr)
        return False
    return True


def warm_up(preset: str, links: int | None, method: str | None) -> None:
    """Load the start mechanism's code and run one tiny simulation (numba loads its cached integrators)."""
    try:
        params = SessionParameters.from_preset(preset, links=links, method=method)
        ensure_ready(params.chain, params.settings, params.theta0, params.omega0)
    except Cancelled:  # the server is stopping: nothing to warm, nothing to say
        return
    except Exception as error:  # an optimisation only: a session reports real problems itself
        print(f"linkage-lab: warm-up skipped: {error}", file=sys.stderr)


def start_warm_up(preset: str, links: int | None, method: str | None) -> threading.Thread:
    thread = threading.Thread(target=warm_up, args=(preset, links, method), name="warm-up", daemon=True)
    thread.start()
    return thread
