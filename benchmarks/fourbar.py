"""Four-bar figures for BENCHMARKS.md: time for the seed's 100 s per formulation and stabilisation, and for the
reduced model, with the tip drift and the energy drift of each run.

    python -m benchmarks.fourbar [--repeats 5]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from physics import Settings, get_preset, simulate

CONFIGS = [(m, s) for m in ("newton_euler", "lagrange", "dae") for s in ("none", "baumgarte", "projection")]
CONFIGS += [("reduced", "projection")]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.fourbar")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)
    preset = get_preset("four-bar")
    print("| method | stabilisation | median time, 100 s (ms) | max tip distance from pin | relative energy drift |")
    print("|---|---|---|---|---|")
    for method, stabilization in CONFIGS:
        settings = Settings(method=method, t_end=100.0, samples=2001, stabilization=stabilization)
        run = simulate(preset.chain, preset.theta0, preset.omega0, settings)  # warm-up (compilation)
        times = []
        for _ in range(args.repeats):
            start = time.perf_counter()
            run = simulate(preset.chain, preset.theta0, preset.omega0, settings)
            times.append(time.perf_counter() - start)
        drift = float(np.max(np.hypot(run.constraint_xy[:, 0], run.constraint_xy[:, 1])))
        label = stabilization if method != "reduced" else "(one coordinate)"
        print(f"| {method} | {label} | {1e3 * statistics.median(times):.1f} | {drift:.2e} | {run.energy_drift():.2e} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
