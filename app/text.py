"""The one place where text from outside (a client's control value, an error message quoting it, a file name)
becomes markdown or HTML.

viser renders ``add_markdown`` content with raw HTML enabled and ``add_html`` content as HTML, so any text that
may carry a client's input must pass through here first: otherwise ``<iframe srcdoc="<script>...">`` sent as a
control value would run in every browser that shows the status line (in ``--shared`` mode, every viewer).
Notifications are rendered by viser as plain text and need nothing.
"""

from __future__ import annotations

import html
import re

# Characters with a meaning in CommonMark (emphasis, links, code, headings, lists, tables, HTML, entities).
_MARKDOWN_SPECIAL = re.compile(r"([\\`*_{}\[\]()<>#+\-.!|~&:])")


def markdown_literal(text: object) -> str:
    """``text`` as markdown that displays exactly those characters and renders no markup, link or HTML."""
    escaped = _MARKDOWN_SPECIAL.sub(r"\\\1", str(text))
    # A backslash-escaped '<' or '&' is still literal text in CommonMark; as entities they are literal in the
    # raw-HTML pass too, whichever of the two a renderer applies first.
    return escaped.replace("\\<", "&lt;").replace("\\>", "&gt;").replace("\\&", "&amp;").replace("\n", " ")


def html_literal(text: object) -> str:
    """``text`` as HTML character data (for ``add_html`` content and exported pages)."""
    return html.escape(str(text), quote=True)
