"""Compile an LLVM IR module once per installation: its machine code kept in the private cache folder.

Every generated system (:mod:`physics.codegen.native`) and the RK45/DOP853 drivers
(:mod:`physics.codegen.native_integrators`) are LLVM IR compiled with llvmlite, 0.02-0.1 s a module: most of a
warm run once numba is off its path. So the object file MCJIT makes is kept, and a later process adds it to an
empty execution engine instead of parsing, optimising and compiling the IR again.

An object file is machine code this process jumps into, so it gets the cache's trust rules
(:mod:`physics.cache_folder`): it lives in ``<cache folder>/native/`` (a folder of this user's that group and
others cannot write, discarded and made again if it is not), it is read once through
:func:`~physics.cache_folder.read_trusted` (a regular file of this user, not writable by others) and its bytes
are used only when their HMAC-SHA256 trailer (under the user's secret key) matches: nothing is loaded that this
user's Linkage Lab did not write. A file that fails any check is removed with one line on stderr and the module
is compiled again and stored afresh.

The file's name is a digest of everything that shapes the machine code: the IR text, what is done to it before
code generation (``variant`` and the source of the modules that do it), the llvmlite version, and the host's
target triple, CPU name and CPU features (an object made for another CPU is never picked up). The drivers' IR is
itself a function of the project's source, so they are named by :func:`sources_digest` instead of their text,
and a process that loads them does not build the IR at all.
"""

from __future__ import annotations

import hashlib
import os
import re
import threading
import time
from collections.abc import Callable
from pathlib import Path

from ..cache_folder import (
    UntrustedFile,
    cache_dir,
    check_folder,
    discard,
    read_tagged,
    tagged,
    warn,
)
from ..file_io import write_atomically

FOLDER = "native"
SUFFIX = ".o"
STALE_SECONDS = 30 * 24 * 3600.0  # object files not loaded for a month (other IR, another llvmlite or CPU)
_SHAPING_SOURCES = ("machine_code.py", "native.py", "native_integrators.py")  # what is done to the IR
_DEFINED = re.compile(r"^define [^@\n]*@\"?([A-Za-z_.$][\w.$]*)\"?\(", re.MULTILINE)
_lock = threading.Lock()
_memo: dict[str, object] = {}
_tidied: list[bool] = []
COUNTS = {"compiled": 0, "loaded": 0}  # this process's modules, by where their machine code came from


def llvm_binding():
    """llvmlite's binding with the host target initialised (once; idempotent in LLVM)."""
    import llvmlite.binding as llvm  # noqa: PLC0415  (only when a module is compiled or loaded)

    if "llvm" not in _memo:
        llvm.initialize_native_target()
        llvm.initialize_native_asmprinter()
        _memo["llvm"] = llvm
    return llvm


def host() -> str:
    """The llvmlite version and the host's triple, CPU name and CPU features: what an object file is made for."""
    if "host" not in _memo:
        import llvmlite  # noqa: PLC0415

        llvm = llvm_binding()
        _memo["host"] = "\n".join((llvmlite.__version__, llvm.get_default_triple(), llvm.get_host_cpu_name(),
                                   llvm.get_host_cpu_features().flatten()))
    return str(_memo["host"])


def _shaping_digest() -> bytes:
    if "shaping" not in _memo:
        here = Path(__file__).resolve().parent
        h = hashlib.sha256()
        for name in _SHAPING_SOURCES:
            h.update(name.encode() + b"\0" + (here / name).read_bytes())
        _memo["shaping"] = h.digest()
    return _memo["shaping"]  # type: ignore[return-value]


def object_name(ir_text: str, variant: str) -> str:
    """The cache file name of ``ir_text``'s machine code as compiled by ``variant`` on this host (``ir_text``:
    the IR, or a text that determines it, such as :func:`sources_digest` and what the IR is built for)."""
    h = hashlib.sha256()
    h.update(b"linkage-lab object v1\0" + variant.encode() + b"\0" + host().encode() + b"\0")
    h.update(_shaping_digest())
    h.update(ir_text.encode())
    return h.hexdigest()[:32] + SUFFIX


def sources_digest() -> str:
    """Digest of every source file of :mod:`physics.codegen` and :mod:`physics.kernels` (and numpy's version,
    which reads their tables): all that the drivers' IR is built from, so it names their machine code without
    building the IR."""
    if "sources" not in _memo:
        import numpy  # noqa: PLC0415  (imported already by every caller; its version is part of the digest)

        package = Path(__file__).resolve().parent.parent
        h = hashlib.sha256(numpy.__version__.encode())
        for folder in ("codegen", "kernels"):
            for path in sorted((package / folder).glob("*.py")):
                h.update(f"{folder}/{path.name}".encode() + b"\0" + path.read_bytes())
        _memo["sources"] = h.hexdigest()
    return str(_memo["sources"])


