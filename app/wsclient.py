"""A minimal viser websocket client, speaking the same protocol as the browser, for tests and the load test.

viser's wire format (viser/infra/_infra.py, 1.1.1): the client connects with subprotocol
``viser-v<version>`` and sends msgpack dicts with a ``type`` key; the server is said to be connected once it
receives the first ``ViewerCameraMessage``. Each server frame is
``[8 B inner length][8 B compressed length][zstd(msgpack {"messages": [...], ...})][aligned binary buffers]``.
This client decodes the msgpack part only (binary buffers hold arrays it does not need) and counts messages,
in particular the pose updates of scene nodes.

Run as a module it is the load generator: ``python -m app.wsclient URL --clients 30 --seconds 60`` prints
one JSON object with per-client counts. (Used by ``python -m app.bench`` and tests/app; not by the served app.)
"""

from __future__ import annotations

import argparse
import asyncio
import collections
import contextlib
import json
import sys
import threading
import time

import msgspec
import viser
import websockets
import zstandard
from websockets.typing import Subprotocol

POSE_PROPS = ("batched_positions", "batched_wxyzs")  # what moves the batched parts of a mechanism (app/scene.py)
BARS = "/linkage/bars"


def moves_parts(message: dict) -> bool:
    """True for a message that moves the instances of a batched node (a frame of a mechanism)."""
    return message.get("type") == "SceneNodeUpdateMessage" and any(
        prop in (message.get("updates") or {}) for prop in POSE_PROPS
    )


def moves_positions(message: dict) -> bool:
    """True for a message that sets a batched node's instance positions."""
    return message.get("type") == "SceneNodeUpdateMessage" and "batched_positions" in (message.get("updates") or {})


def camera_message() -> bytes:
    return msgspec.msgpack.encode(
        {
            "type": "ViewerCameraMessage",
            "wxyz": (1.0, 0.0, 0.0, 0.0),
            "position": (0.0, -6.0, 1.0),
            "fov": 1.3,
            "near": 0.01,
            "far": 1000.0,
            "image_height": 720,
            "image_width": 1280,
            "look_at": (0.0, 0.0, 0.0),
            "up_direction": (0.0, 0.0, 1.0),
        }
    )


def decode_frame(raw: bytes, decompressor: zstandard.ZstdDecompressor) -> list[dict]:
    return msgspec.msgpack.decode(frame_payload(raw, decompressor)[0])["messages"]


def frame_payload(raw: bytes, decompressor: zstandard.ZstdDecompressor) -> tuple[bytes, bytes]:
    """A server frame's msgpack part (decompressed) and its binary buffers: every byte the frame carries."""
    inner_length = int.from_bytes(raw[0:8], "little")
    compressed_length = int.from_bytes(raw[8:16], "little")
    inner = decompressor.decompress(raw[16 : 16 + compressed_length], max_output_size=inner_length)
    return inner, raw[16 + compressed_length :]


class Counts:
    """What one client received."""

    def __init__(self) -> None:
        self.frames = 0
        self.messages = 0
        self.by_type: collections.Counter = collections.Counter()
        self.pose_updates: collections.Counter = collections.Counter()  # node name -> messages that moved its parts
        self.position_updates: collections.Counter = collections.Counter()  # node name -> instance position updates
        self.first_pose_time: float | None = None
        self.last_pose_time: float | None = None
        self.bytes = 0
        self.notifications: list[tuple[float, str]] = []  # (perf_counter, title) of notifications shown
        self.watch = BARS
        self.watched: collections.deque = collections.deque(maxlen=4096)  # (perf_counter, message) of ``watch``
        self.gui_updates: collections.deque = collections.deque(maxlen=4096)  # (uuid, updates) of control updates
        self.payloads: list[bytes] | None = None  # every frame's bytes, decompressed, when a test sets a list

    def add(self, messages: list[dict], nbytes: int) -> None:
        self.frames += 1
        self.bytes += nbytes
        for message in messages:
            kind = message.get("type", "?")
            self.messages += 1
            self.by_type[kind] += 1
            if kind == "NotificationShowMessage":
                props = message.get("props") or {}
                self.notifications.append((time.perf_counter(), str(props.get("title", ""))))
            if kind == "GuiUpdateMessage":
                self.gui_updates.append((message.get("uuid"), message.get("updates") or {}))
            if moves_parts(message):
                name = message.get("name", "?")
                self.pose_updates[name] += 1
                if moves_positions(message):
                    self.position_updates[name] += 1
                now = time.perf_counter()
                if name == self.watch:
                    self.watched.append((now, message))
                if self.first_pose_time is None:
                    self.first_pose_time = now
                self.last_pose_time = now

    def bar_updates(self, name: str = BARS) -> int:
        """Position updates of a mechanism's bars received: one per displayed frame in which they moved."""
        return self.position_updates.get(name, 0)


