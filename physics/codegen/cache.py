"""``load_compiled``: generated numeric code, derived once and kept on disk, that callers never see being made.

One ``.py`` file per formulation, number of links and closure, in the private cache folder
(:mod:`physics.cache_folder`); its name carries a digest of everything that shapes it (every source file of the
derivations and of the code generator, the kernels' binary contract, and the sympy, numba, numpy and Python
versions), computed from the files themselves, so a stale entry is never picked up. Files are written under a
temporary name and renamed; the last line holds a SHA-256 of the rest, so a truncated or edited file is
detected and rebuilt, never trusted. The file holds only the mechanism's layout and straight-line arithmetic
as LLVM IR, compiled to machine code in the loading process on first use (:mod:`physics.codegen.native`,
a fraction of a second); the once-compiled kernels of :mod:`physics.kernels` call it through its address.
sympy is imported only on a miss.
"""

from __future__ import annotations

import hashlib
import importlib.util
import sys
import threading
import time
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

import numpy as np

from ..cache_folder import cache_dir, warn
from ..errors import LinkageError
from ..files import write_atomically
from ..kernels import batch, explicit_rk, midpoint, projection, system, variational
from ..kernels.abi import make_layout
from ..registry import FORMULATION_NAMES
from .native import NativeModule

_PACKAGE_ROOT = Path(__file__).resolve().parent.parent
# Everything the generated text depends on: the derivations, the generator, and the contract it is compiled to.
_GENERATOR_FOLDERS = ("derive", "codegen")
_GENERATOR_FILES = ("kernels/abi.py", "model.py")
MAX_LINKS = 12
_CHECKSUM_PREFIX = "# sha256: "


def _generator_sources() -> list[Path]:
    files = [path for folder in _GENERATOR_FOLDERS for path in sorted((_PACKAGE_ROOT / folder).glob("*.py"))]
    return files + [_PACKAGE_ROOT / rel for rel in _GENERATOR_FILES]


def _version(dist: str) -> str:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "none"


_digest_memo: list[str] = []


def generator_digest() -> str:
    """Digest of every input that shapes the generated code, read from the files themselves."""
    if _digest_memo:
        return _digest_memo[0]
    h = hashlib.sha256()
    for path in _generator_sources():
        h.update(str(path.relative_to(_PACKAGE_ROOT)).encode())
        h.update(path.read_bytes() if path.exists() else b"<missing>")
    for dist in ("sympy", "numba", "numpy"):
        h.update(f"{dist}={_version(dist)}".encode())
    h.update(sys.version.encode())
    _digest_memo.append(h.hexdigest()[:16])
    return _digest_memo[0]


def _c(array) -> np.ndarray:
    return np.ascontiguousarray(array, dtype=np.float64)


