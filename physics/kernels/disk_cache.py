"""numba's on-disk cache for Linkage Lab's kernels: kept in the private cache folder, and never trusted.

numba keeps compiled machine code as pickles (``.nbi`` index, ``.nbc`` data) and unpickles them without a
check: a damaged file ends every later run with a traceback, and a planted one runs its author's code. So, for
the kernels' functions only (the machine code of generated LLVM IR is kept by :mod:`physics.codegen.machine_code`):

* a cache locator puts the kernels' files under ``<cache folder>/numba/kernels-<digest>/`` (the folder
  :mod:`physics.cache_folder` has checked to be private; these two subfolders are checked the same way, and one
  that is not this user's or is writable by others is discarded). It takes every kernel, falling back to a
  private temporary folder, so numba never falls back to its own unchecked places (``__pycache__`` beside the
  source, ``NUMBA_CACHE_DIR``);
* numba's reader and writer of those files are replaced (:class:`AuthenticatedCacheFile`): each file is written
  with a trailer holding an HMAC-SHA256 of its name and bytes under the user's secret key, in the same atomic
  rename as the file (so a file and its tag can never come from two different writers); each read takes the
  file's bytes once, through :func:`physics.cache_folder.read_trusted` (a regular file of this user that group
  and others cannot write), and checks the tag on the very bytes that are then unpickled. A file that fails
  (planted with or without a tag, truncated, garbled, a tag that is not even text) is removed with the rest of
  its function's files, with one line on stderr, and numba compiles that function afresh.

numba writes under a temporary name and renames, so a killed process leaves at most a stray ``*.tmp.*`` file,
which is never read; stale ones are removed.
"""

from __future__ import annotations

import atexit
import glob
import hashlib
import io
import os
import pickle
import shutil
import tempfile
import threading
import time
import uuid
from pathlib import Path

import numba
from numba.core import caching

from ..cache_folder import (
    UntrustedFile,
    cache_dir,
    check_folder,
    discard,
    read_tagged,
    tagged,
    warn,
)
from . import numba_start

_KERNELS = Path(__file__).resolve().parent
STALE_TEMPORARY_SECONDS = 3600.0
_lock = threading.Lock()
_ensured: set[str] = set()
_private_paths: set[str] = set()  # folders whose files AuthenticatedCacheFile reads and writes
_usable: dict[str, str] = {}  # the kernels folder as configured -> the folder actually used
_reported: set[tuple[str, str]] = set()


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


def _private_temporary() -> str:
    folder = tempfile.mkdtemp(prefix="linkage-lab-kernels-")  # mode 0700, owned by us
    atexit.register(shutil.rmtree, folder, True)
    return folder


def _check_or_make(folders: tuple[Path, ...]) -> None:
    for folder in folders:
        try:
            folder.mkdir(mode=0o700, exist_ok=True)
        except OSError as error:
            raise UntrustedFile(f"folder {folder} cannot be created ({error.strerror or error})") from None
        check_folder(folder)


def usable_kernels_folder() -> str:
    """The folder the kernels' files go to: ``kernels_folder()`` once it and ``numba/`` are checked to be this
    user's and not writable by others (a foreign or open one, planted while the cache folder was open, is
    discarded and made again); if that fails too, a private temporary folder for this run."""
    wanted = kernels_folder()
    with _lock:
        if str(wanted) in _usable:
            return _usable[str(wanted)]
        folders = (wanted.parent, wanted)
        try:
            _check_or_make(folders)
            chosen = str(wanted)
        except UntrustedFile as first:
            for folder in folders:
                try:
                    check_folder(folder)
                except UntrustedFile:
                    discard(folder)
                    break
            try:
                _check_or_make(folders)
                chosen = str(wanted)
                warn(f"compiled-code cache: {first}; discarded and rebuilt")
            except UntrustedFile as second:
                chosen = _private_temporary()
                warn(f"compiled-code cache: {second}; using a private temporary folder for this run (slower)")
        _usable[str(wanted)] = chosen
        _private_paths.add(chosen)
        return chosen


class PrivateCacheLocator(caching._SourceFileBackedLocatorMixin, caching._CacheLocator):
    """numba cache locator for the kernels' files: ``<cache folder>/numba/kernels-<digest>/``."""

    def __init__(self, py_func, py_file):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        self._cache_path = usable_kernels_folder()

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
        if not source.exists() or not source.is_relative_to(_KERNELS):
            return None
        locator = cls(py_func, py_file)
        try:
            locator.ensure_cache_path()
        except OSError:  # cannot write there: this run's own folder, never numba's unchecked ones
            locator._cache_path = _private_temporary()
            _private_paths.add(locator._cache_path)
        return locator


