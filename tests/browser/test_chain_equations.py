"""A chain's Equations tab in the page (issue 24): the equations of the mechanism its runs integrate, drawn as
maths in the chain's names, and its LaTeX download handed to the browser."""

from __future__ import annotations

import re

from .conftest import wait_until


def test_a_chains_equations_and_their_latex_in_the_page(start_lab, tmp_path):
    import physics

    lab = start_lab(preset="four-bar")
    page = lab.open_page()
    session = page.session
    session.set("method", "lagrange")
    page.show_time(0.5)  # paused: the picture settles
    page.open_tab("Equations")
    page.page.get_by_role("button", name="Show the equations of the method").click()
    shown = physics.equations_of_motion(session.params.chain, "lagrange")
    wait_until(lambda: f"{len(shown.rows)} equations" in session.equations.content,  # the one session's Equations tab
               timeout_s=180, message="the equations derived")
    heading = page.page.get_by_text("Lagrange equation for θ", exact=False).first  # the chain's names
    heading.wait_for()
    heading.scroll_into_view_if_needed()
    assert page.page.locator("math").count() > len(shown.rows)  # the unknowns and every row, as MathML
    page.picture("chain-equations")

    page.page.get_by_role("button", name="Download as LaTeX").click()
    link = page.page.get_by_role("link", name=re.compile(r"equations-lagrange-3-pinned\.tex")).first
    link.wait_for()
    with page.page.expect_download() as download_info:
        link.click()
    path = tmp_path / download_info.value.suggested_filename
    download_info.value.save_as(path)
    tex = path.read_text()
    assert tex.startswith(r"\documentclass") and r"\ddot{\theta}_{3}" in tex and r"\lambda_{1}" in tex
