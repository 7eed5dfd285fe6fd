"""One equations view for both panels (issue 24): a chain's Equations tab shows the equations of the mechanism its
runs integrate (physics.equations_of_motion of the chain, the same rendering as a general mechanism's), and
"Download as LaTeX" works for a chain and for a general mechanism from the same code."""

from __future__ import annotations

import re

import pytest

import physics
from app import equations, readout
from conftest import lab_of, wait_until
from physics import LinkageError

crank_lab = lab_of("slider-crank")


def _balanced(tex: str) -> bool:
    depth = 0
    for char in re.sub(r"\\[{}]", "", tex):  # escaped braces are text
        depth += {"{": 1, "}": -1}.get(char, 0)
        if depth < 0:
            return False
    return depth == 0


@pytest.mark.parametrize("method", ["lagrange", "newton_euler", "dae"])
def test_a_chains_tab_shows_the_integrated_mechanisms_equations(connect, method):
    _, session = connect()
    session.set("method", method)
    session.show_equations()  # what the Equations tab's button calls
    chain = session.params.chain
    expected = equations.equations_html(chain, method)  # the mechanism path's rendering (one view for both)
    assert wait_until(lambda: session.equations.content == expected, timeout=180), \
        session.equations.content[:300]
    shown = physics.equations_of_motion(chain, method)
    assert f"{len(shown.rows)} equations" in expected
    for number, (name, _, _) in enumerate(shown.rows, start=1):
        assert f"<b>{number}. " in expected, name
    # the chain's names (docs/physics.md), not the structure's symbols
    assert "θ" in expected and "<mi>q0</mi>" not in expected and "<mi>m0</mi>" not in expected


@pytest.mark.parametrize("method", ["lagrange", "dae"])
def test_a_chains_latex_download(connect, method):
    _, session = connect()
    session.set("method", method)
    name, content = readout.download_file(session, "tex")
    tex = content.decode("utf-8")
    assert name.endswith(".tex") and method in name
    assert tex.startswith(r"\documentclass") and tex.rstrip().endswith(r"\end{document}") and _balanced(tex)
    assert tex.count(r"\begin{multline*}") == len(physics.equations_of_motion(session.params.chain, method).rows)
    for k in range(1, session.params.n + 1):
        assert rf"\ddot{{\theta}}_{{{k}}}" in tex  # the method's unknowns
    assert not re.search(r"[^\x00-\x7f]", tex), "pdflatex reads ASCII: every symbol is a macro"


def test_a_mechanisms_latex_download_and_the_reduced_refusal(crank_lab, connect):
    _, session = connect(crank_lab)
    session.guard(lambda: session.set_method("dae"))
    name, content = session.download_file("tex")
    tex = content.decode("utf-8")
    assert name == "equations-slider-crank-dae.tex" and _balanced(tex)
    assert all(unknown in tex for unknown in (r"\ddot{x}_{\mathrm{crank}}", r"\ddot{\varphi}_{\mathrm{piston}}",
                                              r"\lambda_{1}"))
    assert not re.search(r"[^\x00-\x7f]", tex), "pdflatex reads ASCII: every symbol is a macro"
    sent = []
    session.download_equations(client=type("Client", (), {"send_file_download": lambda self, *a: sent.append(a)})(),
                               wait=True)
    assert sent and sent[0][0] == name
    session.guard(lambda: session.set_method("reduced"))
    with pytest.raises(LinkageError, match="reduced"):
        session.download_file("tex")
