"""Writing a file so that no reader ever sees half of it, and reading a user's file with a byte limit: one helper
for generated code, caches and outputs, one for every file a user names (mechanism files, case files).

Why the reader opens the file itself instead of trusting ``stat``: ``/dev/zero`` reports size 0 and never ends,
and a FIFO blocks ``open`` until a writer comes; so a user's file must be a regular file (checked on the open
descriptor, opened without blocking) and at most ``limit + 1`` bytes are ever read.

Why the writer locks its temporary file: a process killed mid-write (``kill -9``) leaves ``.NAME.*.tmp`` behind.
The next write of the same target removes those whose lock nobody holds (their writer is gone), and never one
that another live process is still writing.
"""

from __future__ import annotations

import contextlib
import glob
import os
import stat
import tempfile
import threading
from pathlib import Path

from .errors import LinkageError

try:  # POSIX; elsewhere stale temporary files are left alone
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]

_UMASK_LOCK = threading.Lock()


def current_umask() -> int:
    """The process's umask (read by setting it and putting it back, under a lock)."""
    with _UMASK_LOCK:
        mask = os.umask(0o022)
        os.umask(mask)
    return mask


def _lock(fd: int) -> bool:
    if fcntl is None:
        return True
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return False
    return True


def remove_stale_temporaries(path: str | Path) -> int:
    """Remove the temporary files ``.NAME.*.tmp`` that earlier writes of ``path`` left behind (a writer killed
    midway): only regular files of this user that no live writer holds locked. Returns how many were removed."""
    if fcntl is None:  # pragma: no cover - Windows
        return 0
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    removed = 0
    pattern = os.path.join(glob.escape(str(folder)), f".{glob.escape(path.name)}.*.tmp")
    for candidate in glob.glob(pattern):
        try:
            fd = os.open(candidate, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
        except OSError:
            continue
        try:
            info = os.fstat(fd)
            if stat.S_ISREG(info.st_mode) and info.st_uid == os.getuid() and _lock(fd):
                os.unlink(candidate)
                removed += 1
        except OSError:
            pass
        finally:
            os.close(fd)
    return removed


def write_atomically(path: str | Path, data: bytes | str, mode: int | None = None) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder, flushed to disk, then renamed
    over it: a reader sees the old file or the new one, and a failed write (OSError, raised) leaves no trace.
    ``mode``: permissions of the new file (e.g. 0o600 for the private cache); default: what the umask gives a
    new file (0o644 under umask 022), as for any file a program creates. Temporary files of the same target
    left by a killed writer are removed first."""
    path = Path(path)
    payload = data.encode("utf-8") if isinstance(data, str) else data
    remove_stale_temporaries(path)
    fd, temporary = tempfile.mkstemp(dir=path.parent if str(path.parent) else ".", prefix=f".{path.name}.",
                                     suffix=".tmp")
    try:
        _lock(fd)  # held until the file is closed: a later cleaner knows this writer is alive
        with os.fdopen(fd, "wb") as handle:
            handle.write(payload)
            handle.flush()
            os.fsync(handle.fileno())
            os.fchmod(handle.fileno(), 0o666 & ~current_umask() if mode is None else mode)
            os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        raise


def read_limited(path: str | Path, limit: int, label: str) -> bytes:
    """The bytes of the regular file ``path``, at most ``limit`` of them; LinkageError (one line starting with
    ``label``) for anything else: a device (``/dev/zero``), a FIFO or a folder, a file over the limit (however
    its size is reported), an unreadable one. Never blocks and never reads more than ``limit + 1`` bytes."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except OSError as error:
        raise LinkageError(f"{label}: cannot read it ({error.strerror or error})") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            kind = ("a folder" if stat.S_ISDIR(info.st_mode) else "a pipe (FIFO)" if stat.S_ISFIFO(info.st_mode)
                    else "a device" if stat.S_ISCHR(info.st_mode) or stat.S_ISBLK(info.st_mode) else "a special file")
            raise LinkageError(f"{label}: is {kind}, not a regular file; give a file")
        if info.st_size > limit:
            raise LinkageError(f"{label}: {info.st_size} bytes, more than the {limit} allowed")
        chunks, total = [], 0
        while total <= limit:
            chunk = os.read(fd, min(1 << 20, limit + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
        if total > limit:
            raise LinkageError(f"{label}: over {limit} bytes, more than the {limit} allowed")
        return b"".join(chunks)
    except OSError as error:
        raise LinkageError(f"{label}: cannot read it ({error.strerror or error})") from None
    finally:
        os.close(fd)
