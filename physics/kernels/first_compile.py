"""One line before a kernel's first compilation, so that an installation's first run is not silent.

numba compiles an integrator on its first call with these argument types and keeps the machine code in the
private cache (:mod:`physics.kernels.disk_cache`); every later run loads it at once. That first compilation
takes seconds (``COMPILE_SECONDS``), so a command, a notebook or the app says so first, through
:mod:`physics.notices` (``physics.kernels`` at WARNING: a handler can filter it like every other notice).

Whether a call compiles is read from numba's own state, never guessed: an overload already in memory, or an
entry for exactly these argument types in the cache's index (read through the same authenticated reader numba
then uses). At most one line per process: the rest of a first run's compilations are part of the same wait.

What is generated as LLVM IR and compiled with llvmlite in every process (the RK45 and DOP853 drivers of a run
without projection or Baumgarte terms, the samples' solve: :mod:`physics.codegen.native_integrators`,
:mod:`physics.codegen.native_samples`) takes well under a second and says nothing: the line is said only where a
numba kernel is about to compile.
"""

from __future__ import annotations

import logging
import threading
import time

from ..notices import notify

# Seconds of one empty-cache compilation with everything it calls, measured on the project's 2-core machine at
# load average 2 (BENCHMARKS.md, "First run"): what the line says to expect. Kernels not measured get no figure.
COMPILE_SECONDS = {"RK45": 20, "DOP853": 20}  # one driver for both (physics.kernels.explicit_rk)
LOGGER = "physics.kernels"
_lock = threading.Lock()
_announced: list[str] = []
_checked: set = set()  # kernels whose first call was looked at


def will_compile(dispatcher, args: tuple) -> bool:
    """True when ``dispatcher(*args)`` compiles: no overload for these types in memory, none in the cache."""
    argtypes = tuple(dispatcher.typeof_pyval(arg) for arg in args)
    if argtypes in dispatcher.overloads:
        return False
    cache = dispatcher._cache
    try:
        key = cache._index_key(argtypes, dispatcher.targetctx.codegen())
        return key not in cache._cache_file._load_index()
    except Exception:  # noqa: BLE001 - no readable index (numba's NullCache, a discarded file): it compiles
        return True


def compile_line(what: str) -> str:
    seconds = COMPILE_SECONDS.get(what)
    about = f" (about {seconds} s)" if seconds else ""
    return (f"linkage-lab: compiling the {what} integrator once for this installation{about}; "
            "later runs start at once")


def done_line(what: str, seconds: float) -> str:
    return f"linkage-lab: compiled the {what} integrator in {seconds:.1f} s"


def announce(dispatcher, args: tuple, what: str) -> bool:
    """The one line, before the call that compiles ``what`` (nothing if it is cached or was said already).
    Returns whether it was said."""
    if _announced or dispatcher in _checked:  # once per kernel: an ensemble calls its step thousands of times
        return False
    with _lock:
        _checked.add(dispatcher)
        if _announced or not will_compile(dispatcher, args):
            return False
        _announced.append(what)
    notify(compile_line(what), LOGGER)
    return True


def call_announced(kernel, arguments: tuple, what: str):
    """``kernel(*arguments)`` after :func:`announce`; when the line was said, a record at INFO once the call has
    compiled and returned (:func:`done_line`), so that whoever showed the line (the app's notice) can take it
    down. The command line prints WARNING and above only (:class:`physics.notices.StderrLines`): its one line
    stays the only one."""
    said = announce(kernel, arguments, what)
    start = time.perf_counter()
    try:
        return kernel(*arguments)
    finally:
        if said:
            logging.getLogger(LOGGER).info(done_line(what, time.perf_counter() - start))
