"""What every study shares: a progress bar, a timer with warm-up and repeats, a note of the machine's load,
and the writer of a study's JSON and Markdown report.

Why timing lives here and not in tests: wall time on a shared machine is noisy, so studies measure it (median
of repeats, stated with the machine's load) and BENCHMARKS.md records it; tests only check that the numbers
are sane.
"""

from __future__ import annotations

import json
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

try:  # tqdm comes with viser; without it the bar is a one-line counter
    from tqdm import tqdm
except ImportError:  # pragma: no cover - depends on the environment
    tqdm = None

T = TypeVar("T")

TIME_BUDGET = 2.0  # seconds of repeats per point at most (after the first, untimed, run)
MIN_TIMED = 0.2  # fast runs are repeated until this many seconds are spent, for a steadier median


class Progress:
    """A progress bar on stderr: tqdm when installed, else a one-line counter."""

    def __init__(self, total: int, description: str, enabled: bool = True):
        self.total, self.done, self.description, self.enabled = total, 0, description, enabled
        self._bar = None
        if enabled and tqdm is not None:
            self._bar = tqdm(total=total, desc=description, file=sys.stderr, unit="run", leave=True)

    def step(self, label: str = "") -> None:
        self.done += 1
        if not self.enabled:
            return
        if self._bar is not None:
            self._bar.set_postfix_str(label[:40], refresh=False)
            self._bar.update(1)
        else:
            width = 30
            filled = int(width * self.done / max(self.total, 1))
            sys.stderr.write(f"\r{self.description} [{'#' * filled}{'.' * (width - filled)}] "
                             f"{self.done}/{self.total} {label[:40]:40s}")
            sys.stderr.flush()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
        elif self.enabled:
            sys.stderr.write("\n")


def timed(run: Callable[[], T], repeats: int, budget: float = TIME_BUDGET) -> tuple[T, float, int]:
    """Run once untimed (warm-up: caches, JIT), then at least ``repeats`` timed runs unless ``budget`` seconds
    run out first, and more (up to 20 x repeats) while less than MIN_TIMED seconds were spent; return
    ``(result, median seconds, runs timed)``."""
    result = run()
    times: list[float] = []
    spent = 0.0
    while len(times) < 20 * max(1, repeats):
        start = time.perf_counter()
        run()
        elapsed = time.perf_counter() - start
        times.append(elapsed)
        spent += elapsed
        if spent > budget or (len(times) >= repeats and spent > MIN_TIMED):
            break
    return result, statistics.median(times), len(times)


def median_time(run: Callable[[], Any], repeats: int = 5) -> float:
    """Median wall time of ``repeats`` calls after one untimed warm-up call."""
    run()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def machine_note() -> dict:
    """Python, CPU count and load average: what a reader needs to judge a timing."""
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    return {
        "python": platform.python_version(),
        "machine": platform.machine(),
        "cpus": os.cpu_count(),
        "load_average_1_5_15": [round(v, 2) for v in load],
    }


def write_report(out: Path, stem: str, document: dict, markdown: str) -> list[Path]:
    """``<stem>.json`` and ``<stem>.md`` in ``out`` (created), and the table printed: what each suite leaves."""
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{stem}.json"
    path.write_text(json.dumps(document, indent=1))
    md = out / f"{stem}.md"
    md.write_text(markdown)
    print(markdown)
    return [path, md]


def format_seconds(value: float | None) -> str:
    """``12.3 ms`` (or ``-`` for a missing value), as the reports' tables print times."""
    if value is None:
        return "-"
    return f"{value * 1e3:.3g} ms"
