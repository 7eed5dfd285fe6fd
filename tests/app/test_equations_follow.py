"""The Equations tab never shows another method's system: once shown, it follows the method in force."""

from __future__ import annotations

from conftest import wait_until


def test_equations_follow_a_method_change(connect):
    _, session = connect()
    session.set("method", "lagrange")
    session.show_equations()  # what the Equations tab's button calls
    content = lambda: session.equations.content  # noqa: E731
    assert wait_until(lambda: "<b>Lagrange</b>" in content() and "<math" in content(), timeout=120)
    session.set("method", "dae")
    assert wait_until(lambda: "<b>DAE" in content() and "<math" in content(), timeout=120), content()[:200]
    assert "Lagrange equation" not in content()
    session.set("method", "newton_euler")
    assert wait_until(lambda: "<b>Newton" in content() and "<math" in content(), timeout=120), content()[:200]
