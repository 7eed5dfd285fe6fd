"""Figures for BENCHMARKS.md, issue "One pipeline": a general mechanism on the chains' compiled engine, side by
side with another tree (``--before``, a ``git worktree`` of the commit before the work), alternated in one run.

    git worktree add ../before 0a304c0
    python -m benchmarks.one_pipeline --before ../before [--repeat 3] [--skip-slow-before]

Each figure is the median CPU time (user + system: on a shared machine the wall time is mostly waiting for a
core) of ``--repeat`` whole processes (``python -m physics ...`` started in the tree's
folder, so it imports that tree's code; each tree has a cache folder of its own, ``one-pipeline-after`` and
``one-pipeline-before`` under ``LINKAGE_LAB_CACHE`` or a new temporary folder: a generated system's name
carries its generator's digest and a tree removes another digest's file of the same structure as stale, so a
shared folder made each tree rebuild the other's systems at every switch):

* ``triple-a chain``: ``simulate --preset triple-a --method dae --integrator DOP853 --rtol 1e-10 --atol 1e-10
  --t-end 2000 --samples 2001``;
* ``triple pendulum as a mechanism``: ``mechanism --file docs/examples/triple-pendulum.json --method dae
  --t-end 2000 --samples 2001`` (three bodies, three pins; the mechanism command integrates DOP853 at 1e-10),
  in each tree that runs it (an older tree refuses it: its estimate is hours), and for 20 s (21 samples) in
  both; the ratio to the chain preset's time is printed per tree;
* ``edit``: in one process, after a first run of the slider-crank, a run of one 0.25 s chunk (16 samples) with
  its crank's mass, g and motor speed changed: what a slider's edit costs the server before its first frame;
* ``cold Jansen leg``: ``mechanism --preset jansen-leg --t-end 10`` with the mechanism's generated files
  removed from the cache first (the integrators stay compiled): a new structure's first run.

``--skip-slow-before`` runs the before tree's mechanism file once instead of ``--repeat`` times (about 20 s).
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TRIPLE_FILE = ROOT / "docs" / "examples" / "triple-pendulum.json"

EDIT_SCRIPT = r"""
import time
from physics.mechanism import MECHANISM_PRESETS
from physics.mechanism.description import Mechanism
from physics.mechanism.simulate import simulate_mechanism
base = MECHANISM_PRESETS["slider-crank"]()
simulate_mechanism(base, 0.25, 16)
walls = []
for k in range(5):
    data = base.model_dump()
    data["bodies"][0]["mass"] = data["bodies"][0]["mass"] * (1.1 + 0.1 * k)
    data["g"] = 9.81 + k
    for driver in data["drivers"]:
        if driver.get("speed") is not None:
            driver["speed"] = driver["speed"] * (1.05 + 0.05 * k)
    edited = Mechanism.model_validate(data)
    started = time.process_time()
    simulate_mechanism(edited, 0.25, 16)
    walls.append(time.process_time() - started)
