"""``load_compiled``: generated numeric code, derived once and kept on disk, that callers never see being made.

One ``.py`` file per formulation, number of links and closure, in the private cache folder
(:mod:`physics.cache_folder`); its name carries a digest of everything that shapes it (every source file of the
derivations and of the code generator, the kernels' binary contract, and the sympy, numba, numpy and Python
versions), computed from the files themselves, so a stale entry is never picked up. Files are written under a
temporary name and renamed; the last line holds an HMAC-SHA256 of the file's name and the rest under the user's
secret key (:mod:`physics.cache_folder`), so a truncated, edited, renamed or planted file (whoever wrote it, with
whatever checksum) is detected and rebuilt, never run. What runs is exactly the bytes that were checked: they are
compiled here and executed into a fresh module, so Python never writes or reads ``__pycache__`` bytecode for
them (a stale ``.pyc`` beside the source used to run instead of it). The file holds only the mechanism's layout
and straight-line arithmetic as LLVM IR, compiled to machine code in the loading process on first use
(:mod:`physics.codegen.native`, a fraction of a second); the once-compiled kernels of :mod:`physics.kernels` call
it through its address.
sympy is imported only on a miss.
"""

from __future__ import annotations

import hashlib
import os
import sys
import threading
import time
import types
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..cache_folder import UntrustedFile, cache_dir, discard, mac, mac_matches, read_trusted, warn
from ..errors import LinkageError
from ..file_io import write_atomically
from ..kernels.first_compile import call_announced
from ..kernels.layout import LAYOUT_RHS, LAYOUT_WEIGHTS, make_layout
from ..registry import FORMULATION_NAMES
from . import native_integrators, native_samples, native_states
from .native import NativeModule

_PACKAGE_ROOT = Path(__file__).resolve().parent.parent
# A system's specialised drivers and samples' solve (physics.codegen.specialised_ir) compiled in a background
# thread (False: in the call that asks, as the tests and benchmarks want to know when it is there).
SPECIALISE_IN_BACKGROUND = True
# A maximal mechanism's weighted driver (CompiledSystem.specialised_driver with a weighted_layout) is compiled,
# when its machine code is not cached yet, only for a run expected to evaluate at least this many right-hand
# sides (this process's rate per simulated second so far times the run's span): its O2 compilation costs about
# 1 s once per installation and saves some 0.6 us per evaluation, so a one-off short run (a 60 s CLI run of the
# triple pendulum file, about 14,000) does not pay for it, a long one (2000 s, about 480,000) or an app
# session's chunks added up do.
SPECIALISE_WEIGHTED_RHS = 100_000
# Everything the generated text depends on: the derivations, the generator, and the contract it is compiled to.
_GENERATOR_FOLDERS = ("derive", "codegen")
_GENERATOR_FILES = ("kernels/abi.py", "kernels/layout.py", "model.py")
_GENERATOR_PATTERNS = ("mechanism/parameters.py", "mechanism/symbolic*.py", "mechanism/joints/*.py",
                       "mechanism/description.py", "mechanism/topology.py")  # a mechanism's derivations, the model
# they read and the spanning tree's search (the order of the tree formulations' coordinates)
MAX_LINKS = 12
_MAC_PREFIX = b"# hmac-sha256: "


def _generator_sources() -> list[Path]:
    files = [path for folder in _GENERATOR_FOLDERS for path in sorted((_PACKAGE_ROOT / folder).glob("*.py"))]
    files += [path for pattern in _GENERATOR_PATTERNS for path in sorted(_PACKAGE_ROOT.glob(pattern))]
    return files + [_PACKAGE_ROOT / rel for rel in _GENERATOR_FILES]


