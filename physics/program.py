"""How the two commands name themselves: ``usage:`` lines from the name that was typed, and ``--version``.

Shared by ``python -m physics`` (console script ``linkage-physics``) and ``python -m app`` (``linkage-lab``);
a module of its own so that the app's start does not import the physics command line.
"""

from __future__ import annotations

import os
import sys


def program_name(console_script: str, module: str, argv0: str | None = None) -> str:
    """The name the user typed: the console script's own name when run through it (``linkage-physics``,
    ``linkage-physics.exe``), else the module form (``python -m physics``), which is also what a test or a
    notebook calling ``main()`` directly sees (its ``sys.argv[0]`` is the test runner or the kernel)."""
    base = os.path.basename(sys.argv[0] if argv0 is None else argv0)
    stem = base[:-4] if base.lower().endswith(".exe") else base
    return stem if stem == console_script else module


def version_text() -> str:
    """``--version`` of both commands: the distribution's name and its one version source, ``physics.__version__``."""
    from . import __version__  # noqa: PLC0415 - read when asked; physics is imported already by then

    return f"linkage-lab {__version__}"
