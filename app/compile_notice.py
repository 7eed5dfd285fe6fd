"""The physics' "compiling the ... integrator once" line, shown in every browser of this process as well.

Why: an installation's first run compiles an integrator for about 20 s (physics/kernels/first_compile.py) and
says so in one line through logging, on the server's stderr. A person looking at the page sees nothing of
stderr; without this they would watch a spinner for half a minute with no reason given. The compilation is
process-wide (every session of the process waits for the same machine code), so every open session gets the
notice; a session that starts preparing while a compilation is under way says it in its own "Deriving
equations..." notice (:attr:`CompileNotices.line`).
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Callable, Iterable

from .lab_session import LabSession
from .logs import quietly

LOGGER = "physics.kernels"  # where physics logs the line (physics/notices.py: modules log under physics.<name>)
TITLE = "Compiling once for this installation"
SHOWN_SECONDS = 30.0  # about one compilation (the line itself gives the figure); the next run starts at once
PREFIX = "linkage-lab: "


class CompileNotices(logging.Handler):
    """A logging handler on :data:`LOGGER` that turns each record into a notice in every session of
    ``sessions()``. Attach with :meth:`attach`, detach with :meth:`detach` (a server's stop)."""

    def __init__(self, sessions: Callable[[], Iterable[LabSession]]) -> None:
        super().__init__(level=logging.WARNING)
        self._sessions = sessions
        self._lock = threading.Lock()
        self._line: str | None = None
        self._said_at = 0.0

    @property
    def line(self) -> str | None:
        """The last compilation's line (without the command-line prefix) while it is likely still under way,
        else None."""
        with self._lock:
            if self._line is None or time.monotonic() - self._said_at > SHOWN_SECONDS:
                return None
            return self._line

    def emit(self, record: logging.LogRecord) -> None:
        try:
            text = record.getMessage().removeprefix(PREFIX)
            with self._lock:
                self._line, self._said_at = text, time.monotonic()
            for session in list(self._sessions()):
                quietly(lambda session=session: session.show_notice(TITLE, text, color="blue",
                                                                    seconds=SHOWN_SECONDS),
                        "showing the compile notice")
        except Exception:  # noqa: BLE001 - logging's contract: a failing handler reports, never raises
            self.handleError(record)

    def attach(self) -> CompileNotices:
        logging.getLogger(LOGGER).addHandler(self)
        return self

    def detach(self) -> None:
        logging.getLogger(LOGGER).removeHandler(self)
