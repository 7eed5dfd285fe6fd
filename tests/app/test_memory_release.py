"""A closed session counts as gone only once the memory trim can free it (app/memory.py, app/server.py).

CI saw tests/app/test_memory_cycles.py leave 9 of 25 sessions after a wave, about one full run in three: the
sessions were closed, but the trim's collection ran while their closers still held them (viser's disconnect
callback on its thread pool: the callback's frame and the pool's work item, whose client's controls hold the
session), and once let go they waited in reference cycles for the next full collection. And a seat was freed
before the trim was asked for, so a wave could look settled with its last sessions not yet handed to the trim.
"""

from __future__ import annotations

import gc
import threading
import weakref

from app import logs, memory
from app.server import LabServer
from conftest import BrowserStandIn, wait_until

TIMEOUT = 600.0  # generous: the machine may be loaded; every wait is on a condition


def test_the_trim_collects_again_until_a_closed_session_its_closer_still_held_is_gone():
    class Held:
        """A closed session: a reference cycle, freed only by the collector."""

    references: list = []
    release = threading.Event()
    trimmer = memory.Trimmer(settle=0.05, max_delay=5.0)

    def closer() -> None:  # asks for the trim, then holds the session a while longer (the rest of its callback)
        held = Held()
        held.itself = held
        references.append(weakref.ref(held))
        trimmer.request(closed=held)
        release.wait(TIMEOUT)

    enabled = gc.isenabled()
    gc.disable()
    thread = threading.Thread(target=closer, name="a disconnect callback")
    try:
        thread.start()
        assert wait_until(lambda: references, timeout=TIMEOUT)
        assert not wait_until(trimmer.settled, timeout=1.0), "the trim counted a session still held as released"
        assert references[0]() is not None
        release.set()
        assert trimmer.wait_settled(TIMEOUT)
        assert references[0]() is None, "the closed session's cycle outlived the trim"
        assert trimmer.trims == 1
    finally:
        release.set()
        thread.join(TIMEOUT)
        if enabled:
            gc.enable()
        trimmer.stop()


def test_a_seat_is_freed_only_after_the_trim_for_its_session_was_asked_for():
    server = LabServer(port=0, processes=1, warm=False)
    try:
        seen_at_release: list[bool] = []
        release = server.seats.release

        def watched_release() -> None:
            seen_at_release.append(server.trimmer.settled())
            release()

        server.seats.release = watched_release  # type: ignore[method-assign]
        client = BrowserStandIn(server.url)
        assert wait_until(lambda: len(server.sessions) == 1, timeout=TIMEOUT)
        session = weakref.ref(next(iter(server.sessions.values())))
        client.close()
        assert wait_until(lambda: not server.sessions and server.seats.count == 0, timeout=TIMEOUT)
        assert seen_at_release == [False], "the seat was free before the trim for its session was asked for"
        assert server.trimmer.wait_settled(TIMEOUT)
        assert session() is None, "the closed session outlived the trim"
    finally:
        server.stop()


def test_a_closed_session_held_past_the_trims_patience_is_reported_once(monkeypatch, caplog):
    """A session something really keeps (a leak): the trim gives up after FINISH_WAIT_SECONDS and says so, once,
    instead of settling in silence."""
    class Held:
        pass

    monkeypatch.setattr(memory, "FINISH_WAIT_SECONDS", 0.3)
    monkeypatch.setattr(logs, "_seen", set())  # log_once is once per process: this test's own
    kept = Held()
    trimmer = memory.Trimmer(settle=0.05, max_delay=5.0)
    try:
        with caplog.at_level("WARNING", logger="app"):
            trimmer.request(closed=kept)
            assert trimmer.wait_settled(TIMEOUT)
        assert [r.getMessage() for r in caplog.records if "still held" in r.getMessage()] == [
            "1 closed session(s) still held after the memory trim's collections; their memory stays until "
            "whatever holds them lets go"]
    finally:
        trimmer.stop()
