"""The Analysis tab in a real browser: the work-precision chart, the chaos map and the ensemble, clicked as a person
would, and checked both on the server and in the picture the page shows."""

from __future__ import annotations

import numpy as np

from app.mechanism_analysis import CHAIN_CHAOS_RESOLUTION

from . import pictures
from .conftest import save_failure, wait_until

ANALYSIS_TIMEOUT_S = 240.0


def test_chart_and_chaos_map_appear_in_the_page(start_lab):
    lab = start_lab(preset="triple-a")
    app = lab.open_page()
    session = app.session
    app.open_tab("Analysis")

    # the one session's Analysis tab (app/mechanism_analysis.py): the chart of the chain shown
    app.page.get_by_role("button", name="Work-precision chart", exact=True).click()
    wait_until(lambda: session.analysis.chart_html.content != "", timeout_s=ANALYSIS_TIMEOUT_S,
               message="the work-precision chart on the server")
    chart = app.page.locator("svg", has_text="Work-precision").first
    chart.wait_for(state="visible")
    box = chart.bounding_box()
    assert box is not None and box["width"] > 200 and box["height"] > 150, box
    # One polyline per configuration (RK45, DOP853, midpoint, variational for Lagrange), each with points.
    curves = chart.locator('path[d^="M"]').count()
    assert curves >= 4, f"{curves} curves drawn"
    assert "variational" in chart.text_content()

    # the chain tab's map: the double pendulum's, whatever chain is shown
    app.page.get_by_role("button", name=f"Chaos map (double pendulum, {CHAIN_CHAOS_RESOLUTION} x "
                         f"{CHAIN_CHAOS_RESOLUTION})").click()
    wait_until(lambda: session.analysis.image_handle is not None, timeout_s=ANALYSIS_TIMEOUT_S,
               message="the chaos map on the server")
    image = app.page.locator('img[src^="blob:"]').first  # viser hands the PNG to the page as a blob
    image.wait_for(state="visible")
    image.scroll_into_view_if_needed()
    shot = pictures.decode_png(image.screenshot())
    colours = len(np.unique(shot.reshape(-1, 3) // 16, axis=0))
    assert shot.shape[0] > 200 and shot.shape[1] > 200, shot.shape  # big enough to read
    assert colours > 8, f"the chaos map shows only {colours} colours"


def test_ensemble_fans_out_and_is_drawn(start_lab):
    lab = start_lab(preset="triple-a")
    app = lab.open_page()
    session = app.session
    app.open_tab("Analysis")
    # From the preset's own start at t = 0, paused: how soon a fan 1e-9 rad wide opens depends on where on the
    # chaotic trajectory it starts (built at 6 s it is still 0.02 m wide at 28 s, from t = 0 some 3 m), so the
    # copies start where the claim below is about, not wherever the autoplaying display happened to be.
    params = session.params
    session.guard(lambda: session.set_start(params.theta0, params.omega0))
    app.page.get_by_role("checkbox", name="Ensemble").check()
    analysis = session.analysis
    wait_until(lambda: analysis.ensemble_node is not None, timeout_s=ANALYSIS_TIMEOUT_S,
               message="the ensemble's node on the server")
    assert analysis.ensemble.count == 100 and analysis._ensemble_t0 == 0.0
    built = analysis._ensemble_generation
    # Chaos takes the copies (1e-9 rad apart) visibly apart after some 20-30 s of simulated time: play fast.
    session.set("speed", 4.0)
    session.play()
    # the chain's copies are advanced with the displayed time (app/mechanism_analysis.py follow): 30 s of it
    wait_until(lambda: analysis.ensemble is not None and analysis.ensemble.time > 30.0, timeout_s=ANALYSIS_TIMEOUT_S,
               message="30 s of ensemble time")
    session.pause()
    # the same ensemble all along, however slowly the server drew (a slow frame once restarted it, so on a
    # loaded machine the copies were put back together again and again)
    assert analysis._ensemble_generation == built, "the ensemble was restarted while playing"
    joints = analysis.ensemble.joints()  # (copies, n + 1, 2)
    spread = float(np.ptp(joints[:, -1, :], axis=0).max())
    assert spread > 0.5, f"the copies' tips are only {spread:.3g} apart after 30 s"
    app.wait_for_server_poses()
    with_ensemble = app.picture("analysis-ensemble-on")

    app.page.get_by_role("checkbox", name="Ensemble").uncheck()
    wait_until(lambda: analysis.ensemble_node is None, message="the ensemble removed on the server")
    without = app.picture("analysis-ensemble-off")
    outside = ~pictures.box_mask(with_ensemble.shape, app.panel_box())
    changed = float(pictures.differing(with_ensemble, without)[outside].mean())
    if changed <= 5 * pictures.FRACTION_TOLERANCE:
        save_failure("analysis-ensemble", with_ensemble, without)
    assert changed > 5 * pictures.FRACTION_TOLERANCE, f"the ensemble barely shows ({changed:.4f} of the scene)"
