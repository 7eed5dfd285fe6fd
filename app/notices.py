"""A session's notices: one notification per action in its browser(s), and the same text on the status line.

Why a class of its own: several threads raise notices (GUI callbacks, the player, analysis workers), and a
browser must never see them pile up. :meth:`Notices.show` replaces the previous notification instead of adding
one, and a notice equal to the one still on screen is not sent again (a slider dragged into a refused range
sends one value per step).
"""

from __future__ import annotations

import threading
import time
from typing import Callable

from .logs import quietly
from .viser_compat import resend_value

NOTICE_SECONDS = 8.0
# The notification colours that mean something went wrong or was not done (a refusal, a stopped run): the status
# line marks those with a warning sign; a green "Done" or a blue "Computing" is news, not a warning.
WARNING_COLORS = frozenset({"yellow", "orange", "red"})
VIEWER_NOTICE_SECONDS = 4.0


class Notices:
    """Notifications of one session. ``clients()`` lists the browsers to tell; ``on_change()`` redraws the
    status line; ``connected()`` is False once the browser has gone (nothing is sent then)."""

    def __init__(self, clients: Callable[[], list], on_change: Callable[[], None],
                 connected: Callable[[], bool] = lambda: True) -> None:
        self._clients = clients
        self._on_change = on_change
        self._connected = connected
        self._lock = threading.Lock()
        self._handles: list = []
        self._shown: tuple[str, str] | None = None
        self._until = 0.0
        self.text: str | None = None  # the notice on the status line (None when there is none)
        self.warning = False  # whether that notice is a warning (WARNING_COLORS): the status line marks it so
        self.closed = False
        self.serial = 0  # notices asked for so far: an action that raised none is told apart from one that did
        self._on_screen: str | None = None  # the title of the notification in the browser(s), until taken down

    def show(self, title: str, body: str, color: str = "yellow", seconds: float | None = NOTICE_SECONDS) -> None:
        """Replace the current notice with this one (unless it is the same and still on screen)."""
        with self._lock:
            self.text = f"{title}: {body}"
            self.warning = color in WARNING_COLORS
            self.serial += 1
            now = time.monotonic()
            if self._shown == (title, body) and now < self._until and self._handles:
                return  # the same notice is still showing: not piled up again
            if self.closed or not self._connected():
                return
            old, self._handles = self._handles, []
            for handle in old:
                quietly(handle.remove, "removing a notification")
            for client in self._clients():
                def add(client=client) -> None:
                    self._handles.append(
                        client.add_notification(title, body, color=color, auto_close_seconds=seconds)
                    )
                quietly(add, "sending a notification")
            self._shown = (title, body)
            self._on_screen = title
            self._until = now + (seconds if seconds is not None else float("inf"))
        self._on_change()

    def clear(self) -> None:
        """Forget the status line's notice (a new start, the run goes on). A notification that closes by itself
        is left to do so; one that stays until dealt with (a stopped run, a paused session) is removed: the run
        it was about has been replaced."""
        with self._lock:
            self.text = None
            self._shown = None
            if self._until == float("inf"):
                old, self._handles = self._handles, []
                self._until, self._on_screen = 0.0, None
                for handle in old:
                    quietly(handle.remove, "removing a notification")

    def withdraw(self, title: str) -> None:
        """Take down the notice titled ``title`` (its notification and its status line) if it is the one on
        screen, even after :meth:`clear` forgot its status line: what it said is over (a compilation has
        finished, a refused value has been followed by one applied). Any other notice stays."""
        with self._lock:
            if self._on_screen != title:  # another notice is up (or none): it stays
                return
            old, self._handles = self._handles, []
            self.text, self._shown, self._until, self._on_screen = None, None, 0.0, None
            for handle in old:
                quietly(handle.remove, "removing a notification")
        self._on_change()

    @property
    def showing(self) -> str | None:
        """The title of the notification sent to the browser(s) and not taken down (a notice that closes by
        itself counts until taken down or replaced), or None."""
        with self._lock:
            return self._on_screen

    @property
    def sticky(self) -> bool:
        """Whether a notification that stays until dealt with (no auto close) is on screen."""
        with self._lock:
            return bool(self._handles) and self._until == float("inf")

    def progress(self, title: str, body: str) -> list:
        """A notification with a spinner and no close button (work under way); dismiss it with :meth:`dismiss`."""
        handles: list = []
        for client in self._clients():
            def add(client=client) -> None:
                handles.append(client.add_notification(title, body, loading=True, with_close_button=False))
            quietly(add, "sending a progress notification")
        return handles

    @staticmethod
    def dismiss(handles: list) -> None:
        for handle in handles:
            quietly(handle.remove, "removing a progress notification")


class ViewerRefusals:
    """A viewer of a presenter's session (``--shared``) moved a control: nothing is applied, its control is put
    back in its page, and it is told why, at most once every VIEWER_NOTICE_SECONDS (a dragged slider sends a
    value per step). Called as ``refusals(client_id, handle)`` (``check_gui_updates``' ``refuse_sender``)."""

    def __init__(self, target, shared: bool) -> None:
        self._target, self._shared = target, shared
        self._told: dict[int, float] = {}

    def __call__(self, client_id: int, handle) -> None:
        client = self._target.get_clients().get(client_id) if self._shared else None
        if client is None:
            return
        resend_value(client, handle)
        now = time.monotonic()
        if now - self._told.get(client_id, -1e9) > VIEWER_NOTICE_SECONDS:
            self._told[client_id] = now
            client.add_notification("The presenter controls this session",
                                    "Changes from this browser are not applied.", color="blue",
                                    auto_close_seconds=VIEWER_NOTICE_SECONDS)
