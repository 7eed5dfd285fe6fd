"""A player renders the next frame only once the previous one has been delivered (app/delivery.py), never
waits longer than MAX_DEFER_SECONDS for it, and keeps the displayed time on the wall clock meanwhile."""

from __future__ import annotations

import time

from app.player import MAX_DEFER_SECONDS, Player, RunSpec
from physics import Settings, get_preset, simulate


def _play(ready_for_frame, seconds: float = 2.0) -> tuple[int, int, float]:
    preset = get_preset("triple-a")
    frames = []
    player = Player(
        simulate=simulate,
        make_settings=lambda s, horizon, samples: s.model_copy(update={"t_end": horizon, "samples": samples}),
        on_frame=frames.append,
        on_failure=lambda message: None,
        ready_for_frame=ready_for_frame,
    )
    try:
        spec = RunSpec("main", preset.chain, Settings(method="lagrange"))
        player.restart([spec], 0.0, [(preset.theta0, preset.omega0)], keep_history=False, play=True)
        assert player.wait_idle(60)
        count0, t0, wall0 = len(frames), player.display_time, time.monotonic()
        time.sleep(seconds)
        wall = time.monotonic() - wall0
        return len(frames) - count0, player.frames_deferred, (player.display_time - t0) / wall
    finally:
        player.stop()


def test_undelivered_frames_are_skipped_but_time_runs_on():
    rendered, deferred, rate = _play(lambda: False)
    # never delivered: one frame per MAX_DEFER_SECONDS (4 a second), the others skipped
    assert 0.5 / MAX_DEFER_SECONDS <= rendered / 2.0 <= 1.5 / MAX_DEFER_SECONDS, rendered
    assert deferred > 40, deferred
    assert 0.8 < rate < 1.1, rate  # the motion keeps real time


def test_delivered_frames_are_all_rendered():
    rendered, deferred, rate = _play(lambda: True)
    assert deferred == 0
    assert rendered / 2.0 > 20, rendered  # about 60 a second on an idle machine
    assert 0.8 < rate < 1.1, rate
