"""The private folder that holds generated code and numba's compiled machine code, and the checks that make
it safe to load from.

Files in it are executed (generated ``.py``) or unpickled (numba's ``.nbi``/``.nbc``), so a folder that another
user owns or can write would let that user run code as this one. The folder is ``$LINKAGE_LAB_CACHE`` if set,
else ``$XDG_CACHE_HOME/linkage-lab`` (default ``~/.cache/linkage-lab``), created with mode 0700. A folder that
is not owned by the current user, is writable by group or others, cannot be written, or is not a folder at
all, is refused with one line on stderr naming it and the fix; the process then uses a private temporary
folder of its own (removed at exit), so the run still goes on, only slower.

The folder's mode is not enough: files planted while it was open to others would still be there after the
user applies the fix. So every file read from it must also be a regular file owned by this user, not writable
by group or others, and carry an HMAC-SHA256 of its name and bytes under a per-user secret key that another
user cannot read: 32 random bytes in ``$LINKAGE_LAB_KEY_DIR/cache.key`` if set, else
``$XDG_CONFIG_HOME/linkage-lab/cache.key`` (default ``~/.config/linkage-lab/cache.key``), outside the cache
folder, created once with mode 0600 (written under a temporary name and linked into place, so no process ever
reads half a key). A key file or folder that is not this user's, is readable or writable by others, or does not
hold exactly 32 bytes is refused like a bad cache folder: one line, and this run gets a private temporary cache
with a key of its own. :func:`read_trusted` is the one way to read a cache file; :func:`mac` makes the tag.
"""

from __future__ import annotations

import atexit
import hashlib
import hmac
import os
import shutil
import stat
import tempfile
import threading
from pathlib import Path

from .notices import notify

_lock = threading.Lock()
_resolved: dict[str, tuple[Path, bytes]] = {}
KEY_BYTES = 32
KEY_FILE = "cache.key"
_MAC_CONTEXT = b"linkage-lab cache v1\0"


def configured_path() -> Path:
    """Where the cache should be, before any check."""
    override = os.environ.get("LINKAGE_LAB_CACHE")
    if override:
        return Path(override).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base).expanduser() / "linkage-lab"


def warn(message: str) -> None:
    """One line on stderr, through logging (physics.notices: ``physics.cache`` at WARNING, shown by default):
    the cache's only way of speaking (never a traceback)."""
    notify(f"linkage-lab: {message}", "physics.cache")


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


def key_path() -> Path:
    """Where the per-user key that authenticates the cache's files lives (never inside the cache folder)."""
    override = os.environ.get("LINKAGE_LAB_KEY_DIR")
    if override:
        return Path(override).expanduser() / KEY_FILE
    base = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(base).expanduser() / "linkage-lab" / KEY_FILE


def _not_mine(info: os.stat_result) -> str | None:
    if hasattr(os, "getuid") and info.st_uid != os.getuid():
        return f"is owned by another user (uid {info.st_uid})"
    return None


def _read_key(path: Path) -> bytes:
    """The key's bytes, checked on the open descriptor (no symlink followed); OSError or ValueError if refused."""
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise ValueError("is not a regular file")
        problem = _not_mine(info)
        if problem:
            raise ValueError(problem)
        if stat.S_IMODE(info.st_mode) & 0o077:
            raise ValueError(f"is readable or writable by others (mode {stat.S_IMODE(info.st_mode):o})")
        data = os.read(fd, KEY_BYTES + 1)
    finally:
        os.close(fd)
    if len(data) != KEY_BYTES:
        raise ValueError(f"holds {len(data)} bytes, not {KEY_BYTES}")
    return data


