"""The private recording server of the self-contained HTML replay pages (:mod:`app.mechanism_replay`).

viser records the scene messages of a server's shared scene and writes them, with its client, into one
HTML file (``StateSerializer.as_html``). A session's scene belongs to one browser, so a replay is drawn
again on a private recording server (loopback, a free port, no browser ever connects) with the app's own
scene, frame by frame with ``insert_sleep`` between frames. One recorder is shared by all sessions and used
under a lock; it is created on the first export.
"""

from __future__ import annotations

import contextlib
import io
import threading

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
