"""A general mechanism's Analysis folder in a real browser (issue 24): opened and clicked as a person would; the
rest poses' table, a refusal's notification and the work-precision chart appear in the page, and an ensemble's
copies in the scene."""

from __future__ import annotations

from pathlib import Path

from app.mechanism_analysis import ENSEMBLE_RATE, ENSEMBLE_SECONDS

from . import pictures
from .conftest import save_failure, wait_until

ANALYSIS_TIMEOUT_S = 240.0
ROOT = Path(__file__).resolve().parents[2]


def test_rest_poses_refusal_and_chart_in_the_page(start_lab):
    lab = start_lab(preset="slider-crank")
    app = lab.open_page()
    session = app.session
    analysis = session.analysis
    page = app.page
    page.get_by_text("Analysis", exact=True).first.click()  # the folder starts closed

    page.get_by_role("button", name="Rest poses").click()
    wait_until(lambda: bool(analysis.poses), timeout_s=ANALYSIS_TIMEOUT_S, message="the rest poses on the server")
    table = page.locator("table", has_text="stable").first
    table.wait_for(state="visible")
    # a header row and one row per pose, a column per body and two more
    assert table.locator("tr").count() == len(analysis.poses) + 1
    assert table.locator("th").count() == len(session.mechanism.bodies) + 2
    assert "yes" in table.locator("tr").nth(1).inner_text()  # the lowest pose is the stable one

    page.get_by_role("button", name="Chaos map (16 x 16)").click()
    refusal = page.locator(".mantine-Notification-root", has_text="Chaos map refused").first
    refusal.wait_for(state="visible")
    assert "mobility 1" in refusal.inner_text() and "mobility >= 2" in refusal.inner_text()

    page.get_by_role("button", name="Work-precision chart").click()
    wait_until(lambda: "<svg" in analysis.chart_html.content, timeout_s=ANALYSIS_TIMEOUT_S,
               message="the work-precision chart on the server")
    chart = page.locator("svg", has_text="Work-precision").first
    chart.wait_for(state="visible")
    box = chart.bounding_box()
    panel = app.panel_box()
    assert box is not None and panel is not None and 200 < box["width"] <= panel["width"], (box, panel)
    # a curve per method of a mobility-1 mechanism (three formulations and the reduced model)
    assert chart.locator('path[d^="M"]').count() >= 4
    text = chart.text_content() or ""
    assert all(f"{method} / DOP853" in text for method in ("newton_euler", "lagrange", "dae", "reduced"))
    done = page.locator(".mantine-Notification-root", has_text="work-precision chart of slider-crank").first
    done.wait_for(state="visible")


def test_ensemble_copies_are_drawn_over_the_mechanism(start_lab):
    lab = start_lab(preset="slider-crank")
    app = lab.open_page()
    session = app.session
    analysis = session.analysis
    text = (ROOT / "docs/examples/double-pendulum.toml").read_text()
    for old, new in (("A = [0.0, -1.0]", "A = [1.0, 0.0]"), ("B = [0.0, -2.0]", "B = [2.0, 0.0]"),
                     ("com = [0.0, -0.5]", "com = [0.5, 0.0]"), ("com = [0.0, -1.5]", "com = [1.5, 0.0]")):
        text = text.replace(old, new)  # sketched horizontal: released from there, it moves chaotically
    session.guard(lambda: session.load_file(None, "flat-double-pendulum.toml", text.encode()))
    session.pause()
    assert session.mobility == 2
    app.page.get_by_text("Analysis", exact=True).first.click()
    app.page.get_by_role("checkbox", name="Ensemble", exact=True).check()
    wait_until(lambda: analysis.ensemble_node is not None, timeout_s=ANALYSIS_TIMEOUT_S,
               message="the ensemble's copies on the server")
    late = ENSEMBLE_SECONDS - 0.5  # the copies have parted by then
    assert session.player.seek(analysis._ensemble_t0 + late, timeout=120)
    wait_until(lambda: analysis._ensemble_index == round(late * ENSEMBLE_RATE), message="the copies near their end")
    app.wait_for_server_poses()
    with_copies = app.picture("mechanism-ensemble-on")

    app.page.get_by_role("checkbox", name="Ensemble", exact=True).uncheck()
    wait_until(lambda: analysis.ensemble_node is None, message="the copies removed on the server")
    without = app.picture("mechanism-ensemble-off")
    outside = ~pictures.box_mask(with_copies.shape, app.panel_box())
    changed = float(pictures.differing(with_copies, without)[outside].mean())
    if changed <= 5 * pictures.FRACTION_TOLERANCE:
        save_failure("mechanism-ensemble", with_copies, without)
    assert changed > 5 * pictures.FRACTION_TOLERANCE, f"the copies barely show ({changed:.4f} of the scene)"
