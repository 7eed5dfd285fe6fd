"""The status line marks a notice with the warning sign only when it is a warning (a refusal, a failure): a study's
"Done" or a "Computing" notice is news and is shown plain."""

from __future__ import annotations

import pytest

from app.notices import WARNING_COLORS
from conftest import wait_until


@pytest.mark.parametrize(("title", "color", "warned"), [("Done", "green", False), ("Computing", "blue", False),
                                                          ("Not applied", "yellow", True),
                                                          ("Simulation stopped", "red", True)])
def test_the_status_line_prefixes_a_warning_sign_to_warnings_only(connect, title, color, warned):
    _, session = connect()
    session.player.pause()
    session.show_notice(title, "what happened", color=color)
    assert wait_until(lambda: "what happened" in session.status.content, timeout=30), session.status.content
    line = next(row for row in session.status.content.split("\n") if "what happened" in row)
    assert line.startswith("⚠ ") is warned, line
    assert (color in WARNING_COLORS) is warned
