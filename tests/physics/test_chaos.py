"""Chaos maps (physics.studies.chaos_map): the flip-time physics, tiling through executors, Dask, the CLI."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from physics import Settings, get_preset, load_compiled, simulate
from physics.kinematics import energies
from physics.simulate.chain_system import ChainSystem
from physics.studies import chaos_map as chaos
from physics.studies.chaos_map import FORBIDDEN, compute_map, compute_tile, flip_energy, grid, tiles
from physics.studies.charts import colormap

ROOT = Path(__file__).resolve().parents[2]


def _same(a, b) -> bool:
    """Equal bit for bit, NaN (no flip within t_max) included."""
    return a.shape == b.shape and np.array_equal(np.isnan(a), np.isnan(b)) and np.array_equal(
        np.nan_to_num(a, nan=0.0), np.nan_to_num(b, nan=0.0))


@pytest.mark.parametrize("name", ["double", "triple-a"])
def test_flip_energy_is_the_least_energy_with_a_link_upright(name, rng):
    chain = get_preset(name).chain
    params, n = chain.params(), chain.n
    bound = flip_energy(params, n)
    lowest = np.inf
    for k in range(n):  # brute force: link k upright, the others anywhere, at rest
        theta = rng.uniform(-math.pi, math.pi, (20000, n))
        theta[:, k] = math.pi
        theta[:20, :] = np.where(np.arange(n) == k, math.pi, 0.0)  # include the exact minimiser
        lowest = min(lowest, float(energies(params, theta, np.zeros_like(theta))[2].min()))
    assert bound <= lowest + 1e-12
    assert lowest - bound < 1e-9


def test_tile_flip_times_match_an_adaptive_run_and_forbidden_pixels_cannot_flip():
    chain = get_preset("double").chain
    params = chain.params()
    angles = grid(6)
    task = tiles(chain, "lagrange", 6, 8.0, 0.01)[0]
    start, band = compute_tile(task)
    assert start == 0 and band.shape == (6, 6)
    forbidden = band == FORBIDDEN
    theta = np.stack(np.meshgrid(angles, angles), axis=-1).reshape(-1, 2)  # row i: theta2; column j: theta1
    energy = energies(params, theta, np.zeros_like(theta))[2].reshape(6, 6)
    assert forbidden.any() and np.all(energy[forbidden] < flip_energy(params, 2))
    checked = 0
    for i, j in zip(*np.nonzero(band > 0)):
        if band[i, j] > 3.0:
            continue  # early flips only: later ones are already chaotic
        trajectory = simulate(chain, [angles[j], angles[i]], [0.0, 0.0],
                              Settings(integrator="DOP853", rtol=1e-10, atol=1e-10, t_end=band[i, j] + 0.5,
                                       samples=int((band[i, j] + 0.5) / 0.001) + 1))
        over = np.flatnonzero(np.any(np.abs(trajectory.theta) > math.pi, axis=1))
        assert over.size and abs(trajectory.t[over[0]] - band[i, j]) <= 0.011
        checked += 1
        if checked == 3:
            break
    assert checked >= 2


def test_local_processes_give_the_same_map_as_one_process():
    chain = get_preset("double").chain
    single = compute_map(chain, resolution=20, t_max=4.0)
    with ProcessPoolExecutor(max_workers=2) as pool:
        pooled = compute_map(chain, resolution=20, t_max=4.0, executor=pool)
    assert _same(single, pooled)
    assert np.count_nonzero(single > 0) > 0 and np.count_nonzero(single == FORBIDDEN) > 0


@pytest.mark.slow  # starts a local Dask cluster
def test_a_local_dask_cluster_gives_the_same_map_as_one_process():
    distributed = pytest.importorskip(
        "distributed", reason="dask[distributed] is not installed (pip install 'dask[distributed]'; CI installs it)")
    chain = get_preset("double").chain
    single = compute_map(chain, resolution=16, t_max=3.0)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        mapped = compute_map(chain, resolution=16, t_max=3.0, executor=client.get_executor())
    assert _same(single, mapped)


def _cli(*args, timeout=120):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "physics", "chaos-map", *args], capture_output=True, text=True,
                          cwd=ROOT, env=env, timeout=timeout)


def test_cli_writes_the_png_and_reports_throughput(tmp_path):
    out = tmp_path / "map.png"
    data = tmp_path / "map.npy"
    result = _cli("--resolution", "12", "--t-max", "2", "--workers", "1", "--out", str(out), "--data", str(data),
                  "--no-progress")
    assert result.returncode == 0, result.stderr
    info = json.loads(result.stdout)
    assert info["pixels"] == 144 and info["pixels_per_second"] > 0
    assert info["forbidden"] + info["flipped"] + info["not_within_t_max"] == 144
    image = Image.open(out)
    assert image.size == (12, 12) and image.mode == "RGB"
    times = np.load(data)
    assert times.shape == (12, 12)
    # The image is drawn with theta2 increasing upwards: its bottom row is the map's first row.
    pixels = np.asarray(image)
    assert np.array_equal(np.all(pixels[-1] == 110, axis=-1), times[0] == FORBIDDEN)


@pytest.mark.parametrize(
    "args, needle",
    [(["--resolution", "0"], "resolution"), (["--preset", "four-bar"], "open chains"),
     (["--preset", "single"], "at least 2 bars"), (["--t-max", "-1"], "t_max"), (["--workers", "0"], "workers")],
)
def test_cli_bad_arguments_fail_with_one_line(tmp_path, args, needle):
    result = _cli(*args, "--out", str(tmp_path / "x.png"), "--no-progress", timeout=60)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0] and "Traceback" not in result.stderr


def test_the_framed_map_has_its_axes_a_colour_bar_and_a_key():
    """The Analysis tab's picture (issue 14): the map unchanged inside, a colour bar from the shortest flip time
    (bottom) to t_max (top) in the map's own colours, and the two colours that are not times in a key."""
    rng = np.random.default_rng(3)
    times = rng.uniform(0.01, 10.0, (16, 16))
    times[0, 0], times[1, 1] = chaos.FORBIDDEN, 0.0
    rgb = chaos.to_rgb(times, 10.0, 0.01)
    framed = chaos.framed_picture(rgb, 10.0, 0.01)
    top, left = chaos.FRAME_TOP, chaos.FRAME_LEFT
    assert np.array_equal(framed[top:top + 16, left:left + 16], rgb)
    bar_x = left + 16 + chaos.BAR_GAP + chaos.BAR_WIDTH // 2
    assert np.array_equal(framed[top, bar_x], colormap(np.array(1.0)))
    assert np.array_equal(framed[top + 15, bar_x], colormap(np.array(0.0)))
    key = framed[top + 16 + chaos.FRAME_BOTTOM:]
    for colour in (chaos.NOT_FLIPPED_RGB, chaos.FORBIDDEN_RGB):
        assert np.all(key == colour, axis=-1).sum() >= 64, colour
    assert chaos._log_ticks(0.01, 10.0) == [0.01, 0.05, 0.2, 1.0, 5.0]