def _installed_versions(dists: tuple[str, ...]) -> dict[str, str]:
    """``importlib.metadata.version(dist)`` of each of ``dists`` ("none" where it raises
    ``PackageNotFoundError``) without importing :mod:`importlib.metadata`, whose email parser, zipfile and csv cost
    every process 3-4 ms: the ``Version:`` header of the first ``DIST-*.dist-info`` (or ``.egg-info``) found on
    ``sys.path``, in its order, as that function finds it. For packages the process has not imported (sympy and
    numba: a warm run never does); one pass over ``sys.path`` for all of them."""
    versions: dict[str, str] = {}
    for entry in sys.path:
        folder = entry or "."
        try:
            names = [name for name in os.listdir(folder) if name.endswith(("dist-info", "egg-info"))]
        except OSError:  # a zip file, a path hook, a folder that is gone
            continue
        for name in sorted(names):
            stem, _, suffix = name.rpartition(".")
            dist = stem.partition("-")[0].lower().replace(".", "_")
            if dist not in dists or dist in versions:
                continue
            found = Path(folder, name)
            headers = found if found.is_file() else found / ("METADATA" if suffix == "dist-info" else "PKG-INFO")
            try:
                with headers.open(encoding="utf-8") as text:
                    for line in text:
                        if not line.strip():  # the headers end at the first empty line
                            break
                        if line.startswith("Version:"):
                            versions[dist] = line.partition(":")[2].strip()
                            break
            except OSError:
                continue
    return {dist: versions.get(dist, "none") for dist in dists}


def _versions() -> str:
    """The versions the generated code depends on: numpy's from the module itself (imported above, so free),
    sympy's and numba's from their installed metadata (:func:`_installed_versions`)."""
    installed = _installed_versions(("sympy", "numba"))
    return f"sympy={installed['sympy']};numba={installed['numba']};numpy={np.__version__}"


_digest_memo: list[str] = []


def generator_digest() -> str:
    """Digest of every input that shapes the generated code, read from the files themselves."""
    if _digest_memo:
        return _digest_memo[0]
    h = hashlib.sha256()
    for path in _generator_sources():
        h.update(str(path.relative_to(_PACKAGE_ROOT)).encode())
        h.update(path.read_bytes() if path.exists() else b"<missing>")
    h.update(_versions().encode())
    h.update(sys.version.encode())
    _digest_memo.append(h.hexdigest()[:16])
    return _digest_memo[0]


def _c(array) -> np.ndarray:
    return np.ascontiguousarray(array, dtype=np.float64)