def _key_problem(path: Path) -> tuple[bytes | None, str | None]:
    """The user's key (creating it if missing), or None and why it cannot be trusted."""
    folder = path.parent
    try:
        folder.mkdir(parents=True, exist_ok=True, mode=0o700)
        info = folder.lstat()
    except OSError as error:
        return None, f"folder {folder} cannot be created ({error.strerror or error})"
    if not stat.S_ISDIR(info.st_mode):
        return None, f"folder {folder} is not a folder"
    problem = _not_mine(info)
    if problem is None and stat.S_IMODE(info.st_mode) & 0o022:
        problem = f"is writable by group or others (mode {stat.S_IMODE(info.st_mode):o})"
    if problem:
        return None, f"folder {folder} {problem}; another user could replace the key"
    try:
        return _read_key(path), None
    except FileNotFoundError:
        pass
    except ValueError as error:
        return None, f"{path} {error}"
    except OSError as error:
        return None, f"{path} cannot be read ({error.strerror or error})"
    # First use: write the key under a temporary name, then link it into place (fails if another process won).
    temporary = folder / f".{KEY_FILE}.{os.getpid()}.{threading.get_ident()}.tmp"
    try:
        fd = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o600)
        try:
            os.write(fd, os.urandom(KEY_BYTES))
            os.fsync(fd)
        finally:
            os.close(fd)
        try:
            os.link(temporary, path)
        except FileExistsError:
            pass  # another process made it first: use theirs
        return _read_key(path), None
    except ValueError as error:
        return None, f"{path} {error}"
    except OSError as error:
        return None, f"{path} cannot be created ({error.strerror or error})"
    finally:
        try:
            temporary.unlink()
        except OSError:
            pass


def _resolve() -> tuple[Path, bytes]:
    """The checked private cache folder and the key for its files (the same for the whole process for a given
    configuration)."""
    path = configured_path()
    where = key_path()
    memo = f"{path}\0{where}"
    with _lock:
        if memo in _resolved:
            return _resolved[memo]
        problem = _problem(path)
        key, key_problem = _key_problem(where) if problem is None else (None, None)
        if problem is None and key is not None:
            try:
                if stat.S_IMODE(path.stat().st_mode) & 0o077:
                    path.chmod(0o700)  # readable by others is not dangerous, but the folder is private
            except OSError:
                pass
            chosen = (path, key)
        else:
            chosen = (_private_temporary(), os.urandom(KEY_BYTES))
            if problem is not None:
                warn(
                    f"cache folder {path} {problem}; using a private temporary cache for this run (slower). "
                    f"Fix: set LINKAGE_LAB_CACHE to a folder of your own with mode 0700, or "
                    f"`chmod 700 {path}` if it is yours."
                )
            else:
                warn(
                    f"cache key {key_problem}; using a private temporary cache for this run (slower). "
                    f"Fix: remove {where} (a new key is made) if its folder is yours, or set LINKAGE_LAB_KEY_DIR "
                    f"to a folder of your own with mode 0700."
                )
        _resolved[memo] = chosen
        return chosen


def cache_dir() -> Path:
    """The checked private cache folder (the same for the whole process for a given configuration)."""
    return _resolve()[0]


def cache_key() -> bytes:
    """The secret that authenticates the files of :func:`cache_dir` (a run-private one with a temporary cache)."""
    return _resolve()[1]


def mac(name: str, data: bytes) -> str:
    """HMAC-SHA256 (hex) of a cache file's name and bytes under the user's key: what another user cannot forge,
    and what ties a file to its name (a valid file renamed to another entry fails)."""
    return hmac.new(cache_key(), _MAC_CONTEXT + name.encode() + b"\0" + data, hashlib.sha256).hexdigest()


def mac_matches(name: str, data: bytes, tag: bytes | str) -> bool:
    """Whether ``tag`` (as read from disk: any bytes) is the MAC of ``name`` and ``data``, in constant time."""
    if isinstance(tag, str):
        tag = tag.encode("utf-8", "replace")
    return hmac.compare_digest(mac(name, data).encode(), tag)



