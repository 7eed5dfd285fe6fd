"""One log line per kind of problem: what the app does instead of ``except ...: pass``.

Why: an error that is expected and harmless (a node of a browser that has just left, a notification of a
closed tab) must not stop a frame, but hiding it completely would also hide it the day it starts to matter.
:func:`log_once` writes it to the ``app`` logger the first time it happens in a process, and only then.
"""

from __future__ import annotations

import logging
import threading

LOG = logging.getLogger("app")
_seen: set[str] = set()
_lock = threading.Lock()


def log_once(key: str, text: str, *args: object) -> bool:
    """Log ``text % args`` as a warning if ``key`` was never logged before; True when it was written now."""
    with _lock:
        if key in _seen:
            return False
        _seen.add(key)
    LOG.warning(text, *args)
    return True


def quietly(action, what: str) -> bool:
    """Run ``action()``; an exception is logged once per ``what`` and its type. True when it ran cleanly."""
    try:
        action()
    except Exception as error:  # noqa: BLE001 - the caller said this may fail harmlessly; logged once
        log_once(f"{what}:{type(error).__name__}", "%s failed: %s: %s", what, type(error).__name__, error)
        return False
    return True
