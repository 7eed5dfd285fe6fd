"""What the reference pictures are: one per preset, at one simulated time, and what each must show."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import pictures

REFERENCES = Path(__file__).resolve().parent / "references"
REFERENCE_TIME = 3.5  # simulated seconds: the mechanisms have moved well away from their start
VIEWPORT = {"width": 960, "height": 640}
# Pixels of each bar's colour a scene picture must hold: a bar is ~8 px wide and >= 40 px long here.
MIN_BAR_PIXELS = 60


def bars_drawn(image: np.ndarray, preset: str, links: int | None = None) -> dict[int, int]:
    """``{bar: pixels}`` for the bars whose colour is (nearly) absent from ``image``; empty when all are drawn."""
    from app.scene import BAR_COLORS
    from physics import get_preset

    n = get_preset(preset, links).chain.n if links else get_preset(preset).chain.n
    missing = {}
    for k in range(1, n + 1):
        count = int(pictures.colour_match(image, BAR_COLORS[(k - 1) % len(BAR_COLORS)]).sum())
        if count < MIN_BAR_PIXELS:
            missing[k] = count
    return missing
