"""One session interface for the server, share links, snapshots and the presenter lock, whatever the model.

Why: a browser's session (:class:`app.session.Session`, for any preset, chain or mechanism)
has a panel, a scene, a player and workers; the server and the tools around it need none of that. They start and
close a session, give it the presenter check, apply a link's values by name, pause it at a time and read its
snapshot. :class:`LabSession` is that contract (a ``typing.Protocol``; mypy checks it where the server stores
sessions), so ``app/server.py`` and ``app/snapshot.py`` depend on these few members only, and a test can stand
in for a session. :class:`SessionBase` holds the presenter check, the notices and the browsers' bookkeeping.
"""

from __future__ import annotations

from typing import Any, Callable, Protocol

from .notices import NOTICE_SECONDS, Notices
from .viser_compat import connection_open


class LabSession(Protocol):
    """A session as the server and the tools around it see it."""

    id: int
    shared: bool
    closed: bool
    target: Any  # the viser client (own session) or server (shared)
    player: Any  # app.player.Player: its frame interval is set by the server's frame budget
    camera: Any  # app.camera.CameraDirector
    notices: Notices
    is_presenter: Callable[[int], bool] | None  # --shared with a presenter: whether a browser may change things

    @property
    def frames_sent(self) -> int:
        """Frames drawn so far (the load benchmark counts them)."""

    def close(self, clean: bool = False) -> None:
        """Stop the player; with ``clean`` remove every node and control (a switch in the same browser)."""

    def show_notice(self, title: str, body: str, color: str = ..., seconds: float | None = ...) -> None: ...

    def frame_camera(self, force: bool = False, client: Any = None) -> None: ...

    def set_camera_view(self, view: str) -> None: ...

    def set_reactions(self, on: bool) -> None: ...

    def set_compare(self, on: bool) -> None: ...

    def set_lecture(self, on: bool) -> None: ...

    def set_link_value(self, name: str, text: str) -> None:
        """One value of a share link or a setup file, by its name, in the panel's units."""

    def set_value(self, name: str, text: str) -> None:
        """One ``snapshot --set NAME=VALUE`` (a chain's in SI units, as ``python -m physics --set``)."""

    def load_setup(self, pairs: list[tuple[str, str]], where: str = ...) -> None:
        """A saved setup's ``(name, value)`` pairs (``--state``), applied by :meth:`set_link_value`."""

    def pause(self) -> None: ...

    def open_setup(self, saved: Any) -> None:
        """A saved setup (app/share.py ``SavedSetup``: a file's or a link's), its mechanism then its values."""

    def wait_at_start(self) -> None:
        """Back to t = 0 from the start in force, paused (a --shared lecture waits for the presenter's Play)."""

    def guard(self, action: Callable[[], object]) -> object:
        """Run one action; a refusal is a notice, never an exception."""

    def goto_time(self, t: float, timeout: float = ...) -> bool: ...

    def snapshot(self) -> dict: ...


class SessionBase:
    """Who may change things, notices, which browsers are the session's."""

    target: Any
    shared: bool
    closed: bool
    is_presenter: Callable[[int], bool] | None
    notices: Notices
    player: Any
    camera: Any

    def _stop(self) -> bool:
        """The start of ``close``: mark the session closed (its notices and camera too) and stop its player;
        False if it was closed already (nothing to do)."""
        if self.closed:
            return False
        self.closed = True
        self.notices.closed = True
        self.camera.closed = True
        self.player.stop()
        return True

    def may_change(self, client_id: int | None) -> bool:
        """Without a presenter lock anyone may; with one only the presenter (an unknown sender may not)."""
        return self.is_presenter is None or (client_id is not None and self.is_presenter(client_id))

    def show_notice(self, title: str, body: str, color: str = "yellow", seconds: float | None = NOTICE_SECONDS) -> None:
        """A notification in this session's browser(s), and the same text on the status line."""
        self.notices.show(title, body, color=color, seconds=seconds)

    def _clients(self) -> list:
        if self.shared:
            return list(self.target.get_clients().values())
        return [self.target]

    def _connection_open(self) -> bool:
        """False once this session's browser has gone (a shared session lives as long as the server)."""
        return self.shared or connection_open(self.target)
