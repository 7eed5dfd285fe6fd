"""A run is the same, bit for bit, whatever the frame timing: chunk boundaries never follow the wall clock.

Each chunk restarts the integrator from its last sample, so where chunks end shapes a chaotic run. The player
sizes them by the work they took (right-hand-side evaluations), so a loaded machine, a slow browser or a
lecture rehearsed on another laptop shows the same curves after Reset.
"""

from __future__ import annotations

import random
import time

import numpy as np

from app.player import Player, RunSpec
from physics import Settings, get_preset, simulate


def _run_to(t_end: float, delays: random.Random) -> np.ndarray:
    preset = get_preset("triple-c")
    settings = Settings(method="lagrange", integrator="RK45", rtol=1e-6, atol=1e-6)

    def slow_simulate(*args, **kwargs):
        time.sleep(delays.uniform(0.0, 0.02))  # a busy machine: chunks take random wall time
        return simulate(*args, **kwargs)

    player = Player(
        simulate=slow_simulate,
        make_settings=lambda s, horizon, samples: s.model_copy(update={"t_end": horizon, "samples": samples}),
        on_frame=lambda frame: None,
        on_failure=lambda message: None,
    )
    try:
        spec = RunSpec("main", preset.chain, settings)
        player.restart([spec], 0.0, [(preset.theta0, preset.omega0)], keep_history=False, play=False)
        assert player.seek(t_end, timeout=120.0), "the player did not reach the time"
        with player.lock:
            ring = player.runs[0].ring
            count = ring.index_at(t_end) + 1
            return np.array([ring.get("theta", i) for i in range(count)])
    finally:
        player.stop()


def test_the_same_setup_gives_the_same_run_whatever_the_timing():
    first = _run_to(8.0, random.Random(1))
    second = _run_to(8.0, random.Random(2))
    assert first.shape == second.shape and len(first) >= 8 * 60
    assert np.array_equal(first, second), f"runs differ by up to {np.max(np.abs(first - second)):.3g} rad"
