"""The one door to viser's private internals, open only for the viser versions it was written against.

Why private parts at all: viser's public setters send one message per property, each value cast through its
type hint, where a frame of the mechanism needs a batched node's positions and orientations in one message (a
frame's cost is almost all per message); and viser has no public way to ask whether a browser's connection is
already closed. Everything else in app/ uses viser's public API only.

Each helper works on any viser: on a version outside :data:`TESTED_MINORS`, or when an internal is missing,
it takes the public (slower) route and logs one warning saying so. ``tests/app/test_viser_compat.py`` fails
when the installed viser makes the fast path fall back, so an upgrade cannot slow the app down silently.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import threading
from pathlib import Path
from typing import Any, Callable, Iterator

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

try:  # the wire message the public property setters send
    from viser import _messages as _wire
except ImportError:  # pragma: no cover - another viser layout
    _wire = None  # type: ignore[assignment]
SceneNodeUpdateMessage: Any = getattr(_wire, "SceneNodeUpdateMessage", None)
GuiUpdateMessage: Any = getattr(_wire, "GuiUpdateMessage", None)
FileTransferStartUpload: Any = getattr(_wire, "FileTransferStartUpload", None)
FileTransferPart: Any = getattr(_wire, "FileTransferPart", None)
ShareUrlRequest: Any = getattr(_wire, "ShareUrlRequest", None)
ShareUrlDisconnect: Any = getattr(_wire, "ShareUrlDisconnect", None)


def warn_once(key: str, text: str) -> None:
    """One log line per kind of fallback for the life of the process (never once per frame)."""
    tested = ", ".join(f"{a}.{b}.x" for a, b in TESTED_MINORS)
    log_once(f"viser_compat:{key}", "%s (viser %s; tested with %s)", text, viser.__version__, tested)


def fallbacks() -> list[str]:
    """Why the fast paths are off with the installed viser (empty when all of them are on)."""
    reasons = []
    if not VERSION_TESTED:
        reasons.append(f"viser {viser.__version__} is not a tested version")
    if SceneNodeUpdateMessage is None:
        reasons.append("viser._messages.SceneNodeUpdateMessage is missing")
    if GuiUpdateMessage is None:
        reasons.append("viser._messages.GuiUpdateMessage is missing")
    return reasons


FAST_PATH = not fallbacks()


# ------------------------------------------------------------------------------------------ nodes
def _scene_queue(handle) -> Callable[[Any], None] | None:
    impl = getattr(handle, "_impl", None)
    api = getattr(impl, "api", None)
    return getattr(api, "_queue_scene_message", None)


def fast_pose_available(handle) -> bool:
    """True when :func:`update_node_props` takes the fast path for this handle."""
    return FAST_PATH and _scene_queue(handle) is not None


def update_node_props(handle, updates: dict[str, Any]) -> None:
    """Set several properties of a scene node (e.g. a batched mesh's ``batched_positions`` and
    ``batched_wxyzs``) in one message, where the public setters send one message per property after casting
    each value through its type hint. The values must already have the wire types (float32 arrays)."""
    queue = _scene_queue(handle) if FAST_PATH else None
    if queue is None:
        warn_once("pose", "scene nodes move through viser's public setters (slower per frame)")
        for name, value in updates.items():
            setattr(handle, name, value)
        return
    impl = handle._impl
    for name, value in updates.items():
        setattr(impl.props, name, value)
    queue(SceneNodeUpdateMessage(impl.name, dict(updates)))


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


# ------------------------------------------------------------------------------------------ incoming values
SHOWN_VALUE_CHARS = 80  # a refused value is quoted in a notice up to this many characters (as commands.shown_value)


def _shown(value: object) -> str:
    text = repr(value)
    return text if len(text) <= SHOWN_VALUE_CHARS else text[: SHOWN_VALUE_CHARS - 1] + "…"


def _is_number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def update_problem(current: object, updates: object) -> str | None:
    """Why a browser's GUI update cannot be what a browser sends for a control whose value is ``current``
    (None when it can).

    viser casts an incoming value with the type of the control's value (``float(value)``) on its event loop:
    a hostile client's ``"abc"`` or ``null`` for a slider ended in a traceback there, before any callback of ours
    could refuse it. Browsers send only ``{"value": ...}``, a number for a slider or box, text for a dropdown,
    ``true`` for a button, a list for a vector; anything else is refused here."""
    if not isinstance(updates, dict) or set(updates) != {"value"}:
        names = sorted(str(name) for name in updates) if isinstance(updates, dict) else []
        return f"a browser sets only a control's value (got {_shown(names or updates)})"
    value = updates["value"]
    if isinstance(current, bool):
        ok = isinstance(value, bool)
        kind = "true or false"
    elif _is_number(current):
        ok = _is_number(value)
        kind = "a number"
    elif isinstance(current, str):
        ok = isinstance(value, str)
        kind = "text"
    elif isinstance(current, tuple):
        ok = (
            isinstance(value, (list, tuple))
            and len(value) == len(current)
            and all(_is_number(new) if _is_number(old) else type(new) is type(old) for old, new in zip(current, value))
        )
        kind = f"a list of {len(current)} values"
    else:
        return None  # a kind of control this app does not make: viser decides
    return None if ok else f"{_shown(value)} is not {kind}"


def check_gui_updates(
    gui,
    refuse: Callable[[Any, str], None],
    allowed: Callable[[int], bool] | None = None,
    refuse_sender: Callable[[int, Any], None] | None = None,
    open_to_all: Callable[[Any], bool] | None = None,
) -> bool:
    """Put :func:`update_problem` in front of viser's handler of a browser's control updates for ``gui`` (a
    ``GuiApi``): a value no browser would send is dropped and ``refuse(handle, reason)`` is called (the
    session's notice); an update from a browser for which ``allowed(client_id)`` is False (a viewer of a
    presenter's session) is dropped and ``refuse_sender(client_id, handle)`` is called, unless
    ``open_to_all(handle)`` (a button that only reads, for the sender's page alone: its callback tells the
    presenter from a viewer); every other update goes on to viser unchanged. False when this viser has another
    shape (then viser's own casting stays the only check)."""
    interface = getattr(gui, "_websock_interface", None) if VERSION_TESTED else None
    handlers = getattr(interface, "_incoming_handlers", {}).get(GuiUpdateMessage) if interface is not None else None
    original = getattr(gui, "_handle_gui_updates", None)
    controls = getattr(gui, "_gui_input_handle_from_uuid", None)
    installed = getattr(gui, "_linkage_lab_checker", None)  # a previous session's on this GUI (a switch)
    if installed is not None and handlers and installed in handlers:
        slot = handlers.index(installed)
    elif handlers and original is not None and original in handlers:
        slot = handlers.index(original)
    else:
        slot = None
    if slot is None or handlers is None or original is None or controls is None:
        warn_once("updates", "cannot check a browser's control values before viser casts them")
        return False

    async def checked(client_id, message) -> None:
        handle = controls.get(getattr(message, "uuid", None))
        if handle is None:
            return  # not one of this GUI's controls: viser would ignore it too
        if allowed is not None and not allowed(client_id) and not (open_to_all is not None and open_to_all(handle)):
            try:
                if refuse_sender is not None:
                    refuse_sender(client_id, handle)
            except Exception:  # the event loop's boundary
                log_once("viser_compat:refuse_sender", "could not tell a viewer that the presenter controls")
            return
        problem = update_problem(handle._impl.value, getattr(message, "updates", None))
        if problem is None:
            await original(client_id, message)
            return
        try:
            refuse(handle, problem)
        except Exception:  # the event loop's boundary: a refusal never raises into viser
            log_once("viser_compat:refuse", "could not show a refused control value")

    handlers[slot] = checked
    gui._linkage_lab_checker = checked
    guard_uploads(gui, refuse, allowed)  # an upload is a control's update too: bounded and checked alike
    return True


# ------------------------------------------------------------------------------------------ uploads
UPLOAD_LIMIT_BYTES = 1_000_000
"""The largest file any upload button of the app reads (a mechanism file; a setup file is at most 64 KiB)."""
UPLOAD_PART_BYTES = 512 * 1024  # viser's browser client sends a file in parts of this size (UploadButton.tsx)
UPLOADS_PER_CLIENT = 2  # transfers one browser may have in flight on one GUI


def upload_problem(size_bytes: object, part_count: object) -> str | None:
    """Why an announced upload is refused before a byte of it is kept, or None. A browser announces the size
    and the number of parts first; both are checked against the app's limit and viser's part size, so what a
    transfer can hold is bounded by its announcement."""
    if not isinstance(size_bytes, int) or isinstance(size_bytes, bool) or size_bytes < 0:
        return f"an upload announced a size of {_shown(size_bytes)}"
    if size_bytes > UPLOAD_LIMIT_BYTES:
        return (f"the file has {size_bytes:,} bytes; a file loaded here is at most {UPLOAD_LIMIT_BYTES:,} bytes "
                "(1 MB)")
    expected = -(-size_bytes // UPLOAD_PART_BYTES)
    if not isinstance(part_count, int) or isinstance(part_count, bool) or part_count != expected:
        return f"an upload of {size_bytes} bytes announced {_shown(part_count)} parts (a browser sends {expected})"
    return None


def _live_connection(gui, client_id: int):
    """The websocket connection of ``client_id`` on the server that owns ``gui`` (None when gone)."""
    owner = getattr(gui, "_owner", None)
    server = getattr(owner, "_viser_server", owner)
    websock = getattr(server, "_websock_server", None)
    return getattr(websock, "_live_connections", {}).get(client_id)


def _cut_off(gui, client_id: int, reason: str) -> None:
    """Close one browser's websocket (it sent what no browser sends); runs on viser's event loop."""
    connection = _live_connection(gui, client_id)
    if connection is not None:
        asyncio.get_running_loop().create_task(connection.close(1008, reason[:120]))
    log_once(f"viser_compat:cut_off:{reason[:40]}", "closed a browser's connection: %s", reason)


def guard_uploads(
    gui,
    refuse: Callable[[Any, str], None],
    allowed: Callable[[int], bool] | None = None,
) -> bool:
    """Put a bound in front of viser's upload handlers for ``gui`` (a ``GuiApi``). viser buffers the parts of
    an upload in memory with no limit of its own; here a transfer is refused when it is announced (a sender
    for which ``allowed`` is False, a size over :data:`UPLOAD_LIMIT_BYTES`, a part count no browser sends, or
    more than :data:`UPLOADS_PER_CLIENT` in flight), and a browser whose parts overrun what it announced is
    cut off and its transfer dropped. So the memory that uploads hold is bounded by the announcements this
    function let through. False when this viser has another shape."""
    interface = getattr(gui, "_websock_interface", None) if VERSION_TESTED else None
    handlers = getattr(interface, "_incoming_handlers", None) if interface is not None else None
    start = getattr(gui, "_handle_file_transfer_start", None)
    part = getattr(gui, "_handle_file_transfer_part", None)
    states = getattr(gui, "_current_file_upload_states", None)
    controls = getattr(gui, "_gui_input_handle_from_uuid", None)
    if getattr(gui, "_linkage_lab_uploads", None) is not None:
        gui._linkage_lab_uploads = (refuse, allowed)  # a switch: the guard stays, the new session answers
        return True
    starts = handlers.get(FileTransferStartUpload) if handlers is not None else None
    parts = handlers.get(FileTransferPart) if handlers is not None else None
    if (start is None or part is None or starts is None or parts is None or start not in starts
            or part not in parts or states is None or controls is None):
        warn_once("uploads", "cannot bound uploads before viser buffers them")
        return False

    def checked_start(client_id, message) -> None:
        refuse, allowed = gui._linkage_lab_uploads
        handle = controls.get(getattr(message, "source_component_uuid", None))
        if handle is None:
            return
        if allowed is not None and not allowed(client_id):
            return  # a viewer of a presenter's session: nothing of its file is kept
        problem = upload_problem(getattr(message, "size_bytes", None), getattr(message, "part_count", None))
        in_flight = sum(1 for state in list(states.values()) if state.get("client_id") == client_id)
        if problem is None and in_flight >= UPLOADS_PER_CLIENT:
            problem = f"at most {UPLOADS_PER_CLIENT} uploads at a time from one browser"
        if problem is None and start is not None:
            start(client_id, message)
            return
        try:
            refuse(handle, problem)
        except Exception:  # the event loop's boundary: a refusal never raises into viser
            log_once("viser_compat:refuse_upload", "could not show a refused upload")

    def checked_part(client_id, message) -> None:
        state = states.get(getattr(message, "transfer_uuid", None))
        if state is None:
            return
        content = getattr(message, "content", b"")
        index = getattr(message, "part_index", None)
        overrun = (state.get("client_id") != client_id or not isinstance(content, bytes)
                   or len(content) > UPLOAD_PART_BYTES
                   or state["transferred_bytes"] + len(content) > state["total_bytes"]
                   or not isinstance(index, int) or index in state["parts"])
        if overrun:
            states.pop(message.transfer_uuid, None)
            _cut_off(gui, client_id, "an upload sent more than it announced")
            return
        if part is not None:
            part(client_id, message)

    starts[starts.index(start)] = checked_start
    parts[parts.index(part)] = checked_part
    gui._linkage_lab_uploads = (refuse, allowed)
    return True


# ------------------------------------------------------------------------------------------ share tunnel
def refuse_share_tunnel(server) -> bool:
    """viser opens a public share tunnel (an outbound connection to its share host, publishing this server at
    a public address) when any client sends ``ShareUrlRequest``; hiding the share button does not stop a hostile
    client. Nothing a client sends may open an outbound connection: the handlers are removed and the method
    they call refuses. True when both are done (on any viser the method is replaced)."""

    def refused(*args, **kwargs) -> None:
        log_once("viser_compat:share", "a browser asked for viser's public share link; refused")

    server.request_share_url = refused
    server.disconnect_share_url = lambda *args, **kwargs: None
    websock = getattr(server, "_websock_server", None)
    handlers = getattr(websock, "_incoming_handlers", None) if VERSION_TESTED else None
    if handlers is None or ShareUrlRequest is None:
        warn_once("share", "cannot remove viser's share-link handlers; its share method is replaced")
        return False
    handlers.pop(ShareUrlRequest, None)
    handlers.pop(ShareUrlDisconnect, None)
    return True


def resend_value(client, handle) -> None:
    """Send ``handle``'s value in force to one browser only (``client``, a ``viser.ClientHandle``): puts back a
    control that a viewer moved in its own page although the change was not applied."""
    connection = getattr(client, "_websock_connection", None) if VERSION_TESTED else None
    if connection is None or GuiUpdateMessage is None:
        warn_once("resend", "cannot put one browser's control back")
        return
    connection.queue_message(GuiUpdateMessage(handle._impl.uuid, {"value": handle._impl.value}))


def connection_path(server, client_id: int) -> str | None:
    """The path of the address whose websocket ``client_id`` opened on ``server`` (a ``viser.ViserServer``):
    viser's client connects to its page's own address without the query (``/`` or ``/presenter-....html``).
    None when this viser has another shape."""
    websock = getattr(server, "_websock_server", None) if VERSION_TESTED else None
    connections = getattr(websock, "_live_connections", None) if websock is not None else None
    if connections is not None and client_id not in connections:
        return None  # the browser has left (its last messages may still be handled): no address
    request = getattr(connections.get(client_id) if connections is not None else None, "request", None)
    path = getattr(request, "path", None)
    if path is None:
        warn_once("path", "cannot see which address a browser opened; nobody can change a --shared session")
        return None
    return str(path).partition("?")[0]


# ------------------------------------------------------------------------------------------ the page
@contextlib.contextmanager
def serving_page_from(folder: Path | None) -> Iterator[bool]:
    """While a ``viser.ViserServer`` is constructed inside this block, its HTTP server serves the client from
    ``folder`` (app/page.py: viser's page with the loading screen) instead of viser's own build folder.

    viser takes the folder as a fixed argument of its ``infra.WebsockServer``; the block hands it ours. Yields
    False (and viser serves its own page) when there is no folder or this viser has another shape."""
    infra = getattr(viser, "infra", None)
    original = getattr(infra, "WebsockServer", None)
    if folder is None or original is None or not VERSION_TESTED:
        if folder is not None:
            warn_once("page", "cannot serve the page with the loading screen; viser's bare page shows until ready")
        yield False
        return

    class PageServer(original):  # type: ignore[misc, valid-type]
        def __init__(self, *args, **kwargs) -> None:
            kwargs["http_server_root"] = folder
            super().__init__(*args, **kwargs)

    setattr(infra, "WebsockServer", PageServer)
    try:
        yield True
    finally:
        setattr(infra, "WebsockServer", original)


# ------------------------------------------------------------------------------------------ clients' messages
# Messages no browser sends are dropped where viser reads them, with one log line, never a traceback.
#
# Why: viser decodes each websocket message into its message class and hands it to its handlers without
# checking the fields' types. A hostile client's malformed message ended in a traceback in the server's log (and
# a bare ``KeyError`` or decoding error closed the connection with one): a message that does not decode, an
# unknown type, a missing field, a control id that is a list (``unhashable type``), a NaN or infinite number for
# an integer slider (viser's ``int(value)``). :func:`install` puts a check in front of the decoding: what a
# browser could not have sent is dropped there (logged once per kind, one line), what it could goes on as before.
#
_messages_lock = threading.Lock()
_messages_guarded = False
dropped_messages = 0  # messages dropped since the process started (tests read it)


def _finite_numbers(value: object, depth: int = 0) -> bool:
    """No NaN or infinity anywhere in ``value`` (a browser's controls never send one)."""
    if isinstance(value, float):
        return math.isfinite(value)
    if depth < 4 and isinstance(value, (list, tuple)):
        return all(_finite_numbers(item, depth + 1) for item in value)
    if depth < 4 and isinstance(value, dict):
        return all(_finite_numbers(item, depth + 1) for item in value.values())
    return True


def message_problem(message: object) -> str | None:
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


def _drop_message(kind: str, reason: str) -> None:
    global dropped_messages
    dropped_messages += 1
    log_once(f"viser_compat:dropped:{kind}", "dropped a message no browser sends (%s); logged once", reason)


def guard_messages() -> bool:
    """Check every message a client sends before viser's handlers see it (idempotent; False when this viser
    has another shape, and then viser's own handling stays)."""
    global _messages_guarded
    with _messages_lock:
        if _messages_guarded:
            return True
        base = getattr(_wire, "Message", None)
        original = getattr(base, "deserialize", None) if base is not None else None
        if not VERSION_TESTED or original is None:
            log_once("viser_compat:messages", "cannot check clients' messages before viser reads them")
            return False
        decode = original.__func__  # a classmethod

        def deserialize(cls, raw: bytes) -> Any:
            try:
                message = decode(cls, raw)
            except Exception as error:  # the wire's boundary: a message that does not decode is dropped
                _drop_message(f"decode:{type(error).__name__}", f"{type(error).__name__}: {str(error)[:80]}")
                return None  # viser's handlers look a message up by its type: None reaches none of them
            reason = message_problem(message)
            if reason is not None:
                _drop_message(reason, reason)
                return None
            return message

        setattr(base, "deserialize", classmethod(deserialize))
        _messages_guarded = True
        return True


# ------------------------------------------------------------------------------------------ tests and tools
def control_id(handle) -> str:
    """The id by which viser's wire protocol addresses a GUI control (a websocket client sets it by this)."""
    return handle._impl.uuid


def camera_callbacks(camera) -> list[Callable]:
    """The callbacks registered with ``camera.on_update`` (to replay a browser's camera report in a test)."""
    return list(camera._state.camera_cb)
