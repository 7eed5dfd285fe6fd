"""``--out`` files: refused before any work when they cannot be written, then written atomically.

Shared by the CLI and the studies' commands so that every command treats an output path the same way
(one line naming it and why, never a traceback).
"""

from __future__ import annotations

import os
from pathlib import Path

from .errors import LinkageError
from .files import write_atomically


def check_output_path(out: str) -> None:
    """Refuse, before any work, an output path that cannot be written: one line naming it and why."""
    path = Path(out)
    folder = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise LinkageError(f"--out {out}: is a folder; give a file name")
    if not folder.is_dir():
        raise LinkageError(f"--out {out}: folder {folder} does not exist")
    if not os.access(folder, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
        raise LinkageError(f"--out {out}: cannot write there (permission denied)")


def write_output(out: str, data: bytes) -> None:
    """Write ``data`` to ``out`` atomically (physics.files); a device such as ``/dev/null`` is written directly.
    A failure is one line (LinkageError), never a traceback."""
    path = Path(out)
    try:
        if path.exists() and not path.is_file():
            with open(path, "wb") as handle:
                handle.write(data)
        else:
            write_atomically(path, data)
    except OSError as error:
        raise LinkageError(f"--out {out}: could not write ({error.strerror or error})") from None
