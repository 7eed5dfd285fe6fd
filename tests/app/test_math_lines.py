"""Long equations are broken between terms: the LaTeX export and the Equations panel fit their page."""

from __future__ import annotations

import re

import pytest

import physics
from app.equations import PANEL_LINE_CHARACTERS, equations_html, equations_tex, latex_rows
from app.math_lines import TEX_LINE_CHARACTERS, split_latex_terms, wrap_latex_equation

CHAIN = physics.get_preset("triple-a").chain  # three bars, open


def _unbroken(text: str) -> str:
    """The equation as it was before breaking: delimiters restored, spaces dropped."""
    return text.replace("\\Bigl(", "\\left(").replace("\\Bigr)", "\\right)").replace(" ", "")


def test_terms_split_only_at_top_level_binary_signs():
    assert split_latex_terms(r"a + b \left(c - d\right) - e^{-2} + \frac{x-1}{2}") == [
        "a", r"+ b \left(c - d\right)", "- e^{-2}", r"+ \frac{x-1}{2}",
    ]
    assert split_latex_terms(r"- a \sin{\left(\theta_{1} \right)} + 2") == [r"- a \sin{\left(\theta_{1} \right)}", "+ 2"]


@pytest.mark.parametrize("formulation", ["newton_euler", "lagrange", "dae"])
def test_latex_rows_break_into_short_lines_that_rebuild_the_equation(formulation):
    rows = [row for _, row in latex_rows(physics.equations_of_motion(CHAIN, formulation))]
    longest_before = max(len(row) for row in rows)
    if formulation != "dae":  # minimal-coordinate rows are long: the test means something
        assert longest_before > 3 * TEX_LINE_CHARACTERS
    for row in rows:
        lines = wrap_latex_equation(row)
        assert _unbroken("".join(lines)) == _unbroken(row)
        assert max(len(line) for line in lines) <= TEX_LINE_CHARACTERS + 10, lines
        for line in lines:  # every line is valid on its own: \left/\right and braces pair up within it
            assert line.count("\\left") == line.count("\\right"), line
            assert line.count("{") == line.count("}"), line
        assert sum(line.startswith("= ") for line in lines) == 1


def test_latex_document_has_no_overlong_lines():
    tex = equations_tex(CHAIN, "lagrange")
    assert "\\begin{multline*}" in tex and " \\\\\n" in tex
    assert max(len(line) for line in tex.splitlines()) <= TEX_LINE_CHARACTERS + 20


@pytest.mark.slow  # renders every formulation's equations (sympy)
def test_panel_rows_are_broken_into_lines_of_maths():
    html = equations_html(CHAIN, "lagrange")
    rows = re.split(r"<p><b>\d+\. ", html)[1:]
    assert len(rows) == 3
    assert "theta_" not in html and "\u03b8<sub>1</sub>" in html  # headings read as maths
    for row in rows:
        blocks = re.findall(r"<div style=\"margin[^>]*><math>(.*?)</math></div>", row, flags=re.S)
        assert len(blocks) >= 3, "a Lagrange row of a 3-bar chain spans several lines"
        text_lengths = [len(re.sub(r"<[^>]+>", "", block)) for block in blocks]
        assert max(text_lengths) <= 3 * PANEL_LINE_CHARACTERS, text_lengths
        assert sum("<mo>=</mo>" in block for block in blocks) == 1
