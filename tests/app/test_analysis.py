"""The Analysis tab (issue 7) of a chain shown in the one session (app/mechanism_analysis.py): work-precision chart,
chaos map and ensemble, driven through the calls the tab's buttons make. The heavy work runs in worker threads;
these tests wait for them."""

from __future__ import annotations

import re

import numpy as np

from app.analysis import follows_on
from app.mechanism_analysis import CHAOS_DISPLAY_SCALE, CHAOS_RESOLUTION, ENSEMBLE_RATE
from conftest import wait_until
from physics.chain_presets import get_preset
from physics.studies import chaos_map as chaos

# A wait that includes a first compilation (an empty cache, as CI's): 131 s measured for the RK4 ensemble
# kernel alone at load average 11 on the project's 2 cores; a wait for the condition, so no slower when warm.
FIRST_COMPILE_SECONDS = 600


def test_work_precision_chart_appears_in_the_panel(connect):
    _, session = connect()
    assert session.chain is not None  # the server's chain preset, hosted in the one session
    session.pause()
    session.guard(session.analysis.work_precision_chart)  # the tab's "Work-precision chart" button
    assert "Computing" in session.analysis.chart_status.content
    session.analysis.wait("chart", timeout=FIRST_COMPILE_SECONDS)
    content = session.analysis.chart_html.content
    assert "<svg" in content and "</svg>" in content, (session.notice, session.analysis.chart_status.content)
    # drawn for the panel: its width follows the panel, its legend sits under the plot, inside the picture
    root = re.search(r"<svg [^>]*>", content).group(0)
    assert 'width="100%"' in root and 'viewBox="0 0 380 ' in root
    view_height = float(re.search(r'viewBox="0 0 380 ([\d.]+)"', root).group(1))
    legend_y = [float(y) for y in re.findall(r'<text x="44" y="([\d.]+)" font-size="11"', content)]
    assert legend_y and max(legend_y) < view_height


def test_chaos_map_image_appears(connect):
    _, session = connect()
    session.pause()
    session.guard(session.analysis.chaos_map)  # the tab's "Chaos map" button
    session.analysis.wait("chaos", timeout=FIRST_COMPILE_SECONDS)
    handle = session.analysis.image_handle
    assert handle is not None, (session.notice, session.analysis.chaos_status.content)
    image = np.asarray(handle.image)

    side = CHAOS_RESOLUTION * CHAOS_DISPLAY_SCALE
    assert image.shape[1] <= 384, "wider than the panel"
    top, left = chaos.FRAME_TOP, chaos.FRAME_LEFT
    assert image.shape[0] > side + top and image.shape[1] > side + left  # axes, colour bar and key around it
    mapped = image[top:top + side, left:left + side]
    # Each map pixel is a uniform block of the display scale.
    blocks = mapped.reshape(CHAOS_RESOLUTION, CHAOS_DISPLAY_SCALE, CHAOS_RESOLUTION, CHAOS_DISPLAY_SCALE, 3)
    assert np.all(blocks == blocks[:, :1, :, :1, :])
    assert len(np.unique(mapped.reshape(-1, 3), axis=0)) > 4  # a picture, not a flat fill


def test_ensemble_node_exists_moves_and_goes_away(connect):
    _, session = connect()
    analysis = session.analysis
    session.guard(lambda: analysis.set_ensemble(True, 100))  # the tab's Ensemble box, 100 copies
    assert wait_until(lambda: analysis.ensemble_node is not None, timeout=FIRST_COMPILE_SECONDS), \
        analysis.ensemble_status.content
    node = analysis.ensemble_node
    n = session.params.n
    first = np.array(node.points)
    assert first.shape == (100 * n, 2, 3)  # every copy's bars
    assert np.all(first[:, :, 1] == 0.0)  # in the mechanism's x-z plane
    session.play()
    assert wait_until(lambda: analysis.ensemble_node is not None
                      and not np.allclose(np.array(analysis.ensemble_node.points), first), timeout=30)  # it moves
    assert analysis.ensemble is not None and analysis.ensemble.alive.all()
    session.guard(lambda: analysis.set_ensemble(False))
    assert analysis.ensemble_node is None and analysis.ensemble is None


