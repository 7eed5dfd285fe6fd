"""The end of a ``python -m physics`` process: its exit code, without the interpreter's teardown.

A finished command has nothing left to do but that teardown: freeing every module's objects one by one (sympy's
caches and classes after a derivation, numba's typing registries after any compiled run), about 0.3 s of CPU
after a new mechanism's first run and 0.1 s after a warm one. So once the command has returned its exit code,
its output is flushed and every exit handler is run (logging, the removal of a private temporary cache folder,
a coverage tool's report), and the process ends with that code at once. Anything unusual takes the ordinary way
out (:func:`sys.exit`): a thread still running (the interpreter waits for it) or output that cannot be flushed
(a closed pipe, reported as it always was).
"""

from __future__ import annotations

import atexit
import os
import sys
import threading


def other_threads_running() -> bool:
    """True while a thread other than this one that the interpreter would wait for at exit is still alive."""
    current = threading.current_thread()
    return any(thread.is_alive() and not thread.daemon and thread is not current for thread in threading.enumerate())


def exit_without_teardown(code: int) -> None:
    """End the process with ``code`` after flushing its output and running its exit handlers, skipping only
    the freeing of objects that the operating system reclaims anyway. Falls back to :func:`sys.exit`
    whenever that shortcut could lose anything."""
    if other_threads_running():
        sys.exit(code)
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except (OSError, ValueError):  # a closed pipe or stream: the ordinary exit reports it as it always did
        sys.exit(code)
    atexit._run_exitfuncs()
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except (OSError, ValueError):
        pass  # the handlers' own last words could not be written; the exit code still stands
    os._exit(code)
