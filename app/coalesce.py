"""A coalescing worker for a drag's events: viser reports a drag as a start, ~20 updates a second and an end, and
what a drag does with each (re-assemble, restart a run) can take longer than the gap between two updates.

Why one worker for every drag (app/drag_start.py, app/design_view.py): the events are only recorded on viser's
event loop (never blocked by the work); a thread of its own, started with the first event, handles them in order
with the newest update winning: an update followed by another update, a start or an end is dropped, a start and
an end are always handled, and an update is held until ``min_interval`` seconds have passed since the handler last
called :meth:`CoalescingWorker.mark` (a newer event arriving meanwhile replaces it). A handler's exception is
logged once (:func:`app.logs.quietly`) and the worker serves the next event. Once closed, the events still queued
are dropped.
"""

from __future__ import annotations

import threading
import time
from typing import Callable, Generic, TypeVar

from .logs import quietly

Event = TypeVar("Event")

WAKE_POLL = 0.5  # s: how often an idle worker looks whether it was closed


class CoalescingWorker(Generic[Event]):
    """Hands ``handle`` the events :meth:`submit` receives, on a daemon thread named ``name``; ``is_update`` says
    which events are updates (coalesced), ``what`` names the work in the log when the handler raises. ``clock`` and
    ``sleep`` are the interval's (tests inject their own)."""

    def __init__(self, handle: Callable[[Event], object], is_update: Callable[[Event], bool], *, name: str,
                 what: str, min_interval: float = 0.0, clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], object] = time.sleep) -> None:
        self._handle = handle
        self._is_update = is_update
        self.name = name
        self._what = what
        self.min_interval = min_interval
        self._clock = clock
        self._sleep = sleep
        self._lock = threading.Lock()
        self._wake = threading.Event()
        self._events: list[Event] = []
        self._thread: threading.Thread | None = None
        self._closed = False
        self._last_mark = 0.0

    def submit(self, event: Event) -> None:
        """Queue ``event`` (an update replaces an update still waiting) and wake the worker, started on the first
        event; cheap, so viser's event loop may call it."""
        with self._lock:
            if self._is_update(event) and self._events and self._is_update(self._events[-1]):
                self._events[-1] = event  # newest wins
            else:
                self._events.append(event)
            if self._thread is None and not self._closed:
                self._thread = threading.Thread(target=self._work, name=self.name, daemon=True)
                self._thread.start()
        self._wake.set()

    def mark(self) -> None:
        """The handler did the costly work now: the next update waits ``min_interval`` from here."""
        self._last_mark = self._clock()

    def close(self) -> None:
        """Stop serving: the worker ends within WAKE_POLL seconds; events still queued are not handled."""
        self._closed = True
        self._wake.set()

    @property
    def closed(self) -> bool:
        return self._closed

    def _work(self) -> None:
        while not self._closed:
            self._wake.wait(WAKE_POLL)
            self._wake.clear()
            while not self._closed:
                event = self._next()
                if event is None:
                    break
                quietly(lambda event=event: self._handle(event), self._what)

    def _next(self) -> Event | None:
        """The next event to handle, None when the queue is empty or the worker closed: an update only when nothing follows it, and
        once ``min_interval`` has passed since the last mark with nothing newer arrived meanwhile."""
        while not self._closed:
            with self._lock:
                if not self._events:
                    return None
                event = self._events.pop(0)
                pending = bool(self._events)
            if not self._is_update(event):
                return event
            if pending:
                continue  # an end, a new start or a newer update follows: that one counts
            wait = self._last_mark + self.min_interval - self._clock()
            if wait > 0:  # coalesce: a newer update (or the end) may come meanwhile
                self._sleep(wait)
                with self._lock:
                    if self._events:
                        continue
            return event
        return None
