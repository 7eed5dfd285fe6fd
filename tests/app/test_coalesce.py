"""The drags' coalescing worker (app/coalesce.py): the newest update wins, a start and an end are always handled,
an update waits for the minimum interval (a fake clock and sleep: no real waiting), a handler's exception is
logged and the worker goes on, and a closed worker handles nothing more."""

from __future__ import annotations

import logging
import threading
import time
import uuid

from app.coalesce import CoalescingWorker

DEADLINE = 30.0  # s: generous under load; every wait below ends as soon as its condition holds


class Recorder:
    """A handler that records each event; ``gate`` (when given) holds the first event's handling until set, so
    the events submitted meanwhile queue up; ``on_handle`` runs inside each handling (a mark, a raise)."""

    def __init__(self, gate: threading.Event | None = None, on_handle=None) -> None:
        self.handled: list[tuple] = []
        self.threads: list[threading.Thread] = []
        self.gate = gate
        self.entered = threading.Event()  # the first handling has begun
        self.on_handle = on_handle
        self._changed = threading.Condition()

    def __call__(self, event: tuple) -> None:
        self.entered.set()
        if self.gate is not None and not self.handled:
            self.gate.wait(DEADLINE)
        if self.on_handle is not None:
            self.on_handle(event)
        with self._changed:
            self.handled.append(event)
            self.threads.append(threading.current_thread())
            self._changed.notify_all()

    def wait_for(self, count: int) -> list[tuple]:
        with self._changed:
            assert self._changed.wait_for(lambda: len(self.handled) >= count, DEADLINE), self.handled
            return list(self.handled)


def is_update(event: tuple) -> bool:
    return event[0] == "update"


def worker_for(handler, **options) -> CoalescingWorker[tuple]:
    options.setdefault("name", "test-coalesce")
    options.setdefault("what", f"coalesce test {uuid.uuid4()}")  # logs are once per what: a fresh one per test
    return CoalescingWorker(handler, is_update, **options)


def wait_gone(name: str) -> None:
    deadline = time.monotonic() + DEADLINE
    while any(thread.name == name for thread in threading.enumerate()):
        assert time.monotonic() < deadline, f"thread {name!r} still running"
        time.sleep(0.01)


def test_the_thread_starts_with_the_first_event_as_a_named_daemon():
    name = f"coalesce-{uuid.uuid4()}"
    recorder = Recorder()
    worker = worker_for(recorder, name=name)
    assert not any(thread.name == name for thread in threading.enumerate()), "no thread before an event"
    worker.submit(("start", 0))
    recorder.wait_for(1)
    thread = recorder.threads[0]
    assert thread.name == name and thread.daemon and thread is not threading.current_thread()
    worker.close()
    wait_gone(name)


def test_the_newest_update_wins():
    gate = threading.Event()
    recorder = Recorder(gate)
    worker = worker_for(recorder)
    worker.submit(("start", 0))
    for k in range(1, 6):  # queued while the start is handled: each replaces the one before
        worker.submit(("update", k))
    gate.set()
    assert recorder.wait_for(2) == [("start", 0), ("update", 5)]
    worker.submit(("update", 6))  # the queue empty again: handled on its own
    assert recorder.wait_for(3)[2] == ("update", 6)
    worker.close()


def test_the_start_and_the_end_are_always_handled_and_an_update_before_them_is_dropped():
    gate = threading.Event()
    recorder = Recorder(gate)
    worker = worker_for(recorder, min_interval=1e6)  # an update would wait for ever; a start or an end does not
    worker.submit(("start", 0))
    worker.submit(("update", 1))
    worker.submit(("end", 2))
    worker.submit(("update", 3))
    worker.submit(("start", 4))
    worker.submit(("end", 5))
    gate.set()
    assert recorder.wait_for(4) == [("start", 0), ("end", 2), ("start", 4), ("end", 5)]
    worker.close()


class FakeTime:
    """A clock that only the worker's sleeps move; ``during_sleep`` runs inside a sleep (an event arriving)."""

    def __init__(self) -> None:
        self.now = 100.0
        self.sleeps: list[float] = []
        self.during_sleep = None

    def clock(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.sleeps.append(seconds)
        self.now += seconds
        if self.during_sleep is not None:
            self.during_sleep()


def test_an_update_waits_the_minimum_interval_from_the_handlers_last_mark():
    fake = FakeTime()
    worker: CoalescingWorker[tuple]
    recorder = Recorder(on_handle=lambda event: worker.mark() if event[1] != "no mark" else None)
    worker = worker_for(recorder, min_interval=0.25, clock=fake.clock, sleep=fake.sleep)
    worker.submit(("update", 1))
    recorder.wait_for(1)
    assert fake.sleeps == [], "nothing marked before: no wait"
    fake.now += 0.1
    worker.submit(("update", 2))
    assert recorder.wait_for(2)[1] == ("update", 2)
    assert len(fake.sleeps) == 1 and abs(fake.sleeps[0] - 0.15) < 1e-12, "the rest of the interval, from the mark"
    fake.now += 0.3
    worker.submit(("update", "no mark"))
    recorder.wait_for(3)
    assert len(fake.sleeps) == 1, "the interval had passed: no wait"
    worker.submit(("update", 4))
    recorder.wait_for(4)
    assert len(fake.sleeps) == 1, "the handling before did not mark: the interval still counts from the mark before"
    worker.close()


def test_an_update_arriving_during_the_wait_replaces_the_one_waiting():
    fake = FakeTime()
    worker: CoalescingWorker[tuple]
    recorder = Recorder(on_handle=lambda event: worker.mark())
    worker = worker_for(recorder, min_interval=0.25, clock=fake.clock, sleep=fake.sleep)
    worker.submit(("update", 1))
    recorder.wait_for(1)
    fake.during_sleep = lambda: (setattr(fake, "during_sleep", None), worker.submit(("update", 3)))
    worker.submit(("update", 2))
    assert recorder.wait_for(2) == [("update", 1), ("update", 3)]
    assert len(fake.sleeps) == 1, "the newer update's interval had passed in the first wait"
    worker.close()


def test_a_handlers_exception_is_logged_and_the_worker_keeps_serving(caplog):
    def fail_on_boom(event: tuple) -> None:
        if event[1] == "boom":
            raise RuntimeError("the handler failed")

    recorder = Recorder(on_handle=fail_on_boom)
    what = f"coalesce test {uuid.uuid4()}"
    worker = worker_for(recorder, what=what)
    with caplog.at_level(logging.WARNING, logger="app"):
        worker.submit(("start", "boom"))
        worker.submit(("end", 1))
        assert recorder.wait_for(1) == [("end", 1)], "the failed start was not recorded, the end was"
    lines = [record.getMessage() for record in caplog.records if record.name == "app"]
    assert any(what in line and "RuntimeError" in line and "the handler failed" in line for line in lines), lines
    worker.close()


def test_events_still_queued_when_closed_are_not_handled():
    name = f"coalesce-{uuid.uuid4()}"
    gate = threading.Event()
    recorder = Recorder(gate)
    worker = worker_for(recorder, name=name)
    worker.submit(("start", 0))
    assert recorder.entered.wait(DEADLINE)
    worker.submit(("update", 1))
    worker.submit(("end", 2))
    worker.close()
    gate.set()
    wait_gone(name)
    assert recorder.handled == [("start", 0)], "only the event being handled when it closed"
    worker.submit(("start", 3))  # closed: no thread is started again
    assert not any(thread.name == name for thread in threading.enumerate())
    assert worker.closed
