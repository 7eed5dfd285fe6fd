"""The Equations tab collects the coefficient of each unknown (issue 26): a Lagrange row reads
"(I1 + d1² m1 + L1² m2 + L1² m3) θ̈1 + ...", each acceleration once, not once per expanded term; for reading
only: physics' rows (the derivation) keep their expanded terms."""

from __future__ import annotations

import re

import physics
from app import equations
from conftest import wait_until


def _acceleration(k: int) -> str:
    """θ̈_k as the tab's MathML prints it (an accent over θ, subscript k)."""
    return f'<msub><mover accent="true"><mi>&#952;</mi><mo>&#168;</mo></mover><mi>{k}</mi></msub>'


def test_lagrange_rows_show_each_acceleration_once(connect):
    _, session = connect()  # triple-a: three bars
    session.set("method", "lagrange")
    session.show_equations()  # what the Equations tab's button calls
    chain = session.params.chain
    shown = physics.equations_of_motion(chain, "lagrange")
    assert wait_until(lambda: f"{len(shown.rows)} equations" in session.equations.content, timeout=180)
    content = session.equations.content
    rows = re.split(r"<p><b>\d+\. ", content)[1:]
    assert len(rows) == len(shown.rows) == chain.n
    for (name, lhs_terms, _), row in zip(shown.rows, rows, strict=True):
        expanded = [str(term).count("θ̈_1") for term in lhs_terms]
        assert sum(expanded) > 1 or name != shown.rows[0][0]  # the derivation's row 1 has θ̈1 in several terms
        for k in range(1, chain.n + 1):
            assert row.count(_acceleration(k)) == 1, (name, k, row.count(_acceleration(k)))
    # the collected row is the same equation: coefficient times unknown, summed, is the derivation's left side
    for row_lhs, (_, lhs_terms, _) in zip((equations.collected_terms(lhs, shown.unknowns) for _, lhs, _ in shown.rows),
                                         shown.rows, strict=True):
        rebuilt = sum((coefficient * (unknown if unknown is not None else 1) for coefficient, unknown in row_lhs), 0)
        assert (rebuilt - sum(lhs_terms, 0)).expand() == 0


def test_collecting_leaves_the_derivation_alone():
    chain = physics.get_preset("triple-a").chain
    before = [list(lhs) for _, lhs, _ in physics.equations_of_motion(chain, "lagrange").rows]
    equations.equations_html(chain, "lagrange")
    after = [list(lhs) for _, lhs, _ in physics.equations_of_motion(chain, "lagrange").rows]
    assert before == after and len(before[0]) > chain.n  # still the expanded terms, more than one per unknown
