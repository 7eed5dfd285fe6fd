"""The Equations folder of a general mechanism (issue 24): the linear system A x = b that the chosen method
integrates, derived by physics for this mechanism, its rows named after its bodies and joints."""

from __future__ import annotations

from conftest import lab_of
from physics.mechanism import derived_system

crank_lab = lab_of("slider-crank")


def test_the_equations_are_the_methods_system_for_this_mechanism(crank_lab, connect):
    _, session = connect(crank_lab)
    session.show_equations(wait=True)
    content = session.equations.content
    system = derived_system(session.mechanism, "dae")
    assert f"{system.A.shape[0]} equations" in content and "DAE" in content
    for number, name in enumerate(system.equation_names, start=1):
        assert f"<b>{number}. {name.replace(chr(39), '&#x27;')}</b>" in content, name
    assert content.count("<math") > system.A.shape[0]  # the unknowns and every row
    assert "crank" in content and "q0" not in content  # coordinates by the bodies' names

    session.guard(lambda: session.set_method("newton_euler"))
    session.show_equations(wait=True)
    tree = derived_system(session.mechanism, "newton_euler")
    assert f"{tree.A.shape[0]} equations" in session.equations.content and "Newton" in session.equations.content

    session.guard(lambda: session.set_method("reduced"))
    session.show_equations(wait=True)
    assert "no symbolic system of its own" in session.equations.content


def test_an_older_derivation_ending_later_does_not_replace_the_newer(crank_lab, connect):
    """A change of method re-derives in a thread; the first derivation of a method (sympy) can end after the
    next one asked for: what it finds is dropped, the folder shows the latest method's equations (the CI
    rehearsal caught Newton-Euler's replacing the reduced model's notice)."""
    import threading  # noqa: PLC0415

    _, session = connect(crank_lab)
    release, older_asked = threading.Event(), threading.Event()
    contents = iter(["<p>older</p>", "<p>newer</p>"])

    def slow_then_fast():
        content = next(contents)
        older_asked.set()

        def content_now() -> str:
            if content == "<p>older</p>":
                assert release.wait(60)
            return content
        return content_now

    session._equations_content = slow_then_fast
    older = threading.Thread(target=lambda: session.show_equations(wait=True))
    older.start()
    assert older_asked.wait(60)  # the older one asked first
    session.show_equations(wait=True)
    assert session.equations.content == "<p>newer</p>"
    release.set()
    older.join(60)
    assert not older.is_alive()
    assert session.equations.content == "<p>newer</p>"
