"""``load_compiled``: generated numeric code, derived once and kept on disk, that callers never see being made.

The cache folder is ``$LINKAGE_LAB_CACHE`` if set, else ``$XDG_CACHE_HOME/linkage-lab`` (default
``~/.cache/linkage-lab``), created private to the user (mode 0700). One ``.py`` file per formulation, number
of links and closure; its name carries a digest of everything that shapes it (package, generator sources,
sympy, numba and Python versions), so a stale entry is never picked up. Files are written under a temporary
name and renamed; the last line holds a SHA-256 of the rest, so a truncated or edited file is detected and
rebuilt, never trusted. numba keeps its compiled machine code beside the file (``__pycache__``).
sympy is imported only on a miss.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import stat
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

import numpy as np

from ..errors import LinkageError

_PACKAGE_ROOT = Path(__file__).resolve().parent.parent
_GENERATOR_SOURCES = (
    "derive/symbols.py",
    "derive/formulation.py",
    "derive/newton_euler.py",
    "derive/lagrange.py",
    "derive/dae.py",
    "codegen/emit.py",
    "codegen/cache.py",
    "simulate/kernels.py",
)
FORMULATION_NAMES = ("newton_euler", "lagrange", "dae")
_CHECKSUM_PREFIX = "# sha256: "


def cache_dir() -> Path:
    """The private cache folder, created with mode 0700 if missing."""
    override = os.environ.get("LINKAGE_LAB_CACHE")
    if override:
        path = Path(override).expanduser()
    else:
        base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        path = Path(base).expanduser() / "linkage-lab"
    path.mkdir(parents=True, exist_ok=True, mode=0o700)
    try:
        if stat.S_IMODE(path.stat().st_mode) & 0o077:
            path.chmod(0o700)
    except OSError:
        pass
    return path


def _version(dist: str) -> str:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "none"


def generator_digest() -> str:
    """Digest of every input that shapes the generated code."""
    h = hashlib.sha256()
    for rel in _GENERATOR_SOURCES:
        path = _PACKAGE_ROOT / rel
        h.update(rel.encode())
        h.update(path.read_bytes() if path.exists() else b"<missing>")
    for dist in ("linkage-lab", "sympy", "numba", "numpy"):
        h.update(f"{dist}={_version(dist)}".encode())
    h.update(sys.version.encode())
    return h.hexdigest()[:16]


@dataclass
class CompiledSystem:
    """A generated module and its layout; what simulation, CLI, app and benchmarks hold."""

    formulation: str
    n: int
    pinned: bool
    module: object
    path: Path
    from_cache: bool
    build_seconds: float

    @property
    def n_unknowns(self) -> int:
        return int(self.module.N_UNKNOWNS)

    @property
    def theta_ddot_index(self) -> np.ndarray:
        return self.module.THETA_DDOT_INDEX

    @property
    def reaction_index(self) -> np.ndarray:
        return self.module.REACTION_INDEX

    @property
    def tip_reaction_index(self) -> np.ndarray:
        return self.module.TIP_REACTION_INDEX

    def accel(self, theta, omega, params, alpha=0.0, beta=0.0):
        """Angular accelerations and the condition estimate at one state."""
        theta_ddot = np.empty(self.n)
        cond = self.module.accel(
            np.ascontiguousarray(theta, dtype=float),
            np.ascontiguousarray(omega, dtype=float),
            np.ascontiguousarray(params, dtype=float),
            float(alpha),
            float(beta),
            theta_ddot,
        )
        return theta_ddot, float(cond)

    def solve_full(self, theta, omega, params, alpha=0.0, beta=0.0):
        """All unknowns ``x`` and the condition estimate at one state."""
        x = np.empty(self.n_unknowns)
        cond = self.module.solve_full(
            np.ascontiguousarray(theta, dtype=float),
            np.ascontiguousarray(omega, dtype=float),
            np.ascontiguousarray(params, dtype=float),
            float(alpha),
            float(beta),
            x,
        )
        return x, float(cond)

    def solve_full_batch(self, theta, omega, params, alpha=0.0, beta=0.0):
        """``x`` of shape (K, k) and condition estimates (K,) for a batch of states (K, n)."""
        theta = np.ascontiguousarray(theta, dtype=float)
        x = np.empty((theta.shape[0], self.n_unknowns))
        cond = np.empty(theta.shape[0])
        self.module.solve_full_batch(
            theta, np.ascontiguousarray(omega, dtype=float), np.ascontiguousarray(params, dtype=float),
            float(alpha), float(beta), x, cond,
        )
        return x, cond

    def matrix(self, theta, omega, params):
        """The numeric A and b at one state (for condition numbers and teaching)."""
        k = self.n_unknowns
        A = np.empty((k, k))
        b = np.empty(k)
        self.module.assemble(
            np.ascontiguousarray(theta, dtype=float),
            np.ascontiguousarray(omega, dtype=float),
            np.ascontiguousarray(params, dtype=float),
            A,
            b,
        )
        return A, b


_loaded: dict = {}
_lock = threading.Lock()


def _key(formulation: str, n: int, pinned: bool) -> str:
    return f"{formulation}-n{n}-{'pinned' if pinned else 'open'}"


def _verified_text(path: Path) -> str | None:
    """The file's text if its checksum line matches, else None."""
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError):
        return None
    body, sep, last = text.rstrip("\n").rpartition("\n")
    if not sep or not last.startswith(_CHECKSUM_PREFIX):
        return None
    if hashlib.sha256(body.encode()).hexdigest() != last[len(_CHECKSUM_PREFIX) :].strip():
        return None
    return text


