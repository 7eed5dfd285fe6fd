"""A self-contained HTML page that replays a run without the server (viser's scene serializer).

viser records the scene messages of a server's shared scene and writes them, with its client, into one
HTML file (``StateSerializer.as_html``). A session's scene belongs to one browser, so the replay is drawn
again on a private recording server (loopback, a free port, no browser ever connects) with the same
:class:`~app.scene.LinkageScene`, frame by frame with ``insert_sleep`` between frames. One recorder is
shared by all sessions and used under a lock; it is created on the first export.
"""

from __future__ import annotations

import contextlib
import io
import threading

import numpy as np

from .overlays import TraceLine
from .scene import LinkageScene, camera_pose, mechanism_reach

REPLAY_FPS = 30.0
REPLAY_MAX_SECONDS = 30.0  # the last 30 simulated seconds; keeps the page a few megabytes at most
SOURCE_RATE = 60.0  # samples per second in a session's history
TRACE_SECONDS = 4.0

_lock = threading.Lock()
_recorder = None


def _recording_server():
    global _recorder
    if _recorder is None:
        import viser  # noqa: PLC0415 - the recording server is made on the first export only

        with contextlib.redirect_stdout(io.StringIO()):  # viser prints a banner; this server is private
            _recorder = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    return _recorder


@contextlib.contextmanager
def recording_server():
    """The shared recording server, held under the lock with a cleared scene for one page (and cleared after)."""
    with _lock:
        server = _recording_server()
        server.scene.reset()
        server.gui.reset()
        try:
            yield server
        finally:
            server.scene.reset()


def stop_recorder() -> None:
    global _recorder
    with _lock:
        if _recorder is not None:
            with contextlib.redirect_stdout(io.StringIO()):
                _recorder.stop()
            _recorder = None


def replay_html(history: dict[str, np.ndarray], params, title: str = "Linkage Lab replay",
                rate: float = SOURCE_RATE) -> str:
    """HTML replay of ``history`` (``rate`` samples per second: a session's 60, or a notebook run's own) for
    mechanism ``params`` (``L``, ``d``, ``pin``)."""
    t = history["t"]
    if len(t) < 2:
        raise ValueError("nothing to replay yet: fewer than two samples")
    stride = max(1, int(round(rate / REPLAY_FPS)))
    first = max(0, len(t) - int(REPLAY_MAX_SECONDS * rate))
    frames = range(first, len(t), stride)
    L = np.array(params.L, dtype=float)
    d = np.array(params.d, dtype=float)
    com_ratio = np.divide(d, L, out=np.zeros_like(d), where=L > 0)
    trace_samples = int(TRACE_SECONDS * rate)
    with recording_server() as server:
        reach = mechanism_reach(L, params.pin)
        position, look_at = camera_pose(L, params.pin)
        server.initial_camera.position = tuple(position)
        server.initial_camera.look_at = tuple(look_at)
        server.initial_camera.up = (0.0, 0.0, 1.0)
        server.scene.add_grid("/floor", width=20.0, height=20.0, plane="xy", cell_size=0.25, section_size=1.0,
                              position=(0.0, 0.0, -1.08 * reach))
        scene = LinkageScene(server, "/linkage")
        scene.build(L, params.pin)
        trace = TraceLine(server.scene, "/linkage/trace")
        server.scene.add_label("/title", title, position=(look_at[0], 0.0, look_at[2] + 1.05 * reach))
        serializer = server.get_scene_serializer()
        for i in frames:
            joints = history["joints"][i]
            com = joints[:-1] + com_ratio[:, None] * (joints[1:] - joints[:-1])
            scene.show(joints, com)
            trace.update(history["trace_xy"][max(first, i - trace_samples) : i + 1])
            serializer.insert_sleep(stride / rate)
        return serializer.as_html()