# A cached file's trailer: this magic, the HMAC-SHA256 of the payload (keyed per user and named by the file's
# name) in 64 hex digits, a newline. One format for numba's files and the IR modules' machine code.
MAC_MAGIC = b"\nlinkage-lab-hmac-sha256:"
TRAILER_BYTES = len(MAC_MAGIC) + 64 + 1


def tagged(name: str, payload: bytes) -> bytes:
    """``payload`` with its MAC trailer, as stored under the file name ``name``."""
    return payload + MAC_MAGIC + mac(name, payload).encode() + b"\n"


def tag_problem(name: str, data: bytes) -> str | None:
    """Why ``data`` (a whole file as read) does not carry a valid MAC trailer, or None when it does."""
    if len(data) < TRAILER_BYTES or not data.endswith(b"\n") or not data[-TRAILER_BYTES:].startswith(MAC_MAGIC):
        return "no MAC: not written by this user's Linkage Lab, or cut short"
    if not mac_matches(name, data[:-TRAILER_BYTES], data[-TRAILER_BYTES + len(MAC_MAGIC) : -1]):
        return "MAC differs: changed, or not written by this user's Linkage Lab"
    return None

class UntrustedFile(Exception):
    """A cache file that must not be loaded: the message says why (for the one line the caller prints)."""


def check_folder(folder: Path) -> None:
    """Raise :class:`UntrustedFile` unless ``folder`` (inside the cache) is a real folder of this user that group
    and others cannot write."""
    try:
        info = folder.lstat()
    except OSError as error:
        raise UntrustedFile(f"folder {folder} unreadable ({error.strerror or error})") from None
    if not stat.S_ISDIR(info.st_mode):
        raise UntrustedFile(f"{folder} is not a folder")
    problem = _not_mine(info)
    if problem:
        raise UntrustedFile(f"folder {folder} {problem}")
    if stat.S_IMODE(info.st_mode) & 0o022:
        raise UntrustedFile(f"folder {folder} is writable by group or others")


def read_trusted(path: Path) -> bytes:
    """The bytes of a cache file, read through one descriptor opened without following a symlink, after checking
    on that descriptor that it is a regular file of this user that group and others cannot write.

    Raises FileNotFoundError when there is no file, :class:`UntrustedFile` otherwise. The caller then checks
    the bytes' MAC before using them: owner and mode alone say nothing about what was written while the
    folder was open to others."""
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
    except FileNotFoundError:
        raise
    except OSError as error:
        raise UntrustedFile(f"unreadable ({error.strerror or error})") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise UntrustedFile("not a regular file")
        problem = _not_mine(info)
        if problem:
            raise UntrustedFile(problem)
        if stat.S_IMODE(info.st_mode) & 0o022:
            raise UntrustedFile(f"writable by group or others (mode {stat.S_IMODE(info.st_mode):o})")
        with os.fdopen(os.dup(fd), "rb") as stream:
            return stream.read()
    except OSError as error:
        raise UntrustedFile(f"unreadable ({error.strerror or error})") from None
    finally:
        os.close(fd)


def read_tagged(path: Path) -> tuple[bytes | None, str | None]:
    """``(payload, None)``: a cache file's bytes without their MAC trailer, read by :func:`read_trusted` and its
    MAC checked; or ``(None, why)`` when it must not be used (the caller discards it and says so in one line).
    Raises FileNotFoundError when there is no file."""
    try:
        data = read_trusted(path)
    except UntrustedFile as error:
        return None, str(error)
    problem = tag_problem(path.name, data)
    if problem is not None:
        return None, problem
    return data[:-TRAILER_BYTES], None


def discard(path: Path) -> None:
    """Remove an entry of the cache that is not trusted, whatever it is (the folder is ours, so we may)."""
    try:
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path, ignore_errors=True)
        else:
            path.unlink()
    except OSError:
        pass


def forget() -> None:
    """Forget the folders resolved so far (tests that change LINKAGE_LAB_CACHE within one process)."""
    with _lock:
        _resolved.clear()
