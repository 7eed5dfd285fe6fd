"""The private folder that holds generated code and numba's compiled machine code, and the checks that make
it safe to load from.

Files in it are executed (generated ``.py``) or unpickled (numba's ``.nbi``/``.nbc``), so a folder that another
user owns or can write would let that user run code as this one. The folder is ``$LINKAGE_LAB_CACHE`` if set,
else ``$XDG_CACHE_HOME/linkage-lab`` (default ``~/.cache/linkage-lab``), created with mode 0700. A folder that
is not owned by the current user, is writable by group or others, cannot be written, or is not a folder at
all, is refused with one line on stderr naming it and the fix; the process then uses a private temporary
folder of its own (removed at exit), so the run still goes on, only slower.
"""

from __future__ import annotations

import atexit
import os
import shutil
import stat
import sys
import tempfile
import threading
from pathlib import Path

_lock = threading.Lock()
_resolved: dict[str, Path] = {}


def configured_path() -> Path:
    """Where the cache should be, before any check."""
    override = os.environ.get("LINKAGE_LAB_CACHE")
    if override:
        return Path(override).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base).expanduser() / "linkage-lab"


def warn(message: str) -> None:
    """One line on stderr: the cache's only way of speaking (never a traceback)."""
    print(f"linkage-lab: {message}", file=sys.stderr, flush=True)


def _problem(path: Path) -> str | None:
    """Why ``path`` cannot serve as the private cache, or None when it can (creating it if missing)."""
    try:
        path.mkdir(parents=True, exist_ok=True, mode=0o700)
    except FileExistsError:
        return "is not a folder"
    except OSError as error:
        return f"cannot be created ({error.strerror or error})"
    try:
        info = path.stat()
    except OSError as error:
        return f"cannot be read ({error.strerror or error})"
    if not stat.S_ISDIR(info.st_mode):
        return "is not a folder"
    if hasattr(os, "getuid") and info.st_uid != os.getuid():
        return f"is owned by another user (uid {info.st_uid}); its files would run as you"
    if stat.S_IMODE(info.st_mode) & 0o022:
        return (
            f"is writable by group or others (mode {stat.S_IMODE(info.st_mode):o}); "
            "anyone who can write it can run code as you"
        )
    probe = path / f".write-probe-{os.getpid()}"
    try:
        probe.write_bytes(b"")
        probe.unlink()
    except OSError:
        return "is read-only"
    return None


def _private_temporary() -> Path:
    folder = Path(tempfile.mkdtemp(prefix="linkage-lab-cache-"))  # mode 0700, owned by us
    atexit.register(shutil.rmtree, folder, True)
    return folder


def cache_dir() -> Path:
    """The checked private cache folder (the same for the whole process for a given configuration)."""
    path = configured_path()
    key = str(path)
    with _lock:
        if key in _resolved:
            return _resolved[key]
        problem = _problem(path)
        if problem is None:
            try:
                if stat.S_IMODE(path.stat().st_mode) & 0o077:
                    path.chmod(0o700)  # readable by others is not dangerous, but the folder is private
            except OSError:
                pass
            chosen = path
        else:
            chosen = _private_temporary()
            warn(
                f"cache folder {path} {problem}; using a private temporary cache for this run (slower). "
                f"Fix: set LINKAGE_LAB_CACHE to a folder of your own with mode 0700, or "
                f"`chmod 700 {path}` if it is yours."
            )
        _resolved[key] = chosen
        return chosen


def forget() -> None:
    """Forget the folders resolved so far (tests that change LINKAGE_LAB_CACHE within one process)."""
    with _lock:
        _resolved.clear()
