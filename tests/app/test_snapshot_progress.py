"""A long way to the picture's time reports how far it got (issue 13/14: `snapshot --time 99999` ran 77 s
without a word)."""

from __future__ import annotations

import threading
import time
from types import SimpleNamespace

import pytest

from app import snapshot


class _SlowSession:
    """Stands in for a session whose simulation needs 2.5 s to reach the time asked."""

    def __init__(self, reach: bool) -> None:
        self.reach = reach
        self.ring = SimpleNamespace(t_last=0.0)
        self.player = SimpleNamespace(runs=[SimpleNamespace(ring=self.ring)])

    def goto_time(self, t: float, timeout: float) -> bool:
        for k in range(25):
            self.ring.t_last = t * k / 25
            time.sleep(0.1)
        return self.reach


def test_progress_lines_while_simulating_to_the_time(monkeypatch):
    monkeypatch.setattr(snapshot, "PROGRESS_EVERY_S", 0.5)
    lines: list[str] = []
    snapshot.show_time(_SlowSession(reach=True), 400.0, progress=lines.append)
    assert len(lines) >= 3, lines
    assert all(line.startswith("simulating: ") and "of 400 s" in line for line in lines)
    reached = [float(line.split()[1]) for line in lines]
    assert reached == sorted(reached) and reached[-1] > 0


def test_a_time_not_reached_is_one_error():
    with pytest.raises(snapshot.SnapshotError, match="did not reach it within"):
        snapshot.show_time(_SlowSession(reach=False), 5.0, timeout_s=1.0)
    assert threading.active_count() < 50