def test_bad_ensemble_count_is_a_notice(connect):
    _, session = connect()
    session.guard(lambda: session.analysis.set_ensemble(True, 7))
    assert session.notice is not None and "ensemble copies = 7: allowed 20, 100" in session.notice
    assert session.analysis.ensemble_node is None


def test_the_ensemble_stays_on_the_displayed_pendulum_and_shows_its_spread(connect):
    """Issue 14: the ensemble (computed apart) drifted away from the displayed pendulum (the run shown); copy 0
    must be on it at every sample the two share, and the spread is plotted."""
    _, session = connect()
    session.set_mechanism("triple-a")
    # Paused until the copies are built (a display playing meanwhile would be far on before they arrive).
    session.pause()
    analysis = session.analysis
    session.guard(lambda: analysis.set_ensemble(True, 100))
    assert wait_until(lambda: analysis.ensemble is not None, timeout=FIRST_COMPILE_SECONDS), \
        analysis.ensemble_status.content
    t0 = analysis._ensemble_t0
    session.play()
    assert wait_until(lambda: session.snapshot()["time"] > t0 + 6.0, timeout=60)
    session.pause()
    with session.player.lock:  # the copies and the display read together
        copies = analysis._ensemble_q
        assert copies is not None, analysis.ensemble_status.content
        latest = min(int(round((session.player.display_time - t0) * ENSEMBLE_RATE)), len(copies) - 1)
        for index in range(latest, 0, -1):  # the copies' latest sample that is one of the displayed run's
            shown = session.state_at(t0 + index / ENSEMBLE_RATE, exact=True)
            if shown is not None:
                break
        assert shown is not None and index / ENSEMBLE_RATE > 5.0
        copy0 = np.angle(np.exp(1j * (copies[index, 0, 2::3] - shown[0])))  # body turns are the bar angles
        gap = float(np.max(np.abs(copy0)))
        at = t0 + index / ENSEMBLE_RATE
        assert gap <= 1e-12, f"copy 0 is {gap:.3g} rad from the displayed pendulum at t = {at:.3g} s"
        plot = analysis.spread_plot
        assert plot.handle.visible and plot.points_shown > 10
        spread = np.asarray(plot.handle.data[1])
    assert spread[-1] > spread[0]  # the fan opens (log10 of the spread)


def test_a_slow_frame_advances_the_ensemble_and_a_jump_back_restarts_it():
    """A loaded server draws fewer frames, so each advances the display further (4x speed at 2 frames/s is 2 s
    a frame): the ensemble must follow, not start again from the displayed state, or it never fans out (the
    browser test of the ensemble failed on a loaded machine for this)."""
    fastest_speed, slow_server_fps = 8.0, 2.0
    assert follows_on(fastest_speed / slow_server_fps)
    assert follows_on(0.0) and follows_on(1.0 / 60.0)
    assert not follows_on(-1e-3)  # the timeline dragged back
    assert not follows_on(60.0)  # or far ahead


def test_copies_built_while_the_display_played_on_are_brought_to_it_not_built_again():
    """On a loaded machine the copies took longer to build than ``MAX_FRAME_DT`` of playback; the next frame
    took the gap for a jump and built them again, for ever (CI: no ensemble to compare after 6 s of play).
    ``catch_up`` advances them to the display before they are shown."""
    from app.analysis import MAX_FRAME_DT, catch_up  # noqa: PLC0415
    from physics.ensemble import Ensemble  # noqa: PLC0415

    preset = get_preset("triple-a")
    ensemble = Ensemble(preset.chain, preset.theta0, preset.omega0, "lagrange", 8, 1e-6)
    display = iter([3.0 * MAX_FRAME_DT, 3.3 * MAX_FRAME_DT, 3.3 * MAX_FRAME_DT + 0.01])  # moves on meanwhile
    shown = catch_up(ensemble, 0.0, lambda: (next(display), None, None))
    assert shown == 3.3 * MAX_FRAME_DT + 0.01 and follows_on(shown + 1.0 / 60.0 - shown)
    assert abs(ensemble.time + ensemble.pending - shown) < 1e-9  # the copies stand where the display is
    assert catch_up(ensemble, shown, lambda: (shown - 1.0, None, None)) == shown  # a jump back: left to a frame
    assert catch_up(ensemble, shown, lambda: None) == shown
