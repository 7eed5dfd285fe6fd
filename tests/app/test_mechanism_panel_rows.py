"""The chain panel's rows on a general mechanism's panel (issue 24, "One app session"): View, Plot, the energy
error and constraint residual plots, playback speed, trace length, arrow scale and the HTML replay, made by
app/panel_rows.py for both panels. Each control is driven as a browser drives it (its value stored, then its
callbacks) and must change what the session does."""

from __future__ import annotations

import math

import msgspec
import numpy as np
import pytest
import viser
from test_notebook import recording

from app import panel_rows, readout
from conftest import lab_of, wait_until
from physics import LinkageError

slider_crank_lab = lab_of("slider-crank")
jansen_lab = lab_of("jansen-leg")
LABS = ["slider_crank_lab", "jansen_lab"]


def press(session, handle, value) -> None:
    """What viser does with a browser's update of ``handle`` to ``value``: stored, then every callback."""
    handle._impl.value = value
    for callback in list(handle._impl.update_cb):
        callback(viser.GuiEvent(session.target, session.target.client_id, handle))


def _played(session, seconds: float) -> None:
    session.play()
    assert wait_until(lambda: session.player.display_time > seconds, timeout=120), session.notices.text


@pytest.fixture(params=LABS)
def seat(request, connect):
    _, session = connect(request.getfixturevalue(request.param))
    return session


def test_the_view_row_turns_the_camera_front_and_back(seat):
    session = seat
    camera = session.target.camera  # this browser's (the stand-in reported its canvas)
    assert session.camera_view.options == panel_rows.VIEWS and session.camera.view == "3d"
    start = np.array(camera.position)
    press(session, session.camera_view, "Front")
    assert session.camera.view == "front"
    assert wait_until(lambda: not np.allclose(camera.position, start, atol=1e-6), timeout=10)
    front = np.array(camera.position)
    assert abs(front[2] - camera.look_at[2]) < abs(start[2] - camera.look_at[2])  # level with it, not above
    press(session, session.camera_view, "3D")
    assert session.camera.view == "3d"
    assert wait_until(lambda: np.allclose(camera.position, start, atol=1e-6), timeout=10)
    with pytest.raises(LinkageError, match="view = 'Side'"):
        panel_rows.view_of("Side")


def test_the_plot_menu_shows_each_plot_drawn_from_the_run(seat):
    session = seat
    expected = {"slider-crank": ["crank: angle (°)"], "jansen-leg": ["crank: angle (°)"]}[session.label]
    assert session.plot_choice.options == panel_rows.MECHANISM_PLOT_CHOICES
    assert session.plot_kind == "energy" and session.energy_plot.handle.visible
    assert session.coordinate_plot.labels == expected and not session.coordinate_plot.handle.visible
    assert not session.phase_image.visible
    _played(session, 1.0)

    press(session, session.plot_choice, "Coordinates over time")
    assert session.plot_kind == "angles" and session.coordinate_plot.handle.visible
    assert not session.energy_plot.handle.visible and not session.drift_plot.handle.visible
    session.pause()
    assert wait_until(lambda: session.coordinate_plot.points_shown > 10, timeout=20)
    t_plotted, crank = session.coordinate_plot.handle.data[:2]
    history = readout.history(session.player)
    column = 3 * [b.name for b in session.mechanism.bodies].index("crank") + 2
    last = int(np.searchsorted(history["t"], t_plotted[-1]))
    assert crank[-1] == pytest.approx(math.degrees(history["q"][last, column]), abs=1e-6)
    assert np.ptp(crank) > 1.0  # the crank turns: degrees, not radians, and not a constant

    blank = session.phase_image.image.copy()
    press(session, session.plot_choice, "Phase portrait")
    assert session.phase_image.visible and not session.coordinate_plot.handle.visible
    assert wait_until(lambda: not np.array_equal(session.phase_image.image, blank), timeout=20)

    press(session, session.plot_choice, "Energy")
    assert session.energy_plot.handle.visible and not session.phase_image.visible
    with pytest.raises(LinkageError, match="plot = 'bogus'"):
        session.choose_plot("bogus")


def test_the_energy_error_and_the_constraint_residual_are_plotted_from_the_run(seat):
    """Both mechanisms close loops: their residual is plotted. The slider-crank has no motor: its energy error
    since the last change is plotted too (tiny); the Jansen leg's motor does work, so its error is hidden."""
    session = seat
    driven = bool(session.mechanism.drivers)
    assert session.residual_plot.handle.visible
    assert session.drift_plot.handle.visible == (not driven)
    assert session.drift_plot.handle.title == panel_rows.DRIFT_TITLE
    _played(session, 1.5)
    session.pause()
    assert wait_until(lambda: session.residual_plot.points_shown > 10, timeout=20)
    history = readout.history(session.player)
    t_plotted, log_residual = session.residual_plot.handle.data[:2]
    last = int(np.searchsorted(history["t"], t_plotted[-1]))
    assert log_residual[-1] == pytest.approx(math.log10(max(history["residual"][last], 1e-300)), abs=1e-9) \
        or history["residual"][last] < 1e-15
    assert np.max(log_residual) < -6  # the loops stay closed
    if not driven:
        assert wait_until(lambda: session.drift_plot.points_shown > 10, timeout=20)
        log_drift = session.drift_plot.handle.data[1]
        assert np.max(log_drift) < -4  # DOP853 at the panel's tolerance keeps the energy

    # an edit goes on from the displayed state: the error is measured since that change
    session.play()
    session.set("mass:crank", 0.5)
    changed_at = session._segment_t0
    assert changed_at > 1.0
    assert wait_until(lambda: session.player.display_time > changed_at + 0.5, timeout=60)
    if not driven:
        assert wait_until(lambda: session.drift_plot.handle.data[0][0] >= changed_at - 1e-9, timeout=20)


