"""numba's on-disk cache for Linkage Lab's kernels: kept in the private cache folder, and never trusted
blindly.

numba keeps compiled machine code as pickles (``.nbi`` index, ``.nbc`` data) and loads them without a check:
a truncated, emptied or garbled file ends every later run with a traceback, and a planted one runs its
author's code. So, for the kernels' functions only (generated code keeps no machine code on disk):

* a cache locator puts the kernels' files under ``<cache folder>/numba/kernels-<digest>/`` (the folder
  :mod:`physics.cache_folder` has checked to be private), whatever folder the package is installed in;
* each file gets a ``.sha256`` sidecar once it is known to be complete (its digest, size and modification time);
  before numba reads a group of files, :func:`verify` checks every sidecar: a file whose size and time are
  unchanged is taken as recorded (one ``stat``, as git's index does), any other is hashed again; a file without a
  sidecar must at least be a complete pickle (its opcodes walked without executing them). A file that fails is
  removed with one line on stderr, and numba compiles afresh.

numba writes its files under a temporary name and renames them, so a killed process leaves at most a stray
``*.tmp.*`` file, which is never read; stale ones are removed.
"""

from __future__ import annotations

import atexit
import hashlib
import os
import pickle
import pickletools
import shutil
import threading
import time
from pathlib import Path

import numba
from numba.core import caching

from ..cache_folder import cache_dir, warn

_KERNELS = Path(__file__).resolve().parent
SIDECAR = ".sha256"
STALE_TEMPORARY_SECONDS = 3600.0
_lock = threading.Lock()
_verified: set[tuple[str, str]] = set()
_ensured: set[str] = set()


def numba_folder() -> Path:
    return cache_dir() / "numba"


def _kernels_digest() -> str:
    """Digest of every source file of the kernels and of numba's version. numba keys each cached function by
    its own file alone, so a kernel whose callee in another file changed would load stale machine code: one
    folder per digest of the whole package rules that out."""
    h = hashlib.sha256()
    for path in sorted(_KERNELS.glob("*.py")):
        h.update(path.name.encode())
        h.update(path.read_bytes())
    h.update(numba.__version__.encode())
    return h.hexdigest()[:16]


KERNELS_DIGEST = _kernels_digest()


def kernels_folder() -> Path:
    return numba_folder() / f"kernels-{KERNELS_DIGEST}"


class PrivateCacheLocator(caching._SourceFileBackedLocatorMixin, caching._CacheLocator):
    """numba cache locator for the kernels' files: ``<cache folder>/numba/kernels-<digest>/``."""

    def __init__(self, py_func, py_file):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        self._cache_path = str(kernels_folder())

    def get_cache_path(self):
        return self._cache_path

    def ensure_cache_path(self):
        """numba's check (make the folder, write a probe file) done once per folder, not once per function."""
        if self._cache_path not in _ensured:
            super().ensure_cache_path()
            _ensured.add(self._cache_path)

    @classmethod
    def from_function(cls, py_func, py_file):
        try:
            source = Path(py_file).resolve()
        except (OSError, TypeError):
            return None
        if not source.exists():
            return None
        if not source.is_relative_to(_KERNELS):
            return None
        locator = cls(py_func, py_file)
        try:
            locator.ensure_cache_path()
        except OSError:  # cannot write there: numba compiles without a disk cache
            return None
        return locator


def install_locator() -> None:
    """Put :class:`PrivateCacheLocator` first among numba's locators (it declines every other file)."""
    locators = caching.CacheImpl._locator_classes
    if PrivateCacheLocator not in locators:
        locators.insert(0, PrivateCacheLocator)


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _record(path: Path) -> str:
    """The sidecar's text: digest, size and modification time (ns) of ``path``."""
    info = path.stat()
    return f"{_digest(path)} {info.st_size} {info.st_mtime_ns}"


def _matches(path: Path, sidecar: Path) -> bool:
    """Whether ``path`` is still the file its sidecar recorded (a stat when nothing changed, else a hash)."""
    fields = sidecar.read_text().split()
    if len(fields) != 3:  # an older sidecar held the digest alone
        return bool(fields) and _digest(path) == fields[0]
    digest, size, mtime_ns = fields
    info = path.stat()
    if str(info.st_size) == size and str(info.st_mtime_ns) == mtime_ns:
        return True
    return _digest(path) == digest


