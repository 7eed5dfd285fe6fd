"""Each preset, paused at the same simulated time, looks as its stored reference picture does.

The pictures are made by the snapshot command's own code (``app.snapshot.render_pngs``: the app on a free
loopback port, Chromium with software WebGL, the scene alone) and compared within the tolerance of
``pictures.py``. Tests never write references: ``python tests/browser/regenerate_references.py`` does,
on purpose. A failed comparison leaves the picture and a diff in tests/browser/output/.
"""

from __future__ import annotations

import numpy as np
import pytest

from app import snapshot as snap
from physics import preset_names

from . import pictures
from .conftest import save_failure
from .references_spec import REFERENCE_TIME, REFERENCES, VIEWPORT, bars_drawn

REGENERATE = "python tests/browser/regenerate_references.py"


def reference(preset: str) -> np.ndarray:
    path = REFERENCES / f"{preset}.png"
    assert path.exists(), f"no reference picture {path.name}; make it with `{REGENERATE} {preset}` and look at it"
    image = pictures.read_png(path)
    assert not bars_drawn(image, preset), f"reference {path.name} lacks a bar's colour: {REGENERATE} {preset}"
    return image


def render(browser, preset: str, t: float) -> np.ndarray:
    return pictures.decode_png(snap.render_pngs(preset, [t], viewport=VIEWPORT, browser=browser)[0])


def assert_matches(actual: np.ndarray, expected: np.ndarray, name: str) -> None:
    fraction = pictures.differing_fraction(actual, expected)
    if fraction > pictures.FRACTION_TOLERANCE:
        path = save_failure(name, actual, expected)
        pytest.fail(
            f"{name}: {100 * fraction:.2f} % of pixels differ by more than {pictures.LEVEL_TOLERANCE} levels "
            f"(tolerance {100 * pictures.FRACTION_TOLERANCE:.1f} %); see {path} and its .diff.png. "
            f"If the change is intended: {REGENERATE} {name}",
            pytrace=False,
        )


@pytest.mark.parametrize("preset", preset_names())
def test_preset_at_fixed_time_matches_its_reference(browser, preset):
    expected = reference(preset)
    actual = render(browser, preset, REFERENCE_TIME)
    missing = bars_drawn(actual, preset)
    if missing:
        save_failure(preset, actual, expected)
    assert not missing, f"bars drawn with (nearly) none of their colour: {missing}"
    assert_matches(actual, expected, preset)


def test_tolerance_tells_nearby_moments_apart(browser):
    """The tolerance is not so loose that it hides motion: a quarter of a simulated second later, case A's
    picture no longer matches its reference."""
    expected = reference("triple-a")
    later = render(browser, "triple-a", REFERENCE_TIME + 0.25)
    fraction = pictures.differing_fraction(later, expected)
    assert fraction > 2 * pictures.FRACTION_TOLERANCE, (
        f"only {100 * fraction:.3f} % of pixels differ 0.25 s later: the tolerance would not notice motion"
    )


def test_blank_or_mechanism_free_pictures_fail_the_checks():
    """A blank picture, and one with every bar painted over in the background colour, fail both the
    reference comparison and the bar-colour check."""
    expected = reference("triple-a")
    blank = np.full_like(expected, 255)
    assert pictures.differing_fraction(blank, expected) > pictures.FRACTION_TOLERANCE
    assert bars_drawn(blank, "triple-a") == {1: 0, 2: 0, 3: 0}
    from app.scene import BAR_COLORS

    no_bars = expected.copy()
    for colour in BAR_COLORS[:3]:
        no_bars[pictures.colour_match(no_bars, colour)] = 255
    assert set(bars_drawn(no_bars, "triple-a")) == {1, 2, 3}
