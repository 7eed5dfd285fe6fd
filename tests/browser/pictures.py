"""Pixels for the browser tests: decode screenshots, compare them with references, find colours.

Reference tolerance (see docs/snapshots.md). A pixel *differs* when every pixel within
``SLACK_PIXELS`` (1) of it in the other picture is off by more than ``LEVEL_TOLERANCE`` (40 of 255 levels)
in some channel, looking both ways; a picture matches its reference when at most ``FRACTION_TOLERANCE``
(0.3 %, 1843 pixels of 960 x 640) differ.

Why: SwiftShader renders deterministically for one Chromium build on one CPU (repeat renders here are
bit-identical: 0 pixels differ), but another Chromium build, or SwiftShader's JIT choosing other SIMD
paths on another CPU, may move anti-aliased edges by part of a pixel and change the shading of thin lines
by some levels. As a stand-in for that, case A rendered 1 px wider and taller and cropped (every edge
moves by up to half a pixel) differs in 33 048 pixels plainly, 3041 with the 1-pixel slack at 24 levels,
and 447 (0.07 %) at 40 levels: 95 % of what remains at 24 levels is the faint floor grid, whose 1-pixel
lines change intensity with sub-pixel position. The mechanism is drawn at high contrast (~200 levels from
the background), so 40 levels loses almost nothing of real change: case A 0.02 s later differs in 1030
pixels (0.16 %, passes), 0.1 s later in 4282 (0.70 %), 0.25 s later in 6082 (0.99 %, over three times the
tolerance; ``test_tolerance_tells_nearby_moments_apart`` checks it). A missing bar changes only ~800
pixels of a scene this size, under the tolerance: that is why every picture is also checked for each
bar's colour (``references_spec.bars_drawn``, ``assert_mechanism_drawn``).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

LEVEL_TOLERANCE = 40
SLACK_PIXELS = 1
FRACTION_TOLERANCE = 0.003


def decode_png(png: bytes) -> np.ndarray:
    """PNG bytes -> (H, W, 3) uint8 RGB (imageio: already installed as a dependency of viser)."""
    import imageio.v3 as iio

    image = np.asarray(iio.imread(png, extension=".png"))
    if image.ndim == 2:
        image = np.repeat(image[:, :, None], 3, axis=2)
    return np.ascontiguousarray(image[:, :, :3]).astype(np.uint8)


def write_png(path: Path, image: np.ndarray) -> None:
    import imageio.v3 as iio

    path.parent.mkdir(parents=True, exist_ok=True)
    iio.imwrite(path, np.asarray(image, dtype=np.uint8), extension=".png")


def read_png(path: Path) -> np.ndarray:
    return decode_png(Path(path).read_bytes())


def _unmatched(image: np.ndarray, other: np.ndarray, level: int, slack: int) -> np.ndarray:
    """Pixels of ``image`` with no pixel of ``other`` within ``slack`` pixels and ``level`` levels."""
    height, width, _ = image.shape
    padded = np.pad(other, ((slack, slack), (slack, slack), (0, 0)), mode="edge")
    closest = np.full((height, width), np.iinfo(np.int16).max, dtype=np.int16)
    for dy in range(2 * slack + 1):
        for dx in range(2 * slack + 1):
            shifted = padded[dy : dy + height, dx : dx + width]
            np.minimum(closest, np.abs(image - shifted).max(axis=2), out=closest)
    return closest > level


def differing(
    actual: np.ndarray, reference: np.ndarray, level: int = LEVEL_TOLERANCE, slack: int = SLACK_PIXELS
) -> np.ndarray:
    """Boolean (H, W): pixels that differ, i.e. whose largest channel difference exceeds ``level`` against
    every pixel within ``slack`` pixels of the other picture, looking both ways (so a missing stroke and an
    extra one both count, and an edge anti-aliased half a pixel off does not)."""
    if actual.shape != reference.shape:
        raise AssertionError(f"picture is {actual.shape}, reference is {reference.shape}")
    a, b = actual.astype(np.int16), reference.astype(np.int16)
    return _unmatched(a, b, level, slack) | _unmatched(b, a, level, slack)


def differing_fraction(actual: np.ndarray, reference: np.ndarray, level: int = LEVEL_TOLERANCE) -> float:
    return float(differing(actual, reference, level).mean())


def diff_picture(actual: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """The reference, faded, with differing pixels in magenta: where to look when a test fails."""
    faded = (255 - (255 - reference.astype(np.int16)) // 4).astype(np.uint8)
    faded[differing(actual, reference)] = (255, 0, 255)
    return faded


def colour_match(image: np.ndarray, rgb, max_residual: float = 40.0, shade=(0.45, 1.35)) -> np.ndarray:
    """Boolean (H, W): pixels of colour ``rgb`` under some shading, i.e. ``pixel ~ k * rgb`` with
    ``k`` in ``shade`` (lit faces are brighter, faces turned away darker) and a residual below
    ``max_residual`` levels. A white background or the grey GUI panel never matches a saturated colour."""
    colour = np.asarray(rgb, dtype=float)
    pixels = image.astype(float)
    k = pixels @ colour / float(colour @ colour)
    residual = np.linalg.norm(pixels - k[..., None] * colour, axis=-1)
    return (residual <= max_residual) & (k >= shade[0]) & (k <= shade[1])


def count_near(mask: np.ndarray, xy, radius: int) -> int:
    """How many True pixels of ``mask`` lie within a square of half-size ``radius`` around page point ``xy``."""
    x, y = int(round(xy[0])), int(round(xy[1]))
    height, width = mask.shape
    window = mask[max(y - radius, 0) : min(y + radius + 1, height), max(x - radius, 0) : min(x + radius + 1, width)]
    return int(window.sum())


def box_mask(shape, box: dict | None) -> np.ndarray:
    """Boolean (H, W) of a page box ``{"x", "y", "width", "height"}`` (playwright's bounding_box)."""
    mask = np.zeros(shape[:2], dtype=bool)
    if box is not None:
        x0, y0 = int(np.floor(box["x"])), int(np.floor(box["y"]))
        x1, y1 = int(np.ceil(box["x"] + box["width"])), int(np.ceil(box["y"] + box["height"]))
        mask[max(y0, 0) : max(y1, 0), max(x0, 0) : max(x1, 0)] = True
    return mask


def hue_match(image: np.ndarray, rgb, max_hue_degrees: float = 15.0, min_saturation: float = 0.2) -> np.ndarray:
    """Boolean (H, W): pixels of the hue of ``rgb``, at any brightness and at least ``min_saturation``.

    For unlit scene lines (the trace): viser draws their vertex colours as linear values and encodes the
    output to sRGB, and the trace fades towards white with age, so the exact value on screen differs
    from the colour given, but its hue stays; white, grey, black and the other palette colours do not
    share it."""
    hue, saturation, _ = _hsv(image.astype(float) / 255.0)
    target_hue, _, _ = _hsv(np.asarray(rgb, dtype=float)[None, None, :] / 255.0)
    distance = np.abs((hue - target_hue[0, 0] + 180.0) % 360.0 - 180.0)
    return (distance <= max_hue_degrees) & (saturation >= min_saturation)


def _hsv(rgb: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Hue in degrees, saturation and value of (..., 3) colours in 0..1."""
    high = rgb.max(axis=-1)
    low = rgb.min(axis=-1)
    spread = high - low
    safe = np.where(spread > 0, spread, 1.0)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    hue = np.where(
        high == r, ((g - b) / safe) % 6.0, np.where(high == g, (b - r) / safe + 2.0, (r - g) / safe + 4.0)
    ) * 60.0
    saturation = np.where(high > 0, spread / np.where(high > 0, high, 1.0), 0.0)
    return np.where(spread > 0, hue, 0.0), saturation, high


# The reference pictures hold text (the panel, the figures' labels). Which fonts a machine has installed changes
# it (Debian's `apt-get install chromium` brings the Liberation fonts, `--no-install-recommends` does not, and the
# Report tab came out 899 px high instead of 895), so the browser of the tests sees only the DejaVu fonts, which
# every Debian machine with fontconfig has (fonts-dejavu-core comes with fontconfig-config).
PINNED_FONTS = Path("/usr/share/fonts/truetype/dejavu")
FONTS_CONF = """<?xml version="1.0"?>
<!DOCTYPE fontconfig SYSTEM "fonts.dtd">
<fontconfig>
  <dir>{fonts}</dir>
  <cachedir>{cache}</cachedir>
  <alias><family>sans-serif</family><prefer><family>DejaVu Sans</family></prefer></alias>
  <alias><family>serif</family><prefer><family>DejaVu Serif</family></prefer></alias>
  <alias><family>monospace</family><prefer><family>DejaVu Sans Mono</family></prefer></alias>
</fontconfig>
"""


def pinned_font_environment(folder: Path) -> dict[str, str] | None:
    """This process's environment with a fontconfig file (written into ``folder``) that offers the browser only
    :data:`PINNED_FONTS`; None (the machine's fonts) when that folder is missing."""
    if not PINNED_FONTS.is_dir():
        return None
    conf = folder / "fonts.conf"
    conf.write_text(FONTS_CONF.format(fonts=PINNED_FONTS, cache=folder / "font-cache"), encoding="utf-8")
    return {**os.environ, "FONTCONFIG_FILE": str(conf)}
