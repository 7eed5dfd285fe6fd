"""Snapshots for slides (issue 26): the caption and the time stamp scale with the picture, their letters at least
3 % of its height (they stayed ~11 px on a 1920x1080 picture), measured from the rendered PNG's pixel rows."""

from __future__ import annotations

import io

import numpy as np
import pytest
from PIL import Image

from app.snapshot import labelled


def _blank(width: int, height: int) -> bytes:
    out = io.BytesIO()
    Image.new("RGB", (width, height), (40, 60, 90)).save(out, format="PNG")
    return out.getvalue()


def _text_rows(png: bytes, left: bool) -> int:
    """Rows of dark (text) pixels on the light band, in the left or right half of the picture."""
    pixels = np.asarray(Image.open(io.BytesIO(png)).convert("L")).astype(int)
    height, width = pixels.shape
    band = pixels[height // 2:, : width // 2] if left else pixels[height // 2:, width // 2:]
    light = band > 200
    band_rows = np.flatnonzero(light.mean(axis=1) > 0.5)  # the band: rows mostly light
    region = band[band_rows[0]:]
    dark_rows = np.flatnonzero((region < 100).any(axis=1))
    return int(dark_rows[-1] - dark_rows[0] + 1) if dark_rows.size else 0


@pytest.mark.parametrize(("width", "height"), [(1920, 1080), (1280, 720), (800, 600)])
def test_caption_and_stamp_are_at_least_three_percent_of_the_picture(width, height):
    png = labelled(_blank(width, height), "Triple pendulum A (Lagrange)", "t = 3.50 s")
    assert Image.open(io.BytesIO(png)).size == (width, height)
    caption_rows, stamp_rows = _text_rows(png, left=True), _text_rows(png, left=False)
    assert caption_rows >= 0.03 * height, (caption_rows, height)
    assert stamp_rows >= 0.025 * height, (stamp_rows, height)  # digits and "=" have no descender: a little lower
