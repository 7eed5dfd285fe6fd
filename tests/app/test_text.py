"""The escape helpers every client-supplied text passes through before it becomes markdown or HTML."""

from __future__ import annotations

import re

from app.overlays import status_markdown
from app.text import html_literal, markdown_literal


def test_markdown_literal_leaves_no_tag_link_or_emphasis():
    hostile = "<iframe srcdoc=\"<script>x</script>\"> [a](javascript:x) **b** `c` &amp; <img onerror=y>"
    text = markdown_literal(hostile)
    assert "<" not in text and ">" not in text
    assert not re.search(r"(?<!\\)[\[\]()*`]", text)  # every markdown mark is escaped
    assert "&amp;amp;" in text  # an entity in the input stays visible as typed


def test_status_line_quotes_a_notice_as_text():
    line = status_markdown(1.0, True, 1.0, "Lagrange", None, None, "Not applied: method = '<b>x</b>'")
    assert "<b>" not in line and "&lt;b&gt;" in line


def test_html_literal_escapes_quotes_and_tags():
    assert html_literal("<a href='x'>\"") == "&lt;a href=&#x27;x&#x27;&gt;&quot;"


def test_status_line_never_shows_a_negative_real_time_factor():
    """Scrubbing back moves the shown time backwards over the rate window (issue 26: "real-time factor -7.12x")."""
    scrubbing = status_markdown(3.0, False, -7.12, "Lagrange", None, None, None)
    assert "-7.12" not in scrubbing and "real-time factor" not in scrubbing and "scrubbing" in scrubbing
    playing = status_markdown(3.0, True, 1.0, "Lagrange", None, None, None)
    assert "real-time factor 1.00×" in playing