async def run_client(
    url: str, seconds: float, counts: Counts, stop: asyncio.Event | None = None, outbox: asyncio.Queue | None = None
) -> None:
    ws_url = url.replace("http://", "ws://")
    protocol = f"viser-v{viser.__version__}"
    decompressor = zstandard.ZstdDecompressor()
    async with websockets.connect(
        ws_url, subprotocols=[Subprotocol(protocol)], max_size=None, compression=None, open_timeout=60
    ) as ws:
        await ws.send(camera_message())
        deadline = time.perf_counter() + seconds
        while time.perf_counter() < deadline and not (stop is not None and stop.is_set()):
            while outbox is not None and not outbox.empty():
                await ws.send(outbox.get_nowait())
            try:
                raw = await asyncio.wait_for(ws.recv(), timeout=min(0.2, max(0.01, deadline - time.perf_counter())))
            except asyncio.TimeoutError:
                continue
            if isinstance(raw, bytes):
                inner, buffers = frame_payload(raw, decompressor)
                counts.add(msgspec.msgpack.decode(inner)["messages"], len(raw))
                if counts.payloads is not None:
                    counts.payloads.append(inner + buffers)


async def _load(url: str, clients: int, seconds: float, early: int, early_seconds: float) -> dict:
    counts = [Counts() for _ in range(clients)]
    tasks = []
    for i in range(clients):
        duration = early_seconds if i < early else seconds
        tasks.append(asyncio.create_task(run_client(url, duration, counts[i])))
        await asyncio.sleep(0.05)  # browsers do not all arrive in the same millisecond
    started = time.perf_counter()
    await asyncio.gather(*tasks)
    return {
        "clients": clients,
        "seconds": seconds,
        "elapsed": time.perf_counter() - started,
        "per_client": [
            {
                "frames": c.frames,
                "messages": c.messages,
                "bytes": c.bytes,
                "bar_updates": c.bar_updates(),
                "pose_span": (c.last_pose_time - c.first_pose_time)
                if c.first_pose_time is not None and c.last_pose_time is not None else 0.0,
                "duration": early_seconds if i < early else seconds,
            }
            for i, c in enumerate(counts)
        ],
    }


class BackgroundClient:
    """One websocket client in its own thread and event loop, open until :meth:`close` (a browser stand-in)."""

    def __init__(self, url: str, counts: Counts | None = None) -> None:
        self.url = url
        self.counts = counts if counts is not None else Counts()
        self._ready = threading.Event()
        self._loop = asyncio.new_event_loop()
        self._stop: asyncio.Event | None = None
        self._outbox: asyncio.Queue | None = None
        self.error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, daemon=True, name="ws-client")
        self._thread.start()
        self._ready.wait(5)

    def _run(self) -> None:
        asyncio.set_event_loop(self._loop)

        async def main():
            self._stop = asyncio.Event()
            self._outbox = asyncio.Queue()
            self._ready.set()
            await run_client(self.url, 1e9, self.counts, self._stop, self._outbox)

        try:
            self._loop.run_until_complete(main())
        except BaseException as error:  # looked at by whoever owns the client
            self.error = error
            self._ready.set()

    def send_value(self, uuid: str, value) -> None:
        """Send a control update as this client, as a browser (or a hostile script in its page) would."""
        self.send(gui_update_message(uuid, value))

    def send(self, raw: bytes) -> None:
        """Send any encoded message (:func:`encode`) as this client."""
        outbox = self._outbox
        assert outbox is not None, "the client is not running"
        self._loop.call_soon_threadsafe(outbox.put_nowait, raw)

    def close(self) -> None:
        if self._stop is not None:
            with contextlib.suppress(RuntimeError):  # raised only by a loop that has already finished
                self._loop.call_soon_threadsafe(self._stop.set)
        self._thread.join(5)

    def wait_for(self, predicate, timeout: float = 120.0) -> bool:
        deadline = time.perf_counter() + timeout
        while time.perf_counter() < deadline:
            if predicate(self.counts):
                return True
            time.sleep(0.005)
        return False