def _first_call(kernel, what: str, *arguments):
    """``kernel(*arguments)``, after the one line that says it is about to be compiled, when it is."""
    return call_announced(kernel, arguments, what)


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
        return self._index("THETA_DDOT_INDEX", (-1,))

    @property
    def reaction_index(self) -> np.ndarray:
        return self._index("REACTION_INDEX", (-1, 2))

    @property
    def tip_reaction_index(self) -> np.ndarray:
        return self._index("TIP_REACTION_INDEX", (-1,))

    def _index(self, name: str, shape: tuple[int, ...]) -> np.ndarray:
        """The module's index tuple ``name`` as an int64 array of ``shape``, made once per system and read-only
        (every run's samples read them: three small arrays a run otherwise)."""
        key = f"index {name}"
        index = self._functions.get(key)
        if index is None:
            index = np.array(getattr(self.module, name), dtype=np.int64).reshape(shape)
            index.setflags(write=False)
            index = self._functions.setdefault(key, index)
        return index

    @property
    def has_lagrangian(self) -> bool:
        return bool(self.module.HAS_LAGRANGIAN)

    @property
    def layout(self) -> np.ndarray:
        """The kernels' layout for one evaluation at a time (samples, position analysis, a solve): without the
        fused ``rhs``, whose separate module is compiled only for an integration (:attr:`integration_layout`)."""
        if "layout" not in self._functions:
            m = self.module
            solve = self._native("solve") if m.STRUCTURED else 0
            constraints = self._native("constraints") if m.CONSTRAINT_ROWS else 0
            self._functions["layout"] = make_layout(
                m.N_LINKS, m.N_UNKNOWNS, m.THETA_DDOT_INDEX, n_parameters=m.N_PARAMETERS, symmetric=m.SYMMETRIC,
                solve_address=solve, rhs_address=0, constraint_rows=m.CONSTRAINT_ROWS, constraint_address=constraints,
                time_index=None if m.TIME_INDEX < 0 else m.TIME_INDEX,
            )
        return self._functions["layout"]

    @property
    def integration_layout(self) -> np.ndarray:
        """:attr:`layout` with the address of the generated fused ``rhs`` (a structured system's assemble and
        elimination in one function: the same bits, about half the cost per evaluation), which the integrators'
        stages call. Its module is compiled on first use: a run that never integrates (a driven mechanism's
        position analysis, a batch of samples) does not pay for it."""
        if "integration_layout" not in self._functions:
            layout = self.layout
            if self.module.STRUCTURED and getattr(self.module, "LLVM_IR_RHS", ""):
                layout = layout.copy()
                layout[LAYOUT_RHS] = self._native("rhs", "LLVM_IR_RHS")
            self._functions["integration_layout"] = layout
        return self._functions["integration_layout"]

    def weighted_layout(self, offset: int, integrating: bool = True) -> np.ndarray:
        """:attr:`integration_layout` (``integrating``) or :attr:`layout` with the projection weights at
        ``offset`` of the parameter vector (``LAYOUT_WEIGHTS``: a maximal mechanism's runs), one array per
        offset kept with the system: a run's layout is then the system's own, so its specialised driver
        (:meth:`specialised_driver`) can take it, as it takes the unweighted one (a copy per run could not)."""
        key = f"weighted layout {int(integrating)} {int(offset)}"
        layout = self._functions.get(key)
        if layout is None:
            layout = (self.integration_layout if integrating else self.layout).copy()
            layout[LAYOUT_WEIGHTS] = int(offset)
            with self._lock:
                layout = self._functions.setdefault(key, layout)
        return layout

    def is_own_integration_layout(self, layout: np.ndarray) -> bool:
        """Whether ``layout`` is :attr:`integration_layout` or one of its :meth:`weighted_layout` arrays: the
        layouts a specialised driver is made for."""
        if layout is self.integration_layout:
            return True
        return self._functions.get(f"weighted layout 1 {int(layout[LAYOUT_WEIGHTS])}") is layout

    # ---------------------------------------------------------------- compiled functions (lazy)
    def _native(self, name: str, source: str = "LLVM_IR"):
        """The address of generated function ``name``, compiling the module ``source`` (an IR text of the
        generated module) on first use."""
        with self._lock:
            if source not in self._functions:
                start = time.perf_counter()
                self._functions[source] = NativeModule(getattr(self.module, source))
                self.build_seconds += time.perf_counter() - start
            return self._functions[source].addresses[name]

    @property
    def assemble_function(self):
        """The address of the generated ``assemble``'s machine code (the kernels' first argument)."""
        return self._native("assemble")

    @property
    def has_sample(self) -> bool:
        """Whether the generated module has ``sample`` (a sample's solve and kinematics in one call: every system
        in tree coordinates), compiled or not."""
        found = self._functions.get("has sample")
        if found is None:  # read once: every run's plan asks
            found = self._functions["has sample"] = bool(getattr(self.module, "LLVM_IR_SAMPLE", "").strip())
        return found

    @property
    def sample_function(self) -> int:
        """The address of the generated ``sample``, its module (``LLVM_IR_SAMPLE``) compiled on first use; 0
        without one. The specialised samples' pass asks for it (:meth:`samples_solve`), so a one-off run never
        compiles it."""
        return int(self._native("sample", "LLVM_IR_SAMPLE")) if self.has_sample else 0

    def specialised_samples(self):
        """The :class:`~physics.codegen.native_samples.SpecialisedSamples` :meth:`samples_solve` has made, or None
        (nothing compiled or counted here: a run's plan asks which solve it holds)."""
        made = self._functions.get(f"specialised {native_samples.samples_kind(self.has_sample)}")
        return made[0] if made is not None else None

    @property
    def compiled_sample_function(self) -> int:
        """:attr:`sample_function` when its module is compiled already, else 0 (nothing compiled here; one
        dictionary look-up, as every run asks: the entry is set once, whole, under the lock)."""
        module = self._functions.get("LLVM_IR_SAMPLE")
        return module.addresses["sample"] if module is not None else 0

    @property
    def mass_and_force_function(self):
        if not self.has_lagrangian:
            raise LinkageError(f"the variational integrator needs the Lagrange method, not {self.formulation}")
        return self._native("mass_and_force")

    # ---------------------------------------------------------------- one state, or a batch of states
    def accel_batch(self, theta, omega, params, alpha=0.0, beta=0.0):
        """Angular accelerations (K, n) and condition estimates (K,) for states (K, n)."""
        from ..kernels import system  # noqa: PLC0415  (numba: only when a kernel runs)

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
        from ..kernels import system  # noqa: PLC0415  (numba: only when a kernel runs)

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

    def solve_samples(self, theta, omega, params, alpha=0.0, beta=0.0):
        """:meth:`solve_full_batch` for a run's samples (C-contiguous (K, n) states), by the samples' pass
        generated as LLVM IR (:mod:`physics.codegen.native_samples`): the same bits, and nothing for numba to
        compile in an empty cache. The other entry points keep the numba kernels (their cache is what the cache
        trust tests exercise)."""
        x = np.empty((theta.shape[0], self.n_unknowns))
        cond = np.empty(theta.shape[0])
        native_samples.solve_states(self.assemble_function, self.layout, theta, omega, _c(params), float(alpha),
                                    float(beta), x, cond)
        return x, cond

    def sample_matrices(self, theta, omega, params):
        """:meth:`matrices` for a run's samples (C-contiguous (K, n) states), by the samples' pass in IR."""
        k = self.n_unknowns
        A = np.empty((theta.shape[0], k, k))
        b = np.empty((theta.shape[0], k))
        native_samples.assemble_states(self.assemble_function, self.layout, theta, omega, _c(params), A, b)
        return A, b

    def matrices(self, theta, omega, params):
        """The numeric A (K, k, k) and b (K, k) at a batch of states (for condition numbers and teaching)."""
        from ..kernels import system  # noqa: PLC0415  (numba: only when a kernel runs)

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
        from ..kernels import system  # noqa: PLC0415  (numba: only when a kernel runs)

        theta = np.atleast_2d(_c(theta))
        M = np.empty((theta.shape[0], self.n, self.n))
        force = np.empty((theta.shape[0], self.n))
        system.lagrangian_states(self.mass_and_force_function, theta, np.atleast_2d(_c(omega)), _c(params),
                                 M, force)
        return M[0], force[0]

    # ---------------------------------------------------------------- integrators (physics.kernels)
    def integrate_rk45(self, y0, t0, t_end, t_eval, params, rtol, atol, alpha, beta, project, max_steps,
                       y_out, cond_out):
        return self._explicit_rk("RK45", "integrate_rk45", y0, t0, t_end, t_eval, params, rtol, atol,
                                 alpha, beta, project, max_steps, y_out, cond_out)

    def integrate_dop853(self, y0, t0, t_end, t_eval, params, rtol, atol, alpha, beta, project, max_steps,
                         y_out, cond_out):
        return self._explicit_rk("DOP853", "integrate_dop853", y0, t0, t_end, t_eval, params, rtol, atol,
                                 alpha, beta, project, max_steps, y_out, cond_out)

    def _explicit_rk(self, method, kernel_name, y0, t0, t_end, t_eval, params, rtol, atol, alpha, beta, project,
                     max_steps, y_out, cond_out):
        """RK45 or DOP853 by the drivers generated as LLVM IR (:mod:`physics.codegen.native_integrators`: the
        kernel's bits, without numba's compilation), or by the numba kernel ``kernel_name`` of
        :mod:`physics.kernels.explicit_rk` for a run they hand back (a per-sample condition; numba is imported
        only then)."""
        layout, y0, t_eval, params = self.integration_layout, _c(y0), _c(t_eval), _c(params)
        driver = (self.specialised_driver(method)
                  if native_integrators.answers(layout, alpha, beta, project, cond_out) else None)
        answer = native_integrators.integrate(method, self.assemble_function, layout, y0, t0, t_end, t_eval, params,
                                              rtol, atol, alpha, beta, project, max_steps, y_out, cond_out,
                                              driver=driver)
        if answer is not None:
            return answer
        from ..kernels import explicit_rk  # noqa: PLC0415  (numba: only for a run the IR drivers hand back)

        return getattr(explicit_rk, kernel_name)(self.assemble_function, layout, y0, t0, t_end, t_eval, params, rtol,
                                                 atol, alpha, beta, project, max_steps, y_out, cond_out)

    def specialised_driver(self, method: str, layout: np.ndarray | None = None, span: float | None = None):
        """``method``'s IR driver specialised for this system (:mod:`physics.codegen.specialised_ir`: the same
        bits, its sizes folded into the code; seed case C's RK45 integration in about 0.2 ms instead of 0.5), or
        None for the generic one. Its O2 compilation (0.3-1 s for three bars) is paid only where it pays: loaded
        when its machine code is in the cache already, else compiled from this system's second run of
        ``method`` in this process on (:meth:`_specialised`: a one-off run, the CLI's, compiles nothing).
        ``layout``: :attr:`integration_layout` (default) or one of its :meth:`weighted_layout` arrays (a maximal
        mechanism's projection weights: a driver of its own, the weights' offset folded in too), which is
        loaded when cached and otherwise compiled only for a run of ``span`` simulated seconds expected to be
        long enough to pay for it (:data:`SPECIALISE_WEIGHTED_RHS`, from :meth:`count_integration`'s figures)."""
        worth = None  # the second-run rule
        if layout is None or layout is self.integration_layout:
            layout, what = self.integration_layout, method
        else:
            if not self.is_own_integration_layout(layout):
                raise ValueError("layout: expected the system's integration_layout or one of its weighted_layout")
            what = f"{method} weights {int(layout[LAYOUT_WEIGHTS])}"
            rhs, seconds = self._functions.get(f"work {what}", (0, 0.0))
            worth = span is not None and seconds > 0 and rhs / seconds * span >= SPECIALISE_WEIGHTED_RHS
        return self._specialised(what, layout, lambda digest: native_integrators.specialised_driver(
            method, layout, self.assemble_function, digest), method, worth)

    def count_integration(self, method: str, layout: np.ndarray, n_rhs: int, span: float) -> None:
        """Add a run's right-hand sides and simulated seconds with ``method`` on a :meth:`weighted_layout` to
        this process's figures, from which :meth:`specialised_driver` judges whether a run will pay for its
        compilation (nothing is kept for the unweighted layout: its rule is the second run)."""
        if layout is self.integration_layout or not self.is_own_integration_layout(layout):
            return
        key = f"work {method} weights {int(layout[LAYOUT_WEIGHTS])}"
        with self._lock:
            rhs, seconds = self._functions.get(key, (0, 0.0))
            self._functions[key] = (rhs + int(n_rhs), seconds + abs(float(span)))

    def samples_solve(self):
        """The samples' ``solve_states`` and whole pass specialised for this system
        (:class:`~physics.codegen.native_samples.SpecialisedSamples`: the same bits, the solve about 0.02 ms
        instead of 0.05 for seed case C's 200 samples), by the rule of :meth:`specialised_driver`; None: the
        generic ones."""
        layout = self.layout
        return self._specialised(native_samples.samples_kind(self.has_sample), layout,
                                 lambda digest: native_samples.specialised_solve(
                                     layout, self.assemble_function, digest, self.sample_function))

    def _specialised(self, what: str, layout, make, method: str | None = None, worth: bool | None = None):
        """``make(digest)``'s function, kept with its engine as long as this system, or None (the caller takes
        the generic function) until it is there: loaded at the first call for ``what`` when its machine code is
        cached; else compiled (``worth`` None) from this system's second call in this process on, or (``worth``
        given) when the caller judges the run worth it, in a background thread
        (:data:`SPECIALISE_IN_BACKGROUND`), so that no run waits for its O2 compilation (0.3-1 s): the app's
        next chunks and an ensemble's next runs take the generic function meanwhile."""
        key = f"specialised {what}"
        with self._lock:
            if key in self._functions:
                return self._functions[key][0]
            calls = self._functions.setdefault("specialised calls", {})
            calls[what] = calls.get(what, 0) + 1
            if "system digest" not in self._functions:
                texts = (self.module.LLVM_IR, getattr(self.module, "LLVM_IR_RHS", ""),
                         getattr(self.module, "LLVM_IR_SAMPLE", ""))
                self._functions["system digest"] = hashlib.sha256("\0".join(texts).encode()).hexdigest()[:24]
            digest = self._functions["system digest"]
            building = self._functions.setdefault("specialised building", set())
            if what in building:
                return None
        cached = native_integrators.specialised_cached(what if method is None else method, layout, digest)
        if not cached and not (calls[what] >= 2 if worth is None else worth):
            return None

        def build() -> None:
            start = time.perf_counter()
            try:
                made = make(digest)
            finally:
                with self._lock:
                    building.discard(what)
            with self._lock:
                self.build_seconds += time.perf_counter() - start
                self._functions.setdefault(key, made)

        if cached or not SPECIALISE_IN_BACKGROUND:
            build()
            return self._functions[key][0]
        with self._lock:
            if what in building:
                return None
            building.add(what)
        # not a daemon: a process that ends meanwhile waits for it rather than tearing LLVM down under it
        threading.Thread(target=build, name=f"specialise {what}", daemon=False).start()
        return None

    def integrate_ode45(self, y0, t0, t_end, t_eval, params, rtol, atol, alpha, beta, project, max_steps,
                        y_out, cond_out):
        from ..kernels import ode45  # noqa: PLC0415  (compiled on first use only: few runs ask for it)

        return _first_call(ode45.integrate_ode45, "ode45", self.assemble_function, self.integration_layout, _c(y0), t0, t_end,
                           _c(t_eval), _c(params), rtol, atol, alpha, beta, project, max_steps, y_out, cond_out)

    def integrate_ode45_refined(self, y0, t0, t_end, params, rtol, atol, alpha=0.0, beta=0.0, project=True,
                                refine=4, max_steps=100_000):
        """MATLAB's ``ode45(f, [t0 t_end], y0)`` output: ``refine`` points per step (``Refine``, default 4).

        Returns ``(t, y, status, n_steps)``: the start and ``refine`` rows per accepted step."""
        from ..kernels import ode45  # noqa: PLC0415

        rows = ode45.refined_rows(max_steps, refine)
        t_out = np.empty(rows)
        y_out = np.empty((rows, len(y0)))
        status, n_steps, _, _, filled = ode45.integrate_ode45_refined(
            self.assemble_function, self.integration_layout, _c(y0), t0, t_end, _c(params), rtol, atol, alpha, beta, project,
            refine, t_out, y_out)
        return t_out[:filled], y_out[:filled], int(status), int(n_steps)

    def integrate_midpoint(self, y0, t0, t_end, h, t_eval, params, alpha, beta, project, y_out, cond_out):
        from ..kernels import midpoint  # noqa: PLC0415  (numba: only when a kernel runs)

        return _first_call(midpoint.integrate_midpoint, "midpoint", self.assemble_function, self.integration_layout, _c(y0), t0,
                           t_end, h, _c(t_eval), _c(params), alpha, beta, project, y_out, cond_out)

    def integrate_variational(self, y0, t0, t_end, h, t_eval, params, y_out, cond_out):
        from ..kernels import variational  # noqa: PLC0415  (numba: only when a kernel runs)

        return _first_call(
            variational.integrate_variational, "variational", self.assemble_function, self.mass_and_force_function,
            self.integration_layout, _c(y0), t0, t_end, h, _c(t_eval), _c(params), y_out, cond_out,
        )

    def rk4_batch_step(self, theta, omega, params, h, alpha, beta, work, cond_out):
        from ..kernels import batch  # noqa: PLC0415  (numba: only when a kernel runs)

        return _first_call(batch.rk4_batch_step, "RK4 ensemble", self.assemble_function, self.integration_layout, theta, omega,
                           _c(params), h, alpha, beta, work, cond_out)

    @property
    def pose_size(self) -> int:
        """3 B for tree coordinates (the generated ``kinematics`` gives every body's pose), 0 otherwise."""
        return int(getattr(self.module, "POSE_SIZE", 0))

    @property
    def pose_vector_size(self) -> int:
        """The length of the generated ``kinematics``' vector: every body's pose, the bias, then the cosine and
        the sine of every body's angle (3 B, 3 B, B, B); 0 without tree coordinates."""
        return self.pose_size * 2 + (self.pose_size // 3) * 2

    @property
    def time_slot(self) -> int:
        """The parameter vector's entry that holds the time (a speed motor's system), -1 when nothing reads it."""
        return int(getattr(self.module, "TIME_INDEX", -1))

    @property
    def pose_angle_index(self) -> np.ndarray:
        """The coordinate that each body's angle is in the generated kinematics (-1: a sum of coordinates)."""
        return np.array(getattr(self.module, "POSE_ANGLE_INDEX", ()), dtype=np.int64)

    @property
    def constraint_count(self) -> int:
        return len(self.module.CONSTRAINT_ROWS)

    @property
    def multiplier_index(self) -> np.ndarray:
        return np.array(self.module.MULTIPLIER_INDEX, dtype=np.int64)

    def constraint_states(self, t, theta, omega, params) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The held constraints at states (K, n) and times (K,): ``J`` (K, r, n), ``phi`` (K, r), ``phi_dot`` (K, r)
        (the loop of :func:`physics.kernels.system.native_states` generated as IR: its bits, no numba)."""
        theta = np.atleast_2d(_c(theta))
        r = self.constraint_count
        matrix = np.zeros((theta.shape[0], r, theta.shape[1]))
        vector = np.zeros((theta.shape[0], 2 * r))
        if r:
            native_states.native_states(self._native("constraints"), self.layout,
                                        _c(np.broadcast_to(t, theta.shape[:1])), theta, np.atleast_2d(_c(omega)),
                                        _c(params), matrix, vector)
        return matrix, vector[:, :r], vector[:, r:]

    def kinematics_states(self, theta, omega, params) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Tree coordinates' kinematics at states (K, n): ``d pose/d theta`` (K, 3B, n), ``pose`` (K, 3B) and the
        bias (K, 3B) with ``qddot = J theta_ddot + bias`` (as :meth:`constraint_states`, by IR)."""
        theta = np.atleast_2d(_c(theta))
        size = self.pose_size
        matrix = np.zeros((theta.shape[0], size, theta.shape[1]))
        vector = np.zeros((theta.shape[0], self.pose_vector_size))
        native_states.native_states(self._native("kinematics"), self.layout, np.zeros(theta.shape[0]), theta,
                                    np.atleast_2d(_c(omega)), _c(params), matrix, vector)
        return matrix, vector[:, :size], vector[:, size:2 * size]

    def project(self, theta, omega, params, t=0.0) -> float:
        """Project ``theta``, ``omega`` (n,) in place onto the held constraints (positions, then velocities) at
        time ``t``; returns the position residual left (0 when nothing is held). The kernels' projection generated
        as IR (:mod:`physics.codegen.native_states`): their bits, no numba."""
        theta_rows = np.ascontiguousarray(theta, dtype=np.float64).reshape(1, -1)
        omega_rows = np.ascontiguousarray(omega, dtype=np.float64).reshape(1, -1)
        residual = native_states.project_states(self.layout, np.array([float(t)]), theta_rows, omega_rows,
                                                _c(params))
        theta[...] = theta_rows[0]
        omega[...] = omega_rows[0]
        return float(residual)


_loaded: dict = {}
# (formulation, n, pinned) -> the system _loaded holds under its key
_chain_systems: dict[tuple[str, int, bool], CompiledSystem] = {}
_lock = threading.Lock()


def _key(formulation: str, n: int, pinned: bool) -> str:
    return f"{formulation}-n{n}-{'pinned' if pinned else 'open'}"


def _trusted_source(path: Path) -> tuple[bytes | None, str | None]:
    """The file's bytes if it is this user's, private and its MAC line matches; else None and why (None, None
    when there is no file)."""
    try:
        data = read_trusted(path)
    except FileNotFoundError:
        return None, None
    except UntrustedFile as error:
        return None, str(error)
    body, sep, last = data.rstrip(b"\n").rpartition(b"\n")
    if not sep or not last.startswith(_MAC_PREFIX):
        return None, "no MAC line"
    if not mac_matches(path.name, body, last[len(_MAC_PREFIX) :].strip()):
        return None, "MAC differs: changed, or not written by this user's Linkage Lab"
    return data, None


def _write_atomically(path: Path, text: str) -> None:
    write_atomically(path, text, mode=0o600)


def _chain_system(formulation: str, n: int, pinned: bool):
    """A chain's derivation and its description for the generated file's header."""
    # sympy boundary: the derivations import sympy, so they are loaded only on a cache miss.
    from ..derive import FORMULATIONS  # noqa: PLC0415

    return FORMULATIONS[formulation]().derive(n, pinned), f"n = {n}, {'tip pinned' if pinned else 'open chain'}"


def _build_source(derive, formulation: str, digest: str, name: str) -> str:
    """The generated module's text, ending in its MAC line (``name``: the file name the MAC binds it to);
    ``derive()`` returns the symbolic system and a few words saying what it is."""
    from .emit import emit_module  # noqa: PLC0415  (imports sympy: only on a cache miss)

    system, what = derive()
    header = (
        f'"""Generated by Linkage Lab from the {formulation} derivation: {what}.\n\n'
        f"Unknowns x = {[str(u) for u in system.unknowns]}.\n"
        f"Generator digest {digest}. Do not edit: the file is authenticated and rebuilt when in doubt.\n"
        '"""'
    )
    body = emit_module(system, header).rstrip("\n")
    return body + "\n" + _MAC_PREFIX.decode() + mac(name, body.encode()) + "\n"


def _remove_stale(folder: Path, key: str, current: Path) -> None:
    """Entries of the same mechanism from another generator version."""
    for stale in folder.glob(f"{key}-*.py"):
        if stale != current:
            try:
                stale.unlink()
            except OSError:
                pass


def _execute(source: bytes, path: Path, name: str):
    """A fresh module run from ``source``: the bytes whose MAC was just checked (or that this process just
    generated), never a file read again or a ``__pycache__`` entry beside it."""
    code = compile(source, str(path), "exec", dont_inherit=True)
    module = types.ModuleType(name)
    module.__file__ = str(path)
    sys.modules[name] = module  # where a traceback or a debugger looks for it
    try:
        exec(code, module.__dict__)  # our own derivation's output, authenticated by its MAC: never user input
    except BaseException:
        sys.modules.pop(name, None)
        raise
    return module


_bytecode_checked: set[Path] = set()


def _remove_bytecode(folder: Path) -> None:
    """Remove ``__pycache__`` that an earlier version (which imported the generated files) left in the cache: it
    is never read now, but a stale copy of generated code has no business there."""
    if folder not in _bytecode_checked:
        _bytecode_checked.add(folder)
        pycache = folder / "__pycache__"
        if pycache.exists() or pycache.is_symlink():
            discard(pycache)


def _generate(path: Path, derive, formulation: str, digest: str) -> bytes:
    """Derive, write (atomically, 0600) and return the generated module's bytes."""
    text = _build_source(derive, formulation, digest, path.name)
    _write_atomically(path, text)
    return text.encode()


def load_compiled(formulation: str, n: int, pinned: bool = False) -> CompiledSystem:
    """Ready numeric functions for a chain's formulation; derived and generated only when the cache lacks them."""
    if type(n) is int and type(pinned) is bool:  # every run asks: a loaded chain system in one look-up
        found = _chain_systems.get((formulation, n, pinned))
        if found is not None:
            return found
    if formulation not in FORMULATION_NAMES:
        raise LinkageError(f"method = {formulation!r}: allowed {', '.join(FORMULATION_NAMES)}")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= int(n) <= MAX_LINKS:
        raise LinkageError(f"links = {n!r}: allowed an integer 1 <= links <= {MAX_LINKS}")
    key = _key(formulation, int(n), bool(pinned))
    system = _load(key, formulation, int(n), bool(pinned), lambda: _chain_system(formulation, int(n), bool(pinned)))
    with _lock:
        if _loaded.get(key) is system:  # (not cleared meanwhile)
            _chain_systems[(formulation, int(n), bool(pinned))] = system
    return system


def load_generated(key: str, formulation: str, derive) -> CompiledSystem:
    """Ready numeric functions for any generated system (a mechanism of one structure), cached under ``key``
    (letters, digits and dashes); ``derive()`` returns ``(LinearSystem, description)`` on a cache miss."""
    return _load(key, formulation, -1, False, derive)


def _load(key: str, formulation: str, n: int, pinned: bool, derive) -> CompiledSystem:
    """The loaded system of ``key``; ``n < 0``: read the number of coordinates from the generated module."""
    with _lock:
        if key in _loaded:
            return _loaded[key]
        start = time.perf_counter()
        folder = cache_dir()
        _remove_bytecode(folder)
        digest = generator_digest()
        path = folder / f"{key}-{digest}.py"
        source, problem = _trusted_source(path)
        from_cache = source is not None
        if problem is not None:
            warn(f"generated file {path} is not trusted ({problem}); discarded and rebuilt")
            discard(path)
        if source is None:
            source = _generate(path, derive, formulation, digest)
            _remove_stale(folder, key, path)
        module_name = f"linkage_lab_generated_{key.replace('-', '_')}_{digest}"
        try:
            module = _execute(source, path, module_name)
        except Exception:  # a file that passed its MAC but does not run: rebuild once
            warn(f"generated file {path} did not import; rebuilding it")
            module = _execute(_generate(path, derive, formulation, digest), path, module_name)
            from_cache = False
        compiled = CompiledSystem(
            formulation=formulation,
            n=n if n >= 0 else int(module.N_LINKS),
            pinned=pinned,
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
        _chain_systems.clear()


def is_generated(formulation: str, n: int, pinned: bool = False) -> bool:
    """True if this chain's generated file is in the cache and intact: loading it needs no sympy.

    The app asks before a build, to run the derivation in a worker process (:mod:`physics.codegen.prebuild`)
    rather than in the server's interpreter."""
    return is_generated_key(_key(formulation, int(n), bool(pinned)))


def is_generated_key(key: str) -> bool:
    """True if the generated system cached under ``key`` is loaded or its file is intact (no sympy needed)."""
    with _lock:
        if key in _loaded:
            return True
    path = cache_dir() / f"{key}-{generator_digest()}.py"
    return _trusted_source(path)[0] is not None
