"""The Equations tab within the panel's width (issue 26, "Equations that fit"): for a 12-bar chain and every
method, nothing of the equations runs past the panel's right edge, and they keep a margin from its border,
measured in Chromium."""

from __future__ import annotations

import pytest

from app import snapshot as snap

from .conftest import wait_until

pytestmark = pytest.mark.browser

# The equations' widest content against the panel: every MathML element's edges, and every box holding or inside
# the equations (one wider than its own view would be a horizontal scroll bar).
OVERFLOW = """
() => {
  const panel = document.querySelector('[data-testid="floating-panel"]');
  const p = panel.getBoundingClientRect();
  const maths = [...panel.querySelectorAll('math')];
  let right = -Infinity, left = Infinity;
  for (const m of maths) {
    const r = m.getBoundingClientRect();
    if (!r.width) continue;
    right = Math.max(right, r.right); left = Math.min(left, r.left);
  }
  let overflow = 0, where = "";
  for (const e of panel.querySelectorAll('*')) {
    if (!e.querySelector('math') && !e.closest('math')) continue;  // the equations and the boxes holding them
    if (e.clientWidth > 0 && e.scrollWidth > e.clientWidth + 1 && e.scrollWidth - e.clientWidth > overflow) {
      overflow = e.scrollWidth - e.clientWidth;
      where = `${e.tagName}.${e.className} ${(e.textContent || "").slice(0, 60)}`;
    }
  }
  return {count: maths.length, left: left, right: right, panelLeft: p.left, panelRight: p.right, overflow: overflow,
          where: where};
}
"""


@pytest.mark.parametrize("method", ["newton_euler", "lagrange", "dae"])
def test_twelve_bar_equations_fit_the_panel(start_lab, method):
    lab = start_lab(preset="chain", links=12)
    page = lab.open_page()
    session = page.session
    assert session.params.n == 12
    session.set("method", method)
    page.open_tab("Equations")
    page.page.get_by_role("button", name="Show the equations of the method").click()
    wait_until(lambda: "equations" in session.equations.content and "<math" in session.equations.content,
               timeout_s=180, message="the equations derived")
    page.page.locator(f"{snap.CONTROL_PANEL} math").first.wait_for()
    page.page.wait_for_timeout(500)  # MathML laid out
    measured = page.page.evaluate(OVERFLOW)
    assert measured["count"] >= 12, measured  # a row each, at least
    assert measured["right"] <= measured["panelRight"] and measured["left"] >= measured["panelLeft"], (
        f"{method}: the equations run past the panel ({measured})")
    assert measured["overflow"] == 0, f"{method}: the Equations tab scrolls sideways ({measured})"
    # and not flush against the panel's border (issue 26): a margin of at least 8 px on the left, 4 px on the right
    assert measured["left"] - measured["panelLeft"] >= 8.0 and measured["panelRight"] - measured["right"] >= 4.0, (
        f"{method}: the equations touch the panel's border ({measured})")