class _Discarded(OSError):
    """A cache file that failed its checks and was removed (an OSError: numba's ``load`` then recompiles)."""



def _remove_group(folder: Path, stem: str, reason: str) -> None:
    """Remove one function's index and data files: numba recompiles it on next use."""
    for path in folder.glob(f"{glob.escape(stem)}.*"):
        discard(path)
    if (str(folder), stem) not in _reported:
        _reported.add((str(folder), stem))
        warn(f"compiled-code cache file for {stem} is damaged or not trusted ({reason}); discarded and rebuilt")


class AuthenticatedCacheFile(caching.IndexDataCacheFile):
    """numba's index-and-data cache file, with every file of the kernels' folders authenticated (files of other
    folders, for functions outside the kernels, are left to numba as they were)."""

    def __init__(self, cache_path, filename_base, source_stamp):
        super().__init__(cache_path, filename_base, source_stamp)
        self._filename_base = filename_base
        self._authenticated = str(cache_path) in _private_paths

    def _read(self, path: str) -> bytes:
        """The file's bytes without the trailer, once checked; FileNotFoundError, or _Discarded after removal."""
        file = Path(path)
        payload, problem = read_tagged(file)
        if payload is not None:
            return payload
        self._discard(f"{file.name}: {problem}")
        raise _Discarded(problem)

    def _discard(self, reason: str) -> None:
        _remove_group(Path(self._cache_path), self._filename_base, reason)

    def _write(self, path: str, payload: bytes) -> None:
        """``payload`` and its MAC trailer, written 0600 under a temporary name and renamed into place."""
        name = os.path.basename(path)
        temporary = f"{path}.tmp.{uuid.uuid4().hex[:16]}"
        fd = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o600)
        try:
            with os.fdopen(fd, "wb") as stream:
                stream.write(tagged(name, payload))
            os.replace(temporary, path)
        except BaseException:
            try:
                os.unlink(temporary)
            except OSError:
                pass
            raise

    def _load_index(self):
        if not self._authenticated:
            return super()._load_index()
        try:
            payload = self._read(self._index_path)
        except OSError:  # none yet, or discarded
            return {}
        try:
            stream = io.BytesIO(payload)
            version = pickle.load(stream)  # authenticated: written by this user's Linkage Lab
            if version != self._version:
                return {}
            stamp, overloads = pickle.loads(stream.read())
        except Exception as error:  # authenticated but unreadable (another numba's format): start again
            self._discard(f"{os.path.basename(self._index_path)}: unreadable ({type(error).__name__})")
            return {}
        return overloads if stamp == self._source_stamp else {}

    def _save_index(self, overloads):
        if not self._authenticated:
            return super()._save_index(overloads)
        payload = pickle.dumps(self._version, protocol=-1) + self._dump((self._source_stamp, overloads))
        self._write(self._index_path, payload)

    def _load_data(self, name):
        if not self._authenticated:
            return super()._load_data(name)
        payload = self._read(self._data_path(name))  # an OSError makes numba's load() compile afresh
        try:
            return pickle.loads(payload)  # authenticated: written by this user's Linkage Lab
        except Exception as error:
            self._discard(f"{name}: unreadable ({type(error).__name__})")
            raise _Discarded(str(error)) from None

    def _save_data(self, name, data):
        if not self._authenticated:
            return super()._save_data(name, data)
        self._write(self._data_path(name), self._dump(data))


def install() -> None:
    """Put :class:`PrivateCacheLocator` first among numba's locators (it declines every other file), and make
    numba's caches use :class:`AuthenticatedCacheFile` (numba looks the class up when it creates each cache)."""
    locators = caching.CacheImpl._locator_classes
    if PrivateCacheLocator not in locators:
        locators.insert(0, PrivateCacheLocator)
    caching.IndexDataCacheFile = AuthenticatedCacheFile  # type: ignore[misc]


def kernel_folders() -> list[Path]:
    """Where numba keeps this package's own compiled functions."""
    return [Path(usable_kernels_folder())]


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


def _remove_stale_temporaries(folder: Path) -> None:
    """Temporary files of writers killed midway, older than an hour (a live writer renames its file at once)."""
    now = time.time()
    for path in folder.glob("*.tmp.*"):
        try:
            if now - path.lstat().st_mtime > STALE_TEMPORARY_SECONDS:
                path.unlink()
        except OSError:
            pass


def tidy() -> None:
    _remove_stale_kernels()
    for folder in kernel_folders():
        _remove_stale_temporaries(folder)


numba_start.on_numba_import()
install()
tidy()