@pytest.mark.parametrize("name", ["double", "triple-a"])
def test_the_map_is_the_chains_own_formulas_map(name, monkeypatch):
    """Every tile runs the chain written as a mechanism (physics.simulate.chain_system); its flip times, whole
    steps, are bit for bit those of the same batched RK4 on the chain's own system (its independent
    derivation, :func:`physics.load_compiled`, in the chain's bar order: measured, every pixel of both maps)."""
    chain = get_preset(name).chain
    on_engine = compute_map(chain, resolution=20, t_max=4.0)
    compiled = load_compiled("lagrange", chain.n, chain.pinned)
    identity = np.arange(chain.n, dtype=np.int64)
    chains_own = ChainSystem("lagrange", 0.0, compiled, chain.params(), identity, identity.copy(),
                             compiled.theta_ddot_index, compiled.reaction_index, np.zeros(0, dtype=np.int64),
                             None)  # type: ignore[arg-type]  # no route: the chain's own system

    def chain_kernel(task_chain, method):
        assert (task_chain, method) == (chain, "lagrange")
        return chains_own

    monkeypatch.setattr(chaos, "chain_system", chain_kernel)
    on_formulas = compute_map(chain, resolution=20, t_max=4.0)
    assert _same(on_formulas, on_engine)
    assert np.count_nonzero(on_engine > 0) > 0
