"""How numpy starts in a command-line process: with one BLAS thread, not a pool that only spins.

numpy's OpenBLAS starts its worker threads when numpy is imported, one for every core beyond the first, and a
new worker spins waiting for work before it goes to sleep. The command line's linear algebra is on matrices of a
few rows (a chain's mass matrix, a loop's assembly, scipy's Radau on a few coordinates), far below the sizes
where OpenBLAS hands work to a second thread, so in a ``python -m physics`` process that pool is pure cost:
about 0.05 s of CPU of a warm 0.4 s ``simulate`` (BENCHMARKS.md, "Warm start: one BLAS thread"), taken from a
core that a busy machine's other processes want.

So when this process is the command line (``python -m physics`` or the ``linkage-physics`` script) and the user
has not chosen a thread count (``OPENBLAS_NUM_THREADS``, ``GOTO_NUM_THREADS`` or ``OMP_NUM_THREADS``), numpy is
loaded here with ``OPENBLAS_NUM_THREADS=1``, and the variable is removed again at once: OpenBLAS reads it only
when it loads, so the processes a command starts see the environment as it was. The results are the same bits
(one thread computes what the pool would for these sizes). A library user's process (``import physics`` in a
notebook or a script, the app, the tests) is left as it is. Must be imported before anything imports numpy:
``physics/__init__.py`` imports it first.
"""

from __future__ import annotations

import os
import sys

from .program import program_name

CONSOLE_SCRIPT = "linkage-physics"  # [project.scripts] in pyproject.toml (physics.cli.CONSOLE_SCRIPT)
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")


def _module_run(arguments: list[str]) -> str | None:
    """The module a ``python ... -m MODULE`` command line runs (None when it runs none)."""
    for position, item in enumerate(arguments[1:], start=1):
        if item == "-m":
            return arguments[position + 1] if position + 1 < len(arguments) else None
        if item.startswith("-m") and not item.startswith("--"):
            return item[2:]
    return None


def command_line_process() -> bool:
    """Whether this process is Linkage Lab's command line: ``python -m physics`` while it is still importing
    the package (``sys.argv[0]`` is ``-m`` until the interpreter has found ``__main__``), or the console
    script."""
    if sys.argv[:1] == ["-m"]:
        return _module_run(list(getattr(sys, "orig_argv", []))) == "physics"
    return bool(sys.argv) and program_name(CONSOLE_SCRIPT, "") == CONSOLE_SCRIPT


def start_numpy() -> None:
    """Import numpy, with one BLAS thread when this is the command-line process and the user set no count."""
    if "numpy" in sys.modules or not command_line_process() or any(name in os.environ for name in THREAD_VARIABLES):
        import numpy  # noqa: F401, PLC0415  (as any process loads it)

        return
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
    try:
        import numpy  # noqa: F401, PLC0415  (OpenBLAS reads the variable now, once)
    finally:
        os.environ.pop("OPENBLAS_NUM_THREADS", None)


start_numpy()
