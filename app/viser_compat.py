"""The one door to viser's private internals, open only for the viser versions it was written against.

Why private parts at all: moving a node through the public setters costs an ``np.allclose`` per call (80 µs,
the largest cost of a frame with 30 sessions), and viser has no public way to ask whether a browser's
connection is already closed. Everything else in app/ uses viser's public API only.

Each helper works on any viser: on a version outside :data:`TESTED_MINORS`, or when an internal is missing,
it takes the public (slower) route and logs one warning saying so. ``tests/app/test_viser_compat.py`` fails
when the installed viser makes the fast path fall back, so an upgrade cannot slow the app down silently.
"""

from __future__ import annotations

from typing import Any, Callable

import viser

from .logs import log_once

TESTED_MINORS = ((1, 1),)  # (major, minor) of the viser releases these internals were read from


def _version() -> tuple[int, int]:
    try:
        major, minor = (int(part) for part in viser.__version__.split(".")[:2])
    except ValueError:
        return (0, 0)
    return (major, minor)


VERSION_TESTED = _version() in TESTED_MINORS

try:  # the wire messages the public pose setters send
    from viser import _messages as _wire
except ImportError:  # pragma: no cover - another viser layout
    _wire = None  # type: ignore[assignment]
SetPositionMessage: Any = getattr(_wire, "SetPositionMessage", None)
SetOrientationMessage: Any = getattr(_wire, "SetOrientationMessage", None)


def warn_once(key: str, text: str) -> None:
    """One log line per kind of fallback for the life of the process (never once per frame)."""
    tested = ", ".join(f"{a}.{b}.x" for a, b in TESTED_MINORS)
    log_once(f"viser_compat:{key}", "%s (viser %s; tested with %s)", text, viser.__version__, tested)


def fallbacks() -> list[str]:
    """Why the fast paths are off with the installed viser (empty when all of them are on)."""
    reasons = []
    if not VERSION_TESTED:
        reasons.append(f"viser {viser.__version__} is not a tested version")
    if SetPositionMessage is None:
        reasons.append("viser._messages.SetPositionMessage is missing")
    return reasons


FAST_PATH = not fallbacks()


# ------------------------------------------------------------------------------------------ nodes
def _scene_queue(handle) -> Callable[[Any], None] | None:
    impl = getattr(handle, "_impl", None)
    api = getattr(impl, "api", None)
    return getattr(api, "_queue_scene_message", None)


def fast_pose_available(handle) -> bool:
    """True when :func:`move_node` takes the fast path for this handle."""
    return FAST_PATH and _scene_queue(handle) is not None


def move_node(handle, position: tuple | None, wxyz: tuple | None) -> None:
    """Move a scene node: the same messages as ``handle.position = ...`` / ``handle.wxyz = ...``, without their
    per-call ``np.allclose``; a value equal to the last one sent is skipped, as the public setters do."""
    queue = _scene_queue(handle) if FAST_PATH else None
    if queue is None:
        warn_once("pose", "scene nodes move through viser's public setters (slower per frame)")
        if position is not None:
            handle.position = position
        if wxyz is not None:
            handle.wxyz = wxyz
        return
    impl = handle._impl
    if position is not None and tuple(impl.position) != position:
        impl.position[:] = position
        queue(SetPositionMessage(impl.name, position))
    if wxyz is not None and tuple(impl.wxyz) != wxyz:
        impl.wxyz[:] = wxyz
        queue(SetOrientationMessage(impl.name, wxyz))


# ------------------------------------------------------------------------------------------ clients
def connection_open(client) -> bool:
    """False once a browser's connection has closed (viser closes its buffer before telling the server), so a
    departing session stops sending frames at once. True when it cannot tell (the session's close() decides)."""
    connection = getattr(client, "_websock_connection", None) if VERSION_TESTED else None
    buffer_of = getattr(connection, "get_message_buffer", None)
    if buffer_of is None:
        warn_once("connection", "cannot see a browser's connection close early; relying on the disconnect callback")
        return True
    return not buffer_of().done


def client_caught_up(client) -> bool:
    """True when nothing queued for ``client`` (a ``viser.ClientHandle``) waits to be sent (app/delivery.py).

    Reads viser's per-client message buffer (messages leave it when taken into a window for sending); a viser
    without it, or a closed connection, counts as caught up so that a session never stops animating on it."""
    connection = getattr(client, "_websock_connection", None) if VERSION_TESTED else None
    buffer_of = getattr(connection, "get_message_buffer", None)
    if buffer_of is None:
        warn_once("delivery", "cannot see what waits to be sent to a browser; rendering every frame")
        return True
    buffer = buffer_of()
    return bool(buffer.done or not buffer.message_from_id)


# ------------------------------------------------------------------------------------------ tests and tools
def control_id(handle) -> str:
    """The id by which viser's wire protocol addresses a GUI control (a websocket client sets it by this)."""
    return handle._impl.uuid


def camera_callbacks(camera) -> list[Callable]:
    """The callbacks registered with ``camera.on_update`` (to replay a browser's camera report in a test)."""
    return list(camera._state.camera_cb)
