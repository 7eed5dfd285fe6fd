"""Angle-vs-time and phase-portrait plots beside the energy plot (issue 14): chosen in the panel, each drawn from
the stored run."""

from __future__ import annotations

import numpy as np
import pytest

from app.phase_view import (
    BAR_COLORS,
    HEIGHT,
    MARGIN_BOTTOM,
    MARGIN_LEFT,
    MARGIN_RIGHT,
    MARGIN_TOP,
    WIDTH,
    phase_picture,
)
from conftest import wait_until
from physics import LinkageError


def test_a_phase_picture_puts_a_circle_where_it_belongs():
    s = np.linspace(0.0, 2 * np.pi, 400)
    theta = np.column_stack([90.0 * np.cos(s)])
    omega = np.column_stack([100.0 * np.sin(s)])
    picture = phase_picture(theta, omega)
    assert picture.shape == (HEIGHT, WIDTH, 3)
    coloured = np.all(np.abs(picture.astype(int) - BAR_COLORS[0]) < 30, axis=2)
    legend = 18  # the legend's "bar 1", in the bar's colour, sits in the plot's top row
    rows, cols = np.nonzero(coloured[MARGIN_TOP + legend:HEIGHT - MARGIN_BOTTOM, MARGIN_LEFT:WIDTH - MARGIN_RIGHT])
    plot_w = WIDTH - MARGIN_RIGHT - MARGIN_LEFT
    # theta spans -90..90 of -180..180: the middle half of the plot's width
    assert cols.min() == pytest.approx(plot_w / 4, abs=4) and cols.max() == pytest.approx(3 * plot_w / 4, abs=4)
    # an angle that wraps round breaks the line instead of drawing across the plot
    wrap = phase_picture(np.array([[170.0], [175.0], [-175.0], [-170.0]]), np.array([[0.0], [0.0], [0.0], [0.0]]))
    middle = np.all(np.abs(wrap.astype(int) - BAR_COLORS[0]) < 30, axis=2)[:, WIDTH // 2 - 20: WIDTH // 2 + 20]
    assert not middle.any()


def test_each_plot_is_chosen_and_drawn_from_the_run(connect):
    _, session = connect()
    session.set_mechanism("triple-a")
    assert session.plot_kind == "energy" and session.energy_plot.handle.visible
    assert not session.phase_image.visible and not session.coordinate_plot.handle.visible
    session.play()
    assert wait_until(lambda: session.snapshot()["time"] > 1.0, timeout=30)

    session.plot_choice.value = "Angles θ(t)"  # as the browser sends it
    angles = session.coordinate_plot
    assert angles.handle.visible and not session.energy_plot.handle.visible
    assert len(angles.labels) == 3
    session.pause()
    assert wait_until(lambda: angles.points_shown > 10, timeout=10)
    data = angles.handle.data
    history = session.history()
    last = np.searchsorted(history["t"], data[0][-1])
    assert data[1][-1] == pytest.approx(np.degrees(history["theta"][last, 0]), abs=1e-6)

    blank = session.phase_image.image.copy()
    session.plot_choice.value = "Phase portrait (θ, ω)"
    assert session.phase_image.visible and not angles.handle.visible
    assert wait_until(lambda: not np.array_equal(session.phase_image.image, blank), timeout=10)

    session.set_mechanism("double")
    angles = session.coordinate_plot  # the Angles plot of the new chain: one series per bar
    assert len(angles.labels) == 2 and not angles.handle.visible  # phase still chosen
    with pytest.raises(LinkageError, match="plot = 'bogus'"):
        session.choose_plot("bogus")


def test_a_phase_pictures_text_is_at_least_12_px_tall_as_the_panel_shows_it():
    """Issue 26: every figure in the panel readable at the panel's width. The picture is drawn at about the
    panel's width (shown near 1:1), so its text's ink, ascenders to descenders, must span 12 px or more (the
    bitmap font it had spans 10)."""
    assert WIDTH <= 384
    picture = phase_picture(np.zeros((3, 1)), np.zeros((3, 1)))
    title = (picture.max(axis=2) < 120)[:MARGIN_TOP - 2, MARGIN_LEFT:250]  # "Phase portrait: omega (deg/s)"
    rows = np.flatnonzero(title.any(axis=1))
    assert rows.size and rows.max() - rows.min() + 1 >= 12, rows
