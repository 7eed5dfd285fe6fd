"""How numba starts in a command-line process: without the BLAS probe its CPU target runs.

When numba's CPU target starts it imports scipy.linalg (a quarter of a second) only to offer BLAS to ``np.dot``
and ``np.linalg`` in compiled code, which Linkage Lab's kernels never call. A command-line process is ours
alone, so :func:`start_without_blas` asks for numba's array support to be started with that probe answered
"no" (numba then compiles ``np.dot`` as unsupported in this process). scipy itself imports normally afterwards
(the reduced model, ``--backend scipy``, the equilibrium solver).

numba itself is imported only when a run reaches a numba kernel (:mod:`physics.kernels.disk_cache` is the first
thing every kernel module imports, and it calls :func:`on_numba_import`), so this module imports no numba: a
run that the LLVM IR answers never pays for it.
"""

from __future__ import annotations

import sys

_wanted: list[bool] = []


class _NoScipyLinalg:
    """An import hook that answers "not installed" for scipy while it is in ``sys.meta_path``."""

    def find_spec(self, name, path=None, target=None):
        if name in ("scipy", "scipy.linalg"):
            raise ImportError("scipy.linalg is not needed by numba's kernels here")
        return None


def _start() -> None:
    if "numba.np.arraymath" in sys.modules or "scipy.linalg" in sys.modules:
        return
    hook = _NoScipyLinalg()
    sys.meta_path.insert(0, hook)
    try:
        # Must run here, with the hook in place: this import is the point of the function.
        import numba.np.arraymath  # noqa: F401, PLC0415  (runs numba's BLAS probe now)
    finally:
        sys.meta_path.remove(hook)


def start_without_blas() -> None:
    """This process starts numba without its BLAS probe: at once if numba is loaded already, else when a
    kernel first imports it (:func:`on_numba_import`)."""
    if not _wanted:
        _wanted.append(True)
    if "numba" in sys.modules:
        _start()


def on_numba_import() -> None:
    """Called by :mod:`physics.kernels.disk_cache` right after it imports numba, before any kernel exists."""
    if _wanted:
        _start()