def _write_atomically(path: Path, text: str) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as handle:
            handle.write(text)
            handle.flush()
            os.fsync(handle.fileno())
        os.chmod(tmp, 0o600)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def _build_source(formulation: str, n: int, pinned: bool, digest: str) -> str:
    from ..derive import FORMULATIONS  # imports sympy: only on a miss
    from .emit import emit_module

    system = FORMULATIONS[formulation]().derive(n, pinned)
    kernels_path = _PACKAGE_ROOT / "simulate" / "kernels.py"
    kernels = kernels_path.read_text() if kernels_path.exists() else ""
    header = (
        f'"""Generated by Linkage Lab from the {formulation} derivation: n = {n}, '
        f'{"tip pinned" if pinned else "open chain"}.\n\n'
        f"Unknowns x = {[str(u) for u in system.unknowns]}.\n"
        f"Generator digest {digest}. Do not edit: the file is checked and rebuilt when in doubt.\n"
        '"""'
    )
    body = emit_module(system, header, kernels).rstrip("\n")
    return body + "\n" + _CHECKSUM_PREFIX + hashlib.sha256(body.encode()).hexdigest() + "\n"


def _import(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    # numba's on-disk cache finds the functions' globals again by module name: register it.
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        sys.modules.pop(name, None)
        raise
    return module


def load_compiled(formulation: str, n: int, pinned: bool = False) -> CompiledSystem:
    """Ready numeric functions for a formulation; derived and generated only when the cache lacks them."""
    if formulation not in FORMULATION_NAMES:
        raise LinkageError(f"method = {formulation!r}: allowed {', '.join(FORMULATION_NAMES)}")
    if not 1 <= int(n) <= 12:
        raise LinkageError(f"links = {n}: allowed range 1 <= links <= 12")
    key = _key(formulation, int(n), bool(pinned))
    with _lock:
        if key in _loaded:
            return _loaded[key]
        start = time.perf_counter()
        folder = cache_dir()
        digest = generator_digest()
        path = folder / f"{key}-{digest}.py"
        text = _verified_text(path) if path.exists() else None
        from_cache = text is not None
        if text is None:
            _write_atomically(path, _build_source(formulation, int(n), bool(pinned), digest))
            for stale in folder.glob(f"{key}-*.py"):
                if stale != path:
                    try:
                        stale.unlink()
                    except OSError:
                        pass
        module_name = f"linkage_lab_generated_{key.replace('-', '_')}_{digest}"
        try:
            module = _import(path, module_name)
        except Exception:  # a file that passed its checksum but does not import: rebuild once
            _write_atomically(path, _build_source(formulation, int(n), bool(pinned), digest))
            module = _import(path, module_name)
            from_cache = False
        compiled = CompiledSystem(
            formulation=formulation,
            n=int(n),
            pinned=bool(pinned),
            module=module,
            path=path,
            from_cache=from_cache,
            build_seconds=time.perf_counter() - start,
        )
        _loaded[key] = compiled
        return compiled


def clear_memory_cache() -> None:
    """Forget loaded modules (tests use it to exercise the disk cache)."""
    with _lock:
        _loaded.clear()
