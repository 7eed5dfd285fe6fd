"""Messages no browser sends are dropped where viser reads them, with one log line, never a traceback.

Why: viser decodes each websocket message into its message class and hands it to its handlers without
checking the fields' types. A hostile client's malformed message ended in a traceback in the server's log (and
a bare ``KeyError`` or decoding error closed the connection with one): a message that does not decode, an
unknown type, a missing field, a control id that is a list (``unhashable type``), a NaN or infinite number for
an integer slider (viser's ``int(value)``). :func:`install` puts a check in front of the decoding: what a
browser could not have sent is dropped there (logged once per kind, one line), what it could goes on as before.

Like app/viser_compat.py this reads one private part of viser (``Message.deserialize`` of ``viser._messages``)
and only for the viser versions in ``viser_compat.TESTED_MINORS``; elsewhere nothing is installed.
"""

from __future__ import annotations

import math
import threading
from typing import Any

from .logs import log_once
from .viser_compat import VERSION_TESTED

try:
    from viser import _messages as _wire
except ImportError:  # pragma: no cover - another viser layout
    _wire = None  # type: ignore[assignment]

_lock = threading.Lock()
_installed = False
dropped = 0  # messages dropped since the process started (tests read it)


def _finite_numbers(value: object, depth: int = 0) -> bool:
    """No NaN or infinity anywhere in ``value`` (a browser's controls never send one)."""
    if isinstance(value, float):
        return math.isfinite(value)
    if depth < 4 and isinstance(value, (list, tuple)):
        return all(_finite_numbers(item, depth + 1) for item in value)
    if depth < 4 and isinstance(value, dict):
        return all(_finite_numbers(item, depth + 1) for item in value.values())
    return True


def problem(message: object) -> str | None:
    """Why a decoded message cannot have come from viser's browser client (None when it can)."""
    if _wire is None:
        return None
    if isinstance(message, _wire.GuiUpdateMessage):
        if not isinstance(message.uuid, str):
            return "a control update whose id is not text"
        if not isinstance(message.updates, dict):
            return "a control update without a table of values"
        if not _finite_numbers(message.updates):
            return "a control update with a number that is not finite"
    uuid = getattr(message, "uuid", "")
    if not isinstance(uuid, str):
        return f"a {type(message).__name__} whose id is not text"
    return None


def _drop(kind: str, reason: str) -> None:
    global dropped
    dropped += 1
    log_once(f"wire_guard:{kind}", "dropped a message no browser sends (%s); logged once", reason)


def install() -> bool:
    """Check every message a client sends before viser's handlers see it (idempotent; False when this viser
    has another shape, and then viser's own handling stays)."""
    global _installed
    with _lock:
        if _installed:
            return True
        base = getattr(_wire, "Message", None)
        original = getattr(base, "deserialize", None) if base is not None else None
        if not VERSION_TESTED or original is None:
            log_once("wire_guard:missing", "cannot check clients' messages before viser reads them")
            return False
        decode = original.__func__  # a classmethod

        def deserialize(cls, raw: bytes) -> Any:
            try:
                message = decode(cls, raw)
            except Exception as error:  # the wire's boundary: a message that does not decode is dropped
                _drop(f"decode:{type(error).__name__}", f"{type(error).__name__}: {str(error)[:80]}")
                return None  # viser's handlers look a message up by its type: None reaches none of them
            reason = problem(message)
            if reason is not None:
                _drop(reason, reason)
                return None
            return message

        setattr(base, "deserialize", classmethod(deserialize))
        _installed = True
        return True
