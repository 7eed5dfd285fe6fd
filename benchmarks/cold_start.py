"""Cold and warm starts, whole processes, measured side by side in one run (the figures of the "Compile once"
section of BENCHMARKS.md).

    python -m benchmarks.cold_start [--links 3 10] [--before /path/to/an/older/checkout] [--warm-runs 5]

For each chain length and formulation, in a rotating order within each round:

* ``cold``: ``python -m physics simulate --preset chain --links N --t-end 10 --method M`` with a cache that holds
  the once-compiled integration kernels but no mechanism (what a user meets after the first run ever, or after
  ``python -m physics warm`` in the Docker image): derive, generate, compile the mechanism, integrate;
* ``empty``: the same with an empty cache folder (the kernels are compiled too: the first run of an installation);
* ``before``: the same command in an older checkout (``--before``), empty cache: how it was;
* ``pydy``: PyDy's Kane's method + lambdify + solve_ivp for the same chain (benchmarks/pydy_anchor.py), if pydy is
  installed (``pip install -e '.[bench]'``).

Then ``warm``: ``python -m physics simulate --preset triple-a`` with everything cached, median of ``--warm-runs``
(alternating with the ``--before`` tree).
Prints one JSON object; every figure is a whole-process wall time in seconds, interpreter start included.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
FORMULATIONS = ("newton_euler", "lagrange", "dae")
T_END = 10.0
TIMEOUT_S = 900.0


def _command(n: int, method: str) -> list[str]:
    return [sys.executable, "-m", "physics", "simulate", "--preset", "chain", "--links", str(n), "--t-end",
            str(T_END), "--method", method, "--out", os.devnull]


def _timed(command: list[str], cache: Path, cwd: Path) -> float:
    env = dict(os.environ, LINKAGE_LAB_CACHE=str(cache), PYTHONPATH=str(cwd))
    env.pop("NUMBA_CACHE_DIR", None)
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # as an installation runs: the modules' bytecode is cached
    start = time.perf_counter()
    result = subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True, timeout=TIMEOUT_S)
    elapsed = time.perf_counter() - start
    if result.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} failed in {cwd}: {result.stderr.strip()[-500:]}")
    return elapsed


def _kernels_only(scratch: Path) -> Path:
    """A cache folder holding the compiled kernels and no mechanism (a one-bar run compiles them)."""
    folder = scratch / "kernels-only"
    _timed(_command(1, "lagrange"), folder, REPO_ROOT)
    for path in folder.glob("*.py"):
        path.unlink()
    shutil.rmtree(folder / "numba" / "generated", ignore_errors=True)
    return folder


def _pydy(n: int) -> float | None:
    try:
        from . import pydy_anchor
    except ImportError:
        return None
    if not pydy_anchor.pydy_available():
        return None
    row = pydy_anchor.time_cold(n, T_END, TIMEOUT_S)
    return float(row["process_wall_s"]) if "process_wall_s" in row else None


def measure(links: list[int], before: Path | None, warm_runs: int) -> dict:
    scratch = Path(tempfile.mkdtemp(prefix="linkage-lab-cold-"))
    try:
        template = _kernels_only(scratch)
        rows = []
        for n in links:  # --links with no value: the warm figures alone
            for round_index, method in enumerate(FORMULATIONS):
                row: dict = {"links": n, "method": method}
                kinds = ["cold", "empty", "before", "pydy"]
                kinds = kinds[round_index % len(kinds):] + kinds[: round_index % len(kinds)]  # rotate the order
                for kind in kinds:
                    folder = scratch / f"{kind}-{n}-{method}"
                    if kind == "cold":
                        shutil.copytree(template, folder)
                        row["cold_s"] = _timed(_command(n, method), folder, REPO_ROOT)
                    elif kind == "empty":
                        row["empty_s"] = _timed(_command(n, method), folder, REPO_ROOT)
                    elif kind == "before" and before is not None:
                        row["before_s"] = _timed(_command(n, method), folder, before)
                    elif kind == "pydy" and method == "lagrange":
                        row["pydy_s"] = _pydy(n)  # one chain, one peer: measured beside the Lagrange row
                rows.append(row)
                print(json.dumps(row), file=sys.stderr, flush=True)
        warm_folder = scratch / "warm"
        shutil.copytree(template, warm_folder)
        command = [sys.executable, "-m", "physics", "simulate", "--preset", "triple-a", "--out", os.devnull]
        _timed(command, warm_folder, REPO_ROOT)  # fills the cache for this mechanism
        warm, warm_before = [], []
        before_folder = scratch / "warm-before"
        if before is not None:
            _timed(command, before_folder, before)
        for _ in range(warm_runs):  # interleaved, so both see the same machine
            warm.append(_timed(command, warm_folder, REPO_ROOT))
            if before is not None:
                warm_before.append(_timed(command, before_folder, before))
        return {
            "command": "python -m benchmarks.cold_start " + " ".join(sys.argv[1:]),
            "load_average": os.getloadavg(),
            "cpus": os.cpu_count(),
            "t_end": T_END,
            "rows": rows,
            "warm_triple_a_s": {"median": statistics.median(warm), "all": warm},
            "warm_triple_a_before_s": {"median": statistics.median(warm_before), "all": warm_before}
            if warm_before else None,
        }
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.cold_start", description=__doc__.split("\n\n")[0])
    parser.add_argument("--links", type=int, nargs="*", default=[3, 10],
                        help="chain lengths (1..12); none at all: only the warm figures")
    parser.add_argument("--before", type=Path, default=None, help="an older checkout to time the same way")
    parser.add_argument("--warm-runs", type=int, default=5)
    args = parser.parse_args(argv)
    print(json.dumps(measure(args.links, args.before, args.warm_runs), indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
