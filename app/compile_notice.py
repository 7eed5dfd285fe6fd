"""The physics' "compiling the ... integrator once" line, shown in every browser of this process as well.

Why: an installation's first run compiles an integrator for about 20 s (physics/kernels/first_compile.py) and
says so in one line through logging, on the server's stderr. A person looking at the page sees nothing of
stderr; without this they would watch a spinner for half a minute with no reason given. The compilation is
process-wide (every session of the process waits for the same machine code), so every open session gets the
notice; a session that starts preparing while a compilation is under way says it in its own "Deriving
equations..." notice (:attr:`CompileNotices.line`). When the compilation is over, physics logs one more record below WARNING
(``physics.kernels.first_compile.call_announced``; the command line does not print it) and the notice comes down
from every session and its status line: a notice that said "compiling" after the run had started would be
wrong.
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
        super().__init__(level=logging.INFO)
        self._sessions = sessions
        self._level_before = logging.NOTSET
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
            if record.levelno < logging.WARNING:  # the compilation is over
                self._withdraw()
                return
            text = record.getMessage().removeprefix(PREFIX)
            with self._lock:
                self._line, self._said_at = text, time.monotonic()
            for session in list(self._sessions()):
                quietly(lambda session=session: session.show_notice(TITLE, text, color="blue",
                                                                    seconds=SHOWN_SECONDS),
                        "showing the compile notice")
        except Exception:  # noqa: BLE001 - logging's contract: a failing handler reports, never raises
            self.handleError(record)

    def _withdraw(self) -> None:
        with self._lock:
            self._line = None
        for session in list(self._sessions()):
            quietly(lambda session=session: session.notices.withdraw(TITLE), "taking down the compile notice")

    def attach(self) -> CompileNotices:
        target = logging.getLogger(LOGGER)
        self._level_before = target.level
        if target.getEffectiveLevel() > logging.INFO:
            target.setLevel(logging.INFO)  # the end of a compilation is logged at INFO
        target.addHandler(self)
        return self

    def detach(self) -> None:
        target = logging.getLogger(LOGGER)
        target.removeHandler(self)
        if not any(isinstance(handler, CompileNotices) for handler in target.handlers):
            target.setLevel(self._level_before)
