"""The seed report's figures in the Report tab: every figure is there, scaled to the panel, with its numbers."""

from __future__ import annotations

import base64
import re

from app import report_view


def test_every_figure_is_shown_as_a_panel_wide_image_with_the_numbers_of_the_json():
    document = report_view.load_document()
    assert document is not None
    for figure in report_view.FIGURES:
        html = report_view.figure_html(figure, document=document)
        data = re.search(r'src="data:image/svg\+xml;base64,([^"]+)"', html).group(1)
        assert base64.b64decode(data) == (report_view.SEED_REPORT_FOLDER / figure.file).read_bytes()
        assert "width:100%" in html and "docs/seed-report.md" in html
    case_c = report_view.FIGURES[2]
    departure = document["triple"]["C"]["departure_time"]
    assert f"t = {departure:.4g} s" in report_view.figure_html(case_c, document=document)
    four_bar = report_view.figure_html(report_view.FIGURES[6], document=document)
    assert f"{document['four_bar']['report']['theta1_departure']:.4g} s" in four_bar
    # Both controllers: the report's ode45 and scipy's RK45, each number read from the JSON.
    rk45 = document["scipy_rk45"]
    assert f"{rk45['triple']['C']['departure_time']:.4g} s with RK45" in report_view.figure_html(case_c,
                                                                                               document=document)
    assert f"{rk45['four_bar']['report']['pin_gap_max']:.2g} with RK45" in four_bar


def test_a_missing_figure_points_to_the_command(tmp_path):
    html = report_view.figure_html(report_view.FIGURES[0], folder=tmp_path)
    assert "python -m physics seed-report" in html and "<img" not in html
    assert report_view.load_document(tmp_path) is None


def test_the_report_tab_opens_on_the_first_figure(connect):
    _, session = connect()
    # the one session's Report tab (app/session.py): ``seed_report``, a SeedReportPanel(gui, self._bind)
    panel = session.seed_report
    assert panel.choice.value == report_view.FIGURES[0].label
    panel.choice.value = report_view.FIGURES[5].label
    assert base64.b64encode((report_view.SEED_REPORT_FOLDER / report_view.FIGURES[5].file).read_bytes()).decode() \
        in panel.figure.content