def _well_formed(path: Path) -> bool:
    """Whether ``path`` is a complete numba cache file, checked without executing any of it."""
    try:
        data = path.read_bytes()
        if path.suffix == ".nbi":
            # a version string pickled alone, then the pickled (stamp, overloads)
            first_end = None
            for opcode, _arg, position in pickletools.genops(data):
                if opcode.name == "STOP" and position is not None:
                    first_end = position + 1
                    break
            if first_end is None:
                return False
            version = pickle.loads(data[:first_end])  # a str: safe to load
            if not isinstance(version, str):
                return False
            data = data[first_end:]
        last = None
        for opcode, _arg, _position in pickletools.genops(data):
            last = opcode.name
        return last == "STOP"
    except Exception:  # any parse failure is a damaged file
        return False


def _remove_group(folder: Path, stem: str, reason: str) -> None:
    """Remove one function's index, data and sidecars: numba recompiles it on next use."""
    for path in folder.glob(f"{stem}.*"):
        try:
            path.unlink()
        except OSError:
            pass
    warn(f"damaged compiled-code cache file for {stem} ({reason}) removed; rebuilding it")


def verify(folder: Path, prefix: str) -> None:
    """Check numba's files in ``folder`` whose names start with ``prefix``; remove any group that fails.

    Runs once per (folder, prefix) in a process, before numba reads them."""
    key = (str(folder), prefix)
    with _lock:
        if key in _verified or not folder.is_dir():
            _verified.add(key)
            return
        now = time.time()
        groups: dict[str, list[Path]] = {}
        for path in folder.glob(f"{prefix}*"):
            name = path.name
            if ".tmp." in name:
                try:
                    if now - path.stat().st_mtime > STALE_TEMPORARY_SECONDS:
                        path.unlink()
                except OSError:
                    pass
                continue
            if name.endswith(SIDECAR) or not (name.endswith(".nbi") or name.endswith(".nbc")):
                continue
            stem = name.split(".py")[0]  # "<module>.<function>-<line>"
            groups.setdefault(stem, []).append(path)
        for stem, paths in groups.items():
            for path in paths:
                sidecar = path.with_name(path.name + SIDECAR)
                try:
                    if sidecar.exists():
                        ok = _matches(path, sidecar)
                        reason = "checksum differs"
                    else:
                        ok = _well_formed(path)
                        reason = "not a complete pickle"
                except OSError as error:
                    ok, reason = False, f"unreadable: {error.strerror or error}"
                if not ok:
                    _remove_group(folder, stem, f"{path.name}: {reason}")
                    break
        _verified.add(key)


def seal(folder: Path, prefix: str) -> None:
    """Write a sidecar for every complete file with ``prefix`` that has none (or a stale one)."""
    if not folder.is_dir():
        return
    for path in folder.glob(f"{prefix}*"):
        name = path.name
        if ".tmp." in name or not (name.endswith(".nbi") or name.endswith(".nbc")):
            continue
        sidecar = path.with_name(name + SIDECAR)
        try:
            if sidecar.exists() and _matches(path, sidecar):
                continue
            if not _well_formed(path):
                continue
            temporary = sidecar.with_name(f"{sidecar.name}.tmp.{os.getpid()}")
            temporary.write_text(_record(path) + "\n")
            os.replace(temporary, sidecar)
        except OSError:
            pass


def kernel_folders() -> list[Path]:
    """Where numba keeps this package's own compiled functions."""
    return [kernels_folder()]


STALE_KERNELS_SECONDS = 7 * 24 * 3600.0


def _remove_stale_kernels() -> None:
    """Compiled kernels of other versions of the package, untouched for a week (another installation may still
    be using a recent one: ``python -m physics cache --clear`` empties everything at once)."""
    now = time.time()
    for folder in numba_folder().glob("kernels-*"):
        try:
            if folder != kernels_folder() and folder.is_dir() and now - folder.stat().st_mtime > STALE_KERNELS_SECONDS:
                shutil.rmtree(folder, ignore_errors=True)
        except OSError:
            pass


def verify_kernels() -> None:
    _remove_stale_kernels()
    for folder in kernel_folders():
        verify(folder, "")


def seal_kernels() -> None:
    for folder in kernel_folders():
        try:
            seal(folder, "")
        except Exception:  # at exit: never a traceback
            pass


install_locator()
verify_kernels()
atexit.register(seal_kernels)