def test_the_playback_speed_and_its_box(seat):
    session = seat
    press(session, session.numbers.controls["speed"].slider, 2.0)
    assert session.display.speed == 2.0 and session.player.speed == 2.0
    box = session.typed_box("speed")
    box.value = "2.5e-1"
    assert wait_until(lambda: not session.typing(), timeout=10)
    assert session.player.speed == 0.25 and session.numbers.controls["speed"].slider.value == 0.25
    assert box.value == "0.25" and session.notices.text is None
    before = session.notices.text
    box.value = "1,5"
    assert wait_until(lambda: not session.typing(), timeout=10)
    notice = session.notices.text or ""
    assert notice != before and notice.startswith("Not applied") and "'1,5'" in notice and "\n" not in notice
    assert session.player.speed == 0.25 and box.value == "0.25"


@pytest.mark.parametrize("text, expected", [("2.5e1", 25.0), ("1e-3", 1e-3), ("-0", -0.0), ("1_0", 10.0)])
def test_the_trace_length_box_reads_numbers_as_every_box(slider_crank_lab, connect, text, expected):
    _, session = connect(slider_crank_lab)
    session.typed_box("trace_seconds").value = text
    assert wait_until(lambda: not session.typing(), timeout=10)
    assert session.display.trace_seconds == expected and session.notices.text is None
    assert session.typed_box("trace_seconds").value == f"{expected:.6g}"


def test_the_trace_length_sets_how_much_of_the_path_is_drawn(seat):
    session = seat
    session.set_trace(session.spec.draw.labels[0] if session.settings.trace is None else session.settings.trace)
    _played(session, 4.0)
    press(session, session.numbers.controls["trace_seconds"].slider, 1.0)
    assert session.display.trace_seconds == 1.0
    assert wait_until(lambda: 55 <= session.trace.points_shown <= 62, timeout=20), session.trace.points_shown
    press(session, session.numbers.controls["trace_seconds"].slider, 3.0)
    assert wait_until(lambda: 175 <= session.trace.points_shown <= 182, timeout=20), session.trace.points_shown


def _arrow_lengths(session) -> np.ndarray:
    points = np.asarray(session.arrows.handle.points, dtype=float)
    return np.linalg.norm(points[:, 1] - points[:, 0], axis=1)


def test_the_arrow_scale_sets_the_reaction_arrows_length(seat):
    session = seat
    _played(session, 0.5)
    session.pause()
    session.set_reactions(True)
    assert wait_until(lambda: session.arrows.handle is not None and session.arrows.handle.visible, timeout=20)
    before = _arrow_lengths(session)
    press(session, session.numbers.controls["arrow_scale"].slider, 1.0)  # twice the default
    assert session.display.arrow_scale == 1.0
    assert wait_until(lambda: np.allclose(_arrow_lengths(session), 2 * before, rtol=1e-4), timeout=20), (
        _arrow_lengths(session), before)


def test_the_html_replay_holds_the_run(seat):
    session = seat
    assert session.export_html.label == "Save HTML replay"
    _played(session, 2.0)
    session.pause()
    shown = session.player.display_time
    sent = []
    session.target.send_file_download = lambda name, content, **kw: sent.append((name, content))
    press(session, session.export_html, None)
    assert session.notices.text is None, session.notices.text
    ((name, content),) = sent
    assert name.endswith("-replay.html") and session.label in name
    payload, _ = recording(content.decode("utf-8"))
    assert payload["durationSeconds"] == pytest.approx(shown, abs=0.1)  # every sample up to the time shown
    assert f"Linkage Lab replay: {session.label}" in msgspec.json.encode(payload["messages"]).decode()


def test_a_second_mechanism_leaves_one_set_of_these_rows(slider_crank_lab, connect):
    _, session = connect(slider_crank_lab)
    rows = ("View", "Plot", "playback speed (×)", "Trace length (s)", "arrow scale", "Save HTML replay")

    def labels() -> list[str]:
        return sorted(h.label for h in session.target.gui._gui_input_handle_from_uuid.values() if h.label in rows)

    assert labels() == sorted(rows), labels()
    session.choose("jansen-leg")
    assert wait_until(lambda: session.player.wait_idle(1), timeout=60)
    session.choose("slider-crank")
    assert labels() == sorted(rows), labels()
