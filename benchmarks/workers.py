"""What the benchmarks that compare two trees side by side share: a worker script's timing loop and one run of
a worker in a tree.

A worker runs with ``PYTHONPATH`` set to its tree (``--before``'s worktree or this one), so it imports that
tree's code; its script is therefore a string written here, never an import of ``benchmarks`` from the worker
(an older tree may lack this module). :data:`TIMED_CASES_LOOP` is text appended to a script that has built
``calls`` (a dict from case name to a function of no arguments).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

TIMED_CASES_LOOP = r"""
print(json.dumps(list(calls)), flush=True)
for line in sys.stdin:  # "CASE COUNT": COUNT timed calls of CASE, their median thread CPU time in ms
    case, count = line.rsplit(" ", 1)
    spent = []
    for _ in range(int(count)):
        started = time.thread_time()
        calls[case]()
        spent.append(time.thread_time() - started)
    print(1e3 * statistics.median(spent), flush=True)
"""


def run_once(tree: Path, script: str, arguments: list[str], **environment: str) -> dict:
    """Run ``script`` in ``tree`` with ``arguments`` (and ``environment`` added) and return the JSON of its last
    line of output; its stderr's end as the reason when it fails."""
    env = dict(os.environ, PYTHONPATH=str(tree), **environment)
    done = subprocess.run([sys.executable, "-c", script, *arguments], cwd=tree, env=env, capture_output=True,
                          text=True)
    if done.returncode != 0:
        raise SystemExit(f"{tree}: {done.stderr.strip()[-800:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])