def gui_update_message(uuid: str, value) -> bytes:
    """What a browser sends when a control changes; a test sends any value a hostile client could."""
    return encode({"type": "GuiUpdateMessage", "uuid": uuid, "updates": {"value": value}})


def encode(message: dict) -> bytes:
    """Any message of viser's protocol (a dict with its ``type``), as a browser's websocket sends it."""
    return msgspec.msgpack.encode(message)


def upload_messages(uuid: str, name: str, content: bytes, transfer: str = "t1",
                    part_bytes: int = 512 * 1024) -> list[bytes]:
    """What a browser sends to upload ``content`` through the upload button ``uuid`` (viser's UploadButton)."""
    parts = [content[at : at + part_bytes] for at in range(0, len(content), part_bytes)]
    start = {"type": "FileTransferStartUpload", "source_component_uuid": uuid, "transfer_uuid": transfer,
             "filename": name, "mime_type": "application/octet-stream", "part_count": len(parts),
             "size_bytes": len(content)}
    return [encode(start)] + [
        encode({"type": "FileTransferPart", "source_component_uuid": uuid, "transfer_uuid": transfer,
                "part_index": index, "content": part}) for index, part in enumerate(parts)]


async def _send_raw(url: str, messages: list[bytes], pause: float) -> None:
    ws_url = url.replace("http://", "ws://")
    async with websockets.connect(
        ws_url, subprotocols=[Subprotocol(f"viser-v{viser.__version__}")], max_size=None, compression=None, open_timeout=60
    ) as ws:
        await ws.send(camera_message())
        for raw in messages:
            await ws.send(raw)
            if pause:
                await asyncio.sleep(pause)
        if pause:
            await asyncio.sleep(pause)


def send_values(url: str, updates: list[tuple[str, object]], pause: float = 0.05) -> None:
    """Connect as a client of its own, send ``(control uuid, value)`` pairs as GUI updates, disconnect.

    Runs in a thread of its own, so that it works beside another event loop (playwright's, in tests)."""
    send_messages(url, [gui_update_message(uuid, value) for uuid, value in updates], pause)


def send_messages(url: str, messages: list[bytes], pause: float = 0.05) -> None:
    """Connect as a client of its own, send encoded messages (:func:`encode`), disconnect; with ``pause``
    0 it closes at once after the last one (a browser that leaves mid-action)."""
    errors: list[BaseException] = []

    def run() -> None:
        try:
            asyncio.run(_send_raw(url, messages, pause))
        except BaseException as error:  # handed to the caller below
            errors.append(error)

    thread = threading.Thread(target=run, name="ws-sender", daemon=True)
    thread.start()
    thread.join(120)
    if errors:
        raise errors[0]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("url")
    parser.add_argument("--clients", type=int, default=30)
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--early", type=int, default=0, help="this many clients disconnect after --early-seconds")
    parser.add_argument("--early-seconds", type=float, default=10.0)
    args = parser.parse_args(argv)
    result = asyncio.run(_load(args.url, args.clients, args.seconds, args.early, args.early_seconds))
    json.dump(result, sys.stdout)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
