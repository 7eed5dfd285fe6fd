"""The page a browser loads: viser's own client with Linkage Lab's additions (``static/page.html``).

The additions: a loading screen; share links (app/share.py); dark mode when the browser prefers it (viser's own
``?darkMode``); keyboard shortcuts (Space play/pause, R reset, S step, F front view) that press the panel's own
buttons, so that they go through the same checks as a click.

Between the first paint and the moment a session's panel arrives (a fraction of a second warm, longer while a
new session is being built), viser's client shows its bare developer panel (the websocket address, "Save Canvas",
the scene tree), which is meaningless to a student. The loading screen covers the
page from its first paint and removes itself when the session adds its ready marker (:data:`READY_HTML`).

viser serves its client from a folder it is given at construction; the page is written once per process into a
private temporary folder (mode 0700, removed at exit) and handed to viser through
:func:`app.viser_compat.serving_page_from`.
"""

from __future__ import annotations

import atexit
import importlib.util
import shutil
import tempfile
from pathlib import Path

from .resources import STATIC

ADDITIONS = STATIC / "page.html"  # app/resources.py: the installed app/static, else the repository's static/
FIGURE_CLASS = "linkage-lab-figure"
"""The class of a study's or the seed report's figure (an SVG drawn on white): in dark mode the page's stylesheet
(static/page.html) turns its lightness round and keeps its hues, so it is no white block on a dark panel."""
READY_ID = "linkage-lab-ready"
READY_HTML = f'<span id="{READY_ID}" hidden></span>'
"""Added to a browser's panel when its session is shown (or it is told the server is full)."""

_folder: Path | None = None


def viser_page() -> Path:
    """viser's own page (found without importing viser: the server imports it after the warm-up has started)."""
    spec = importlib.util.find_spec("viser")
    if spec is None or not spec.submodule_search_locations:
        raise OSError("viser is not installed")
    return Path(list(spec.submodule_search_locations)[0]) / "client" / "build" / "index.html"


CONTENT_SECURITY_POLICY = "connect-src 'self' data: blob:"
"""The page connects (websocket, fetch) to the server that served it and to nothing else: a link that names
another server (viser's ``?websocket=``) cannot make this origin run what that server sends."""
POLICY_META = f'<meta http-equiv="Content-Security-Policy" content="{CONTENT_SECURITY_POLICY}">'


def with_loading_screen(page: str, screen: str) -> str:
    """``page`` (viser's index.html) with :data:`POLICY_META` as the first thing in its head (a policy in a
    meta element counts only there, and only for what is loaded after it) and ``screen`` as the first thing
    in its body."""
    head, body = "<head>", "<body>"
    at_head, at_body = page.find(head), page.find(body)
    if at_head < 0 or at_body < at_head:
        raise ValueError("viser's page has no <head> before its <body>")
    at_head += len(head)
    at_body += len(body)
    return page[:at_head] + POLICY_META + page[at_head:at_body] + "\n" + screen + page[at_body:]


def page_folder() -> Path | None:
    """A folder holding the page with the loading screen (made once per process); None when viser's page cannot
    be read or changed, then viser serves its own."""
    global _folder
    if _folder is not None:
        return _folder
    try:
        page = with_loading_screen(viser_page().read_text(encoding="utf-8"), ADDITIONS.read_text(encoding="utf-8"))
        folder = Path(tempfile.mkdtemp(prefix="linkage-lab-page-"))
        (folder / "index.html").write_text(page, encoding="utf-8")
    except (OSError, ValueError, UnicodeError):
        return None
    atexit.register(shutil.rmtree, folder, True)
    _folder = folder
    return folder


def add_alias(name: str) -> bool:
    """Serve the page under ``/<name>`` too (the presenter's secret address in ``--shared`` mode: viser's client
    connects its websocket to the page's own path, so the server learns which address a browser opened).
    False when there is no page folder."""
    folder = page_folder()
    if folder is None or "/" in name or not name.endswith(".html"):
        return False
    shutil.copyfile(folder / "index.html", folder / name)
    return True
