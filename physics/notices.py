"""Notices of the library (a cache file rebuilt, a long run's progress) go through :mod:`logging`, under the
logger ``"physics"`` (modules log under ``"physics.<module>"``), so a notebook or the app can filter them:
``logging.getLogger("physics").setLevel(logging.ERROR)`` silences them.

They are logged at WARNING on purpose: with no handler configured anywhere, Python's last-resort handler
prints WARNING and above on stderr as the bare message, which is the one-line text the library printed before
(``linkage-lab: ...``). The commands install :class:`StderrLines` so their lines stay exactly as they were
whatever a test runner or an embedding program attaches to the root logger.
"""

from __future__ import annotations

import logging
import sys

LOGGER_NAME = "physics"
NOTICE = logging.WARNING  # shown by default (the last-resort handler's threshold); see the module docstring


def notify(message: str, logger: str = LOGGER_NAME) -> None:
    """One notice line (the text as it will be printed, prefix included)."""
    logging.getLogger(logger).log(NOTICE, message)


class StderrLines(logging.Handler):
    """Each notice (WARNING and above) as its bare message on the stderr current at the time (pytest's capture,
    a redirect); records below (a compilation's end, for the app) are not printed."""

    def __init__(self) -> None:
        super().__init__(level=NOTICE)

    def emit(self, record: logging.LogRecord) -> None:
        try:
            sys.stderr.write(record.getMessage() + "\n")
            sys.stderr.flush()
        except Exception:  # noqa: BLE001 - logging's contract: a failing handler reports, never raises
            self.handleError(record)


def install_stderr_lines(logger: str = LOGGER_NAME) -> None:
    """For a command's ``main()``: print the notices of ``logger`` as one line each on stderr (once per process)."""
    target = logging.getLogger(logger)
    if not any(isinstance(handler, StderrLines) for handler in target.handlers):
        target.addHandler(StderrLines())
