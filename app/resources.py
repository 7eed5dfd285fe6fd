"""Where the app's static files are (the page's additions ``page.html``, the help text ``help.md``).

They live in ``static/`` at the top of the repository, and a wheel installs them as ``app/static`` (package data
of the app: pyproject.toml maps ``app.static`` to ``static``). An installed copy is looked up first, through
importlib.resources, so a wheel install never reads a ``static/`` folder that merely happens to sit beside it;
a source checkout or an editable install (whose ``app`` is the repository's folder) falls back to the
repository's ``static/``.
"""

from __future__ import annotations

import importlib.resources
from pathlib import Path

SOURCE_STATIC = Path(__file__).resolve().parent.parent / "static"


def static_folder() -> Path:
    """The folder holding ``page.html`` and ``help.md``: the installed ``app/static`` if there is one, else the
    repository's ``static/``."""
    installed = importlib.resources.files("app") / "static"
    if isinstance(installed, Path) and (installed / "page.html").is_file():
        return installed
    return SOURCE_STATIC


STATIC = static_folder()