walls.sort()
print(walls[len(walls) // 2])
"""


# each tree's processes get a cache folder of their own (TREE_CACHES, set by main): a generated system's file
# name carries the digest of its generator's sources, and a tree that finds another digest's file for the same
# structure removes it as stale, so two trees sharing one folder rebuilt each other's systems at every switch
TREE_CACHES: dict[Path, Path] = {}


def _env(tree: Path) -> dict:
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # as an installation runs: the modules' bytecode is cached
    env.pop("PYTHONPATH", None)  # each tree imports its own code (the command runs in its folder)
    if tree in TREE_CACHES:
        env["LINKAGE_LAB_CACHE"] = str(TREE_CACHES[tree])
    return env


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _whole(tree: Path, argv: list[str]) -> float:
    """The CPU seconds (user + system) of one whole process: on a shared, loaded machine the wall time is mostly
    waiting for a core, the CPU time is the work."""
    started = _children_cpu()
    done = subprocess.run([sys.executable, *argv], cwd=tree, env=_env(tree), stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{tree}: {' '.join(argv)} failed: {done.stderr.strip()[-500:]}")
    return _children_cpu() - started


def _refuses(tree: Path, argv: list[str]) -> str | None:
    """What ``tree`` says when it refuses ``argv`` (an older tree refuses the file's 2000 s run: its estimate
    from the first simulated seconds is hours), or None when it runs it. The probe is the whole command, so a
    tree that runs it has had its warm-up run too."""
    done = subprocess.run([sys.executable, *argv], cwd=tree, env=_env(tree), stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, text=True)
    return None if done.returncode == 0 else done.stderr.strip()[-300:]


def _cache_folder(tree: Path) -> Path:
    out = subprocess.run([sys.executable, "-c", "from physics.cache_folder import cache_dir; print(cache_dir())"],
                         cwd=tree, env=_env(tree), check=True, capture_output=True, text=True)
    return Path(out.stdout.strip().splitlines()[-1])


def _structure(tree: Path, preset: str) -> str:
    """The structure digest that names a mechanism preset's generated systems in ``tree``'s cache folder."""
    out = subprocess.run([sys.executable, "-c", "from physics.mechanism import MECHANISM_PRESETS; "
                          "from physics.mechanism.parameters import structure_key; "
                          f"print(structure_key(MECHANISM_PRESETS[{preset!r}]()))"],
                         cwd=tree, env=_env(tree), check=True, capture_output=True, text=True)
    return out.stdout.strip().splitlines()[-1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.one_pipeline")
    parser.add_argument("--before", type=Path, required=True, help="a worktree of the commit before the work")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--skip-slow-before", action="store_true")
    args = parser.parse_args(argv)
    trees = {"after": ROOT, "before": args.before.resolve()}
    base = Path(os.environ.get("LINKAGE_LAB_CACHE") or tempfile.mkdtemp(prefix="one-pipeline-"))
    for label, tree in trees.items():
        TREE_CACHES[tree] = base / f"one-pipeline-{label}"
    out = Path(os.environ.get("TMPDIR", "/tmp"))
    chain = ["-m", "physics", "simulate", "--preset", "triple-a", "--method", "dae", "--integrator", "DOP853",
             "--rtol", "1e-10", "--atol", "1e-10", "--t-end", "2000", "--samples", "2001", "--out",
             str(out / "one-pipeline-chain.csv")]
    mechanism = ["-m", "physics", "mechanism", "--file", str(TRIPLE_FILE), "--method", "dae", "--t-end", "2000",
                 "--samples", "2001", "--out", str(out / "one-pipeline-mechanism.csv")]
    # the tree before refuses the mechanism file for 2000 s (its estimate: hours), so both trees run it for 20 s
    short = [*mechanism[:-6], "--t-end", "20", "--samples", "21", "--out", str(out / "one-pipeline-short.csv")]
    jansen = ["-m", "physics", "mechanism", "--preset", "jansen-leg", "--t-end", "10"]
    print(f"load average at start: {os.getloadavg()[0]:.1f}", flush=True)
    long_file = {}
    for label, tree in trees.items():  # compile and cache what every figure but the cold one reuses
        _whole(tree, [*chain[:-6], "--t-end", "1", "--samples", "2"])
        _whole(tree, [*mechanism[:-6], "--t-end", "1", "--samples", "2"])
        # then whole runs (segmented: a system's second call in a process makes its specialised driver, cached
        # for the timed processes as for an installation's later runs); an older tree refuses the file's 2000 s
        # run (its estimate is hours): then it is not timed there
        _whole(tree, chain)
        # asked twice: the first probe of a new cache can still meet one-time work (its estimate then too long)
        refusal = _refuses(tree, mechanism) and _refuses(tree, mechanism)
        if refusal:
            print(f"{label} refuses the file's 2000 s run: {refusal}", flush=True)
        long_file[label] = not refusal
    figures: dict[tuple[str, str], list[float]] = {}
    for round_ in range(args.repeat):
        # the trees' order alternates between rounds, so both meet the same machine
        for label, tree in (list(trees.items()) if round_ % 2 == 0 else list(trees.items())[::-1]):
            figures.setdefault(("triple-a chain, 2000 s", label), []).append(_whole(tree, chain))
            if long_file[label]:
                figures.setdefault(("triple pendulum as a mechanism, 2000 s", label), []).append(
                    _whole(tree, mechanism))
            slow = label == "before" and args.skip_slow_before and figures.get(("mechanism", label))
            if not slow:
                figures.setdefault(("triple pendulum as a mechanism, 20 s", label), []).append(_whole(tree, short))
                figures.setdefault(("mechanism", label), []).append(1.0)
            edit = subprocess.run([sys.executable, "-c", EDIT_SCRIPT], cwd=tree, env=_env(tree), check=True,
                                  capture_output=True,
                                  text=True)
            figures.setdefault(("edit of the slider-crank, one chunk", label), []).append(
                float(edit.stdout.strip().splitlines()[-1]))
            # the leg's own generated systems only: a chain's run on the mechanism engine keeps its tree systems
            # under the same word (``treedae-mechanism-...``), and deleting them would time a cold chain next
            for generated in _cache_folder(tree).glob(f"*mechanism*{_structure(tree, 'jansen-leg')}*.py"):
                generated.unlink()
            figures.setdefault(("cold Jansen leg, 10 s", label), []).append(_whole(tree, jansen))
    print(f"load average after the rounds: {os.getloadavg()[0]:.1f}; every figure (CPU s): "
          + "; ".join(f"{name} {label}: {', '.join(f'{v:.3f}' for v in values)}"
                      for (name, label), values in figures.items() if name != "mechanism"), flush=True)
    print("| figure (CPU seconds, median) | before | after | before / after |")
    print("|---|---|---|---|")
    for name in dict.fromkeys(key[0] for key in figures if key[0] != "mechanism"):
        after = statistics.median(figures[(name, "after")])
        if (name, "before") not in figures:
            print(f"| {name} | (refused: estimated hours) | {after:.3f} | |")
            continue
        before = statistics.median(figures[(name, "before")])
        print(f"| {name} | {before:.3f} | {after:.3f} | {before / after:.1f}x |")
    for label in trees:
        if long_file[label]:
            ratio = statistics.median(figures[("triple pendulum as a mechanism, 2000 s", label)]) / statistics.median(
                figures[("triple-a chain, 2000 s", label)])
            print(f"{label}: the mechanism file takes {ratio:.2f}x the chain preset's time")
    print(f"load average at end: {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