def defined_functions(ir_text: str) -> set[str]:
    """The names of the functions ``ir_text`` defines (not those it only declares)."""
    return set(_DEFINED.findall(ir_text))


def folder() -> Path | None:
    """``<cache folder>/native``, checked to be this user's and closed to others (one that is not is discarded
    and made again, with one line); None when it cannot be had (the run then compiles without keeping)."""
    wanted = cache_dir() / FOLDER
    key = f"folder:{wanted}"
    with _lock:
        if key in _memo:
            return _memo[key]  # type: ignore[return-value]
        chosen: Path | None = wanted
        for attempt in range(2):
            try:
                wanted.mkdir(mode=0o700, exist_ok=True)
                check_folder(wanted)
                if attempt:
                    warn(f"machine-code cache: folder {wanted} was not trusted; discarded and made again")
                break
            except (OSError, UntrustedFile) as error:
                if attempt:
                    warn(f"machine-code cache: {error}; compiling without keeping machine code this run")
                    chosen = None
                else:
                    discard(wanted)
        _memo[key] = chosen
        return chosen


def _trusted_object(path: Path) -> bytes | None:
    """The object file's bytes when it is there and trusted; None when there is none. A file that fails a
    check is removed, with one line on stderr."""
    try:
        payload, problem = read_tagged(path)
    except FileNotFoundError:
        return None
    if payload is not None:
        return payload
    warn(f"machine-code cache file {path} is damaged or not trusted ({problem}); discarded and rebuilt")
    discard(path)
    return None



def _store(path: Path, code: bytes) -> None:
    """The object file and its MAC trailer, written 0600 under a temporary name and renamed into place (a
    failure only costs the next process a compilation)."""
    try:
        write_atomically(path, tagged(path.name, code), mode=0o600)
    except OSError:
        return
    if not _tidied:
        _tidied.append(True)
        _remove_stale(path.parent)


def _remove_stale(where: Path) -> None:
    now = time.time()
    for stale in where.glob(f"*{SUFFIX}"):
        try:
            if now - stale.lstat().st_mtime > STALE_SECONDS:
                stale.unlink()
        except OSError:
            pass


def is_cached(key: str, variant: str) -> bool:
    """Whether the cache folder holds an object file for ``key`` and ``variant`` (its trust is checked only when
    :func:`compile_module` loads it): lets a caller choose to compile a module only when it is worth it."""
    where = folder()
    return where is not None and (where / object_name(key, variant)).is_file()


def compile_module(ir_text: str | Callable[[], str], variant: str, prepare: Callable, target_machine: Callable,
                   key: str | None = None):
    """An MCJIT execution engine holding ``ir_text``'s machine code, finalised: loaded from the cache when a
    trusted object file of it is there, else compiled (``prepare(module)`` runs the caller's passes on the
    parsed IR; ``target_machine()`` makes a fresh target machine, as every engine owns its own) and stored.
    ``variant`` names the caller's passes and code generation level. ``key``: a text that determines the IR
    (then ``ir_text`` may be a function that builds it, called only to compile); default the IR text itself."""
    llvm = llvm_binding()
    if key is None:
        ir_text = ir_text if isinstance(ir_text, str) else ir_text()
        key = ir_text
    where = folder()
    path = where / object_name(key, variant) if where is not None else None
    code = _trusted_object(path) if path is not None else None
    if path is not None and code is not None:
        engine = llvm.create_mcjit_compiler(llvm.parse_assembly(""), target_machine())
        engine.add_object_file(llvm.ObjectFileRef.from_data(code))
        engine.finalize_object()
        COUNTS["loaded"] += 1
        try:
            os.utime(path)  # in use: not stale
        except OSError:
            pass
        return engine
    module = llvm.parse_assembly(ir_text if isinstance(ir_text, str) else ir_text())
    module.verify()
    prepare(module)
    engine = llvm.create_mcjit_compiler(module, target_machine())
    made: list[bytes] = []
    engine.set_object_cache(notify_func=lambda _module, buffer: made.append(bytes(buffer)))
    engine.finalize_object()
    COUNTS["compiled"] += 1
    if path is not None and made:
        _store(path, made[0])
    return engine
