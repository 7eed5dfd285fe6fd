"""A general mechanism's Analysis folder in a real browser (issue 24): opened and clicked as a person would; the
rest poses' table, a refusal's notification and the work-precision chart appear in the page."""

from __future__ import annotations

from .conftest import wait_until

ANALYSIS_TIMEOUT_S = 240.0


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
