"""``--out`` files: refused before any work when they cannot be written, then written atomically.

Shared by the CLI and the studies' commands so that every command treats an output path the same way
(one line naming the option, the path and why, never a traceback). ``option`` names the flag the path came
from (``--out``, ``--data``), so an unwritable ``--data`` is not reported as ``--out``.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import stat
import sys
import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from .errors import LinkageError
from .file_io import write_atomically

# The exit status of a command whose run (or one copy of an ensemble) stopped before its end: what was computed is
# written (docs/cli.md); 2 is bad input, refused before any work.
EXIT_RUN_STOPPED = 3

# The temporary file of an atomic write is ``.NAME.XXXXXXXX.tmp``: 14 bytes longer than the name.
TEMPORARY_NAME_EXTRA = 14
# Where a symbolic link is the way to reach a stream (``/dev/stdout``, ``/proc/self/fd/1``), not a file to replace.
_STREAM_FOLDERS = ("/dev/", "/proc/")


def _name_max(folder: Path) -> int:
    try:
        return int(os.pathconf(folder, "PC_NAME_MAX"))
    except (OSError, ValueError, AttributeError):
        return 255


def _refuse_symlink(out: str, path: Path, option: str) -> None:
    """A link to a file would be replaced by the atomic rename (the link gone, its target unchanged): refused.
    A link into /dev or /proc (``/dev/stdout``) is a stream, written through."""
    if not path.is_symlink() or str(path.absolute()).startswith(_STREAM_FOLDERS):
        return
    target = os.path.realpath(path)
    if target.startswith(_STREAM_FOLDERS):
        return
    raise LinkageError(f"{option} {out}: is a symbolic link (to {target}); writing would replace the link, not "
                       f"its target: give {target} itself or another name")


def check_output_path(out: str, option: str = "--out", suffixes: Sequence[str] | None = None) -> None:
    """Refuse, before any work, an output path that cannot be written: one line naming it and why.
    ``suffixes``: the file endings the command can write (e.g. ``(".json", ".csv", ".png")``)."""
    if not out.strip():
        raise LinkageError(f"{option}: empty; give a file name")
    path = Path(out)
    folder = path.parent if str(path.parent) else Path(".")
    try:
        if path.is_dir():
            raise LinkageError(f"{option} {out}: is a folder; give a file name")
        if not folder.is_dir():
            raise LinkageError(f"{option} {out}: folder {folder} does not exist")
        _refuse_symlink(out, path, option)
        device = path.exists() and not stat.S_ISREG(path.stat().st_mode)
        if suffixes is not None and not device and path.suffix.lower() not in suffixes:
            raise LinkageError(f"{option} {out}: unknown file type {path.suffix or '(none)'!r}; allowed "
                               f"{', '.join(suffixes)}")
        name_max = _name_max(folder)
        if not device and len(path.name.encode("utf-8", "surrogateescape")) + TEMPORARY_NAME_EXTRA > name_max:
            raise LinkageError(f"{option}: file name of {len(path.name)} characters is too long (at most "
                               f"{name_max - TEMPORARY_NAME_EXTRA} bytes here)")
        if not os.access(folder, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
            raise LinkageError(f"{option} {out}: cannot write there (permission denied)")
    except OSError as error:
        raise LinkageError(f"{option} {out[:120]}{'...' if len(out) > 120 else ''}: cannot write there "
                           f"({error.strerror or error})") from None


def check_partial_path(out: str) -> None:
    """``OUT.partial``, where a run that stops midway writes what it computed, must be writable too (checked with
    ``OUT``, before any work); a device (``--out /dev/null``) has none: what stops is written to the device."""
    path = Path(out)
    try:
        device = path.exists() and not path.is_file()
    except OSError:
        device = False
    if not device:
        check_output_path(f"{out}.partial", "--out (its .partial file)")


def partial_note(t, partial: str | None) -> str:
    """The end of a stopped run's one line: where the samples computed before the stop were kept (``t``, their
    times), or nothing without ``--out``. A run stopped at its start kept none (its file holds the header only):
    the line says so rather than quoting the time of a sample that does not exist."""
    if not partial:
        return ""
    if len(t) == 0:
        return f"; no sample was computed (the table's header alone is in {partial})"
    if len(t) == 1:
        return f"; the 1 sample, at t = {float(t[-1]):.6g} s, is in {partial}"
    return f"; the {len(t)} samples up to t = {float(t[-1]):.6g} s are in {partial}"


def check_output_folder(out: str, option: str = "--out") -> None:
    """Refuse, before any work, an output folder that cannot take files: not a folder, a missing parent, or a
    folder where a file cannot be created (tried with a temporary file, removed at once)."""
    if not out.strip():
        raise LinkageError(f"{option}: empty; give a folder")
    path = Path(out)
    try:
        if path.exists() and not path.is_dir():
            raise LinkageError(f"{option} {out}: is not a folder; give a folder (or a new name in an existing one)")
        if not path.exists():
            parent = path.parent if str(path.parent) else Path(".")
            if not parent.is_dir():
                raise LinkageError(f"{option} {out}: folder {parent} does not exist")
            if not os.access(parent, os.W_OK):
                raise LinkageError(f"{option} {out}: cannot create it (permission denied in {parent})")
            return
        with tempfile.TemporaryFile(dir=path):
            pass
    except OSError as error:
        raise LinkageError(f"{option} {out}: cannot write there ({error.strerror or error})") from None


def write_output(out: str, data: bytes, option: str = "--out") -> None:
    """Write ``data`` to ``out`` atomically (physics.file_io); a device such as ``/dev/null`` is written directly.
    A failure is one line (LinkageError), never a traceback."""
    path = Path(out)
    try:
        _refuse_symlink(out, path, option)
        if path.exists() and not path.is_file():
            with open(path, "wb") as handle:
                handle.write(data)
        else:
            write_atomically(path, data)
    except OSError as error:
        raise LinkageError(f"{option} {out}: could not write ({error.strerror or error})") from None


def _finite_or_null(value):
    """``value`` with every float that is not finite (a stopped copy's tip, a spread with it) as None: JSON has no
    NaN, and strict readers (a browser's ``JSON.parse``) refuse Python's bare ``NaN``."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, Mapping):
        return {key: _finite_or_null(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite_or_null(item) for item in value]
    return value


def write_ensemble(out: str | None, document: Mapping, columns: Mapping[str, Sequence[float]],
                   picture: Callable[[], bytes], alive: bool, message: str) -> int:
    """The one writer of an ensemble, a chain's or a mechanism's (``python -m physics ensemble``): an ``--out``
    ending in ``.png`` gets ``picture()`` (the copies at the end), one in ``.csv`` the time series ``columns``
    (one row per sample, every value as Python writes a float), any other (or none: stdout) ``document`` as one
    line of JSON. Then the exit status: 0 when every copy ran to the end, else :data:`EXIT_RUN_STOPPED` with
    ``error: MESSAGE`` on stderr, the same for both kinds."""
    out = out or ""
    if out.lower().endswith(".png"):
        write_output(out, picture())
    elif out.lower().endswith(".csv"):
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow(columns.keys())
        for row in zip(*columns.values()):
            writer.writerow([repr(float(v)) for v in row])
        write_output(out, buffer.getvalue().encode("utf-8"))
    else:
        text = json.dumps(_finite_or_null(document), allow_nan=False)  # strict JSON: a dead copy's NaN is null
        if out:
            write_output(out, (text + "\n").encode("utf-8"))
        else:
            print(text)
    if not alive:
        print(f"error: {message}", file=sys.stderr)
        return EXIT_RUN_STOPPED
    return 0