@dataclass
class CompiledSystem:
    """A mechanism's generated functions and layout, and every numeric operation on them.

    The generated IR is compiled to machine code on first use; all loops run in the once-compiled kernels of
    :mod:`physics.kernels`, which call it through its address."""

    formulation: str
    n: int
    pinned: bool
    module: object
    path: Path
    from_cache: bool
    build_seconds: float
    _functions: dict = field(default_factory=dict, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    # ---------------------------------------------------------------- layout
    @property
    def n_unknowns(self) -> int:
        return int(self.module.N_UNKNOWNS)

    @property
    def theta_ddot_index(self) -> np.ndarray:
        return np.array(self.module.THETA_DDOT_INDEX, dtype=np.int64)

    @property
    def reaction_index(self) -> np.ndarray:
        return np.array(self.module.REACTION_INDEX, dtype=np.int64).reshape(-1, 2)

    @property
    def tip_reaction_index(self) -> np.ndarray:
        return np.array(self.module.TIP_REACTION_INDEX, dtype=np.int64)

    @property
    def has_lagrangian(self) -> bool:
        return bool(self.module.HAS_LAGRANGIAN)

    @property
    def layout(self) -> np.ndarray:
        if "layout" not in self._functions:
            m = self.module
            solve = self._native("solve") if m.STRUCTURED else 0
            self._functions["layout"] = make_layout(
                m.N_LINKS, m.N_UNKNOWNS, m.PINNED, m.TIP_ROWS, m.THETA_DDOT_INDEX, m.SYMMETRIC, solve
            )
        return self._functions["layout"]

    # ---------------------------------------------------------------- compiled functions (lazy)
    def _native(self, name: str):
        with self._lock:
            if "native" not in self._functions:
                start = time.perf_counter()
                self._functions["native"] = NativeModule(self.module.LLVM_IR)
                self.build_seconds += time.perf_counter() - start
            return self._functions["native"].addresses[name]

    @property
    def assemble_function(self):
        """The address of the generated ``assemble``'s machine code (the kernels' first argument)."""
        return self._native("assemble")

    @property
    def mass_and_force_function(self):
        if not self.has_lagrangian:
            raise LinkageError(f"the variational integrator needs the Lagrange method, not {self.formulation}")
        return self._native("mass_and_force")

    # ---------------------------------------------------------------- one state, or a batch of states
    def accel_batch(self, theta, omega, params, alpha=0.0, beta=0.0):
        """Angular accelerations (K, n) and condition estimates (K,) for states (K, n)."""
        theta = np.atleast_2d(_c(theta))
        theta_ddot = np.empty_like(theta)
        cond = np.empty(theta.shape[0])
        system.accel_states(self.assemble_function, self.layout, theta, np.atleast_2d(_c(omega)), _c(params),
                            float(alpha), float(beta), theta_ddot, cond)
        return theta_ddot, cond

    def accel(self, theta, omega, params, alpha=0.0, beta=0.0):
        """Angular accelerations and the condition estimate at one state."""
        theta_ddot, cond = self.accel_batch(theta, omega, params, alpha, beta)
        return theta_ddot[0], float(cond[0])

    def solve_full_batch(self, theta, omega, params, alpha=0.0, beta=0.0):
        """``x`` of shape (K, k) and condition estimates (K,) for a batch of states (K, n)."""
        theta = np.atleast_2d(_c(theta))
        x = np.empty((theta.shape[0], self.n_unknowns))
        cond = np.empty(theta.shape[0])
        system.solve_states(self.assemble_function, self.layout, theta, np.atleast_2d(_c(omega)), _c(params),
                            float(alpha), float(beta), x, cond)
        return x, cond

    def solve_full(self, theta, omega, params, alpha=0.0, beta=0.0):
        """All unknowns ``x`` and the condition estimate at one state."""
        x, cond = self.solve_full_batch(theta, omega, params, alpha, beta)
        return x[0], float(cond[0])

    def matrices(self, theta, omega, params):
        """The numeric A (K, k, k) and b (K, k) at a batch of states (for condition numbers and teaching)."""
        theta = np.atleast_2d(_c(theta))
        k = self.n_unknowns
        A = np.empty((theta.shape[0], k, k))
        b = np.empty((theta.shape[0], k))
        system.assemble_states(self.assemble_function, self.layout, theta, np.atleast_2d(_c(omega)), _c(params),
                               A, b)
        return A, b

    def matrix(self, theta, omega, params):
        """The numeric A and b at one state."""
        A, b = self.matrices(theta, omega, params)
        return A[0], b[0]

    def mass_and_force(self, theta, omega, params):
        """The Lagrangian's mass matrix (n, n) and force (n,) at one state (Lagrange only)."""
        theta = np.atleast_2d(_c(theta))
        M = np.empty((theta.shape[0], self.n, self.n))
        force = np.empty((theta.shape[0], self.n))
        system.lagrangian_states(self.mass_and_force_function, theta, np.atleast_2d(_c(omega)), _c(params),
                                 M, force)
        return M[0], force[0]

    # ---------------------------------------------------------------- integrators (physics.kernels)
    def integrate_rk45(self, y0, t0, t_end, t_eval, params, rtol, atol, alpha, beta, project, max_steps,
                       y_out, cond_out):
        return explicit_rk.integrate_rk45(self.assemble_function, self.layout, _c(y0), t0, t_end, _c(t_eval),
                                          _c(params), rtol, atol, alpha, beta, project, max_steps, y_out, cond_out)

    def integrate_dop853(self, y0, t0, t_end, t_eval, params, rtol, atol, alpha, beta, project, max_steps,
                         y_out, cond_out):
        return explicit_rk.integrate_dop853(self.assemble_function, self.layout, _c(y0), t0, t_end, _c(t_eval),
                                            _c(params), rtol, atol, alpha, beta, project, max_steps, y_out,
                                            cond_out)

    def integrate_ode45(self, y0, t0, t_end, t_eval, params, rtol, atol, alpha, beta, project, max_steps,
                        y_out, cond_out):
        from ..kernels import ode45  # noqa: PLC0415  (compiled on first use only: few runs ask for it)

        return ode45.integrate_ode45(self.assemble_function, self.layout, _c(y0), t0, t_end, _c(t_eval), _c(params),
                                     rtol, atol, alpha, beta, project, max_steps, y_out, cond_out)

    def integrate_ode45_refined(self, y0, t0, t_end, params, rtol, atol, alpha=0.0, beta=0.0, project=True,
                                refine=4, max_steps=100_000):
        """MATLAB's ``ode45(f, [t0 t_end], y0)`` output: ``refine`` points per step (``Refine``, default 4).

        Returns ``(t, y, status, n_steps)``: the start and ``refine`` rows per accepted step."""
        from ..kernels import ode45  # noqa: PLC0415

        rows = ode45.refined_rows(max_steps, refine)
        t_out = np.empty(rows)
        y_out = np.empty((rows, len(y0)))
        status, n_steps, _, _, filled = ode45.integrate_ode45_refined(
            self.assemble_function, self.layout, _c(y0), t0, t_end, _c(params), rtol, atol, alpha, beta, project,
            refine, t_out, y_out)
        return t_out[:filled], y_out[:filled], int(status), int(n_steps)

    def integrate_midpoint(self, y0, t0, t_end, h, t_eval, params, alpha, beta, project, y_out, cond_out):
        return midpoint.integrate_midpoint(self.assemble_function, self.layout, _c(y0), t0, t_end, h, _c(t_eval),
                                           _c(params), alpha, beta, project, y_out, cond_out)

    def integrate_variational(self, y0, t0, t_end, h, t_eval, params, y_out, cond_out):
        return variational.integrate_variational(
            self.assemble_function, self.mass_and_force_function, self.layout, _c(y0), t0, t_end, h, _c(t_eval),
            _c(params), y_out, cond_out,
        )

    def rk4_batch_step(self, theta, omega, params, h, alpha, beta, work, cond_out):
        return batch.rk4_batch_step(self.assemble_function, self.layout, theta, omega, _c(params), h, alpha, beta,
                                    work, cond_out)

    @staticmethod
    def project_position(theta, params):
        return projection.project_position(theta, params)

    @staticmethod
    def project_velocity(theta, omega, params):
        return projection.project_velocity(theta, omega, params)


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
    write_atomically(path, text, mode=0o600)


def _build_source(formulation: str, n: int, pinned: bool, digest: str) -> str:
    # sympy boundary: the derivations and the emitter import sympy, so they are loaded only on a cache miss.
    from ..derive import FORMULATIONS  # noqa: PLC0415
    from .emit import emit_module  # noqa: PLC0415

    system = FORMULATIONS[formulation]().derive(n, pinned)
    header = (
        f'"""Generated by Linkage Lab from the {formulation} derivation: n = {n}, '
        f'{"tip pinned" if pinned else "open chain"}.\n\n'
        f"Unknowns x = {[str(u) for u in system.unknowns]}.\n"
        f"Generator digest {digest}. Do not edit: the file is checked and rebuilt when in doubt.\n"
        '"""'
    )
    body = emit_module(system, header).rstrip("\n")
    return body + "\n" + _CHECKSUM_PREFIX + hashlib.sha256(body.encode()).hexdigest() + "\n"


def _remove_stale(folder: Path, key: str, current: Path) -> None:
    """Entries of the same mechanism from another generator version."""
    for stale in folder.glob(f"{key}-*.py"):
        if stale != current:
            try:
                stale.unlink()
            except OSError:
                pass


def _import(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None, path  # a .py path always has a source loader
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
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= int(n) <= MAX_LINKS:
        raise LinkageError(f"links = {n!r}: allowed an integer 1 <= links <= {MAX_LINKS}")
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
        if text is None and path.exists():
            warn(f"generated file {path} is damaged (checksum differs); rebuilding it")
        if text is None:
            _write_atomically(path, _build_source(formulation, int(n), bool(pinned), digest))
            _remove_stale(folder, key, path)
        module_name = f"linkage_lab_generated_{key.replace('-', '_')}_{digest}"
        try:
            module = _import(path, module_name)
        except Exception:  # a file that passed its checksum but does not import: rebuild once
            warn(f"generated file {path} did not import; rebuilding it")
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


def is_generated(formulation: str, n: int, pinned: bool = False) -> bool:
    """True if this mechanism's generated file is in the cache and intact: loading it needs no sympy.

    The app asks before a build, to run the derivation in a worker process (:mod:`physics.codegen.prebuild`)
    rather than in the server's interpreter."""
    key = _key(formulation, int(n), bool(pinned))
    with _lock:
        if key in _loaded:
            return True
    path = cache_dir() / f"{key}-{generator_digest()}.py"
    return path.exists() and _verified_text(path) is not None
