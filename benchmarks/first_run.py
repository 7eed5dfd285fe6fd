"""An installation's first run, whole processes, this tree against an older one side by side (the "First run"
section of BENCHMARKS.md).

    python -m benchmarks.first_run --before /path/to/an/older/checkout [--rounds 3] [--warm-runs 3] [--chain-rounds N]

Each round takes both trees in turn (the order alternates between rounds, so both meet the same machine) and,
for each, with a fresh empty ``LINKAGE_LAB_CACHE``:

* ``triple_a``: ``python -m physics simulate --preset triple-a`` (what a newcomer types first);
* ``warm``: the same command again ``--warm-runs`` times in the cache the first one filled (median);
* ``chain_<method>``: ``python -m physics simulate --preset chain --links 10 --method <method>``, each formulation
  in its own empty cache;
* ``app``: ``python -m app --port 0`` until a websocket client (app/wsclient.py, the browser's protocol) receives
  the mechanism's first drawing, and then its first simulated pose (``app.bench.measure_start(cold=True)``, run in
  the tree measured).

Every figure is wall seconds, interpreter start included; the CPU seconds of the child (user + system) are kept
beside it, as the machine is shared. Each row is printed on stderr as it is measured (a partial run still
counts), then one JSON object with every row and the medians per tree.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
FORMULATIONS = ("newton_euler", "lagrange", "dae")  # "reduced" is for a four-bar only
TIMEOUT_S = 900.0


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _timed(command: list[str], cache: Path, tree: Path) -> tuple[float, float]:
    """Wall and CPU seconds of ``command`` run in ``tree`` with ``cache`` as the cache folder."""
    env = dict(os.environ, LINKAGE_LAB_CACHE=str(cache), PYTHONPATH=str(tree))
    env.pop("NUMBA_CACHE_DIR", None)
    cpu = _children_cpu()
    start = time.perf_counter()
    result = subprocess.run(command, cwd=tree, env=env, capture_output=True, text=True, timeout=TIMEOUT_S)
    elapsed = time.perf_counter() - start
    if result.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} failed in {tree}: {result.stderr.strip()[-500:]}")
    return elapsed, _children_cpu() - cpu


def _simulate(*arguments: str) -> list[str]:
    return [sys.executable, "-m", "physics", "simulate", *arguments, "--out", os.devnull]


def _app_start(tree: Path) -> dict:
    """Seconds from launching the app with an empty cache to the first drawing of the mechanism at a websocket
    client (``start_pose_s``, the first frame) and to its first simulated pose (``first_pose_s``)."""
    code = "import json; from app.bench import measure_start; print(json.dumps(measure_start(cold=True)))"
    env = dict(os.environ, PYTHONPATH=str(tree))
    result = subprocess.run([sys.executable, "-c", code], cwd=tree, env=env, capture_output=True, text=True,
                            timeout=TIMEOUT_S)
    if result.returncode != 0:
        raise RuntimeError(f"app start failed in {tree}: {result.stderr.strip()[-500:]}")
    figures = json.loads(result.stdout.strip().splitlines()[-1])
    return {"app_first_frame_s": figures.get("start_pose_s"), "app_first_pose_s": figures.get("first_pose_s")}


def _recorded(row: dict, what: str, measurement) -> None:
    """``row.update(measurement())``; a failure (a timeout on a loaded machine) is kept in the row, not fatal."""
    try:
        row.update(measurement())
    except (RuntimeError, subprocess.TimeoutExpired, OSError, ValueError) as error:
        row.setdefault("errors", []).append(f"{what}: {' '.join(str(error).split())[-300:]}")


def measure_tree(tree: Path, scratch: Path, warm_runs: int, with_app: bool, with_chains: bool) -> dict:
    row: dict = {}
    cache = scratch / "triple-a"

    def triple_a() -> dict:
        wall, cpu = _timed(_simulate("--preset", "triple-a"), cache, tree)
        return {"triple_a_s": wall, "triple_a_cpu_s": cpu}

    def warm() -> dict:
        return {"warm_s": statistics.median(_timed(_simulate("--preset", "triple-a"), cache, tree)[0]
                                            for _ in range(warm_runs))}

    def chain(method: str):
        def measurement() -> dict:
            wall, cpu = _timed(_simulate("--preset", "chain", "--links", "10", "--method", method),
                               scratch / f"chain-{method}", tree)
            return {f"chain_{method}_s": wall, f"chain_{method}_cpu_s": cpu}
        return measurement

    _recorded(row, "triple-a", triple_a)
    _recorded(row, "warm", warm)
    for method in FORMULATIONS if with_chains else ():
        _recorded(row, f"chain {method}", chain(method))
    if with_app:
        _recorded(row, "app", lambda: _app_start(tree))
    return row


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.first_run", description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", type=Path, required=True, help="an older checkout to time the same way")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--warm-runs", type=int, default=3)
    parser.add_argument("--chain-rounds", type=int, default=None,
                        help="measure the chains in the first N rounds only (default: every round)")
    parser.add_argument("--no-app", action="store_true", help="leave out the app's first pose")
    args = parser.parse_args(argv)
    trees = {"after": REPO_ROOT, "before": args.before.resolve()}
    rows: list[dict] = []
    for round_index in range(args.rounds):
        order = ["after", "before"] if round_index % 2 == 0 else ["before", "after"]
        for name in order:
            scratch = Path(tempfile.mkdtemp(prefix="linkage-lab-first-"))
            try:
                row = {"tree": name, "round": round_index, "load_average": os.getloadavg()[0]}
                chains = args.chain_rounds is None or round_index < args.chain_rounds
                row.update(measure_tree(trees[name], scratch, args.warm_runs, not args.no_app, chains))
            finally:
                shutil.rmtree(scratch, ignore_errors=True)
            rows.append(row)
            print(json.dumps(row), file=sys.stderr, flush=True)
    medians = {}
    for name in trees:
        mine = [row for row in rows if row["tree"] == name]
        keys = sorted({key for row in mine for key in row if key.endswith("_s")})
        medians[name] = {key: statistics.median(values) if (values := [row[key] for row in mine
                                                                        if row.get(key) is not None]) else None
                         for key in keys}
    print(json.dumps({"command": "python -m benchmarks.first_run " + " ".join(sys.argv[1:]), "cpus": os.cpu_count(),
                      "rows": rows, "medians": medians}, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
