"""The command line under hostile input (issue 23): files that never end, requests the machine cannot hold,
long runs, outputs that are links, devices or too long a name, and values that used to be read as something
else. Each refusal is one line on stderr with exit status 2, before any work; a long run is estimated up front,
reports its progress and keeps what it computed when stopped.

Nothing here depends on the machine's speed: the limits that are wall-clock figures (a segment's length, the
progress interval, the longest mechanism run) are set by the tests, and the assertions are on counts, content
and simulated time.
"""

from __future__ import annotations

import csv
import fcntl
import io
import json
import os
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from physics import long_run
from physics.chain_presets import get_preset
from physics.cli import main
from physics.errors import LinkageError
from physics.file_io import read_limited, write_atomically
from physics.mechanism import MECHANISM_PRESETS, Mechanism, validation
from physics.mechanism import simulate as mechanism_simulate
from physics.mechanism.validation import MAX_MOTOR_SPEED, check_runnable
from physics.model import Settings, make_chain, validated
from physics.outputs import partial_note
from physics.simulate import simulate
from physics.studies import chaos_map

ROOT = Path(__file__).resolve().parents[2]


def run(capsys, *argv):
    code = main(list(argv))
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def refused(capsys, *argv, needle: str = "") -> str:
    code, out, err = run(capsys, *argv)
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2, (code, err)
    assert len(lines) == 1 and "Traceback" not in err, err
    assert needle in lines[0], lines[0]
    return lines[0]


def pendulum_file(tmp_path: Path, mass="1.0", name="m.json") -> Path:
    path = tmp_path / name
    path.write_text('{"name": "p", "ground": {"O": [0, 0]}, "bodies": [{"name": "rod", "points": {"O": [0, 0], '
                    f'"T": [1, 0]}}, "mass": {mass}, "inertia": 0.1}}], "joints": [{{"kind": "revolute", "name": '
                    '"O", "a": "ground.O", "b": "rod.O"}]}')
    return path


# ---------------------------------------------------------------------------------------------------------
# Files that never end


@pytest.fixture
def endless_files(tmp_path):
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    return {"/dev/zero": "a device", str(fifo): "a pipe (FIFO)", str(tmp_path): "a folder"}


def test_a_device_a_fifo_or_a_folder_is_refused_at_once_wherever_a_file_is_read(capsys, endless_files):
    for path, kind in endless_files.items():
        refused(capsys, "mechanism", "--file", path, needle=f"is {kind}, not a regular file")
        refused(capsys, "simulate", "--mechanism", path, needle=f"is {kind}, not a regular file")
        refused(capsys, "accelerations", "--input", path, needle=f"is {kind}, not a regular file")


def test_a_file_is_read_up_to_its_limit_whatever_stat_says(tmp_path):
    # /proc files report size 0 and hold more: the reader counts what it reads
    assert Path("/proc/self/status").stat().st_size == 0
    with pytest.raises(LinkageError, match=r"status: over 100 bytes, more than the 100 allowed"):
        read_limited("/proc/self/status", 100, "status")
    big = tmp_path / "big.json"
    big.write_bytes(b" " * 70_000)
    with pytest.raises(LinkageError, match=r"big.json: 70000 bytes, more than the 65536 allowed"):
        read_limited(big, 65536, "big.json")
    assert read_limited(big, 70_000, "big.json") == b" " * 70_000


def test_the_app_reads_a_mechanism_file_through_the_same_bounded_reader(tmp_path):
    """``python -m app --mechanism /dev/zero`` and the CLI share physics.mechanism.files.load_mechanism."""
    result = subprocess.run([sys.executable, "-m", "app", "--mechanism", "/dev/zero", "--port", "0"], cwd=ROOT,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 2, result.stderr
    assert "/dev/zero: is a device, not a regular file" in result.stderr and "Traceback" not in result.stderr


# ---------------------------------------------------------------------------------------------------------
# Values read as something else


@pytest.mark.parametrize("mass, needle", [
    ("true", "mass: must be a finite number (got True); allowed range 0 <= mass <= 1e+06"),
    ('"1"', "mass: must be a finite number (got '1'); allowed range 0 <= mass <= 1e+06"),
    ("NaN", "mass: must be a finite number (got nan); allowed range 0 <= mass <= 1e+06"),
])
def test_a_mechanism_file_takes_numbers_only(tmp_path, capsys, mass, needle):
    refused(capsys, "mechanism", "--file", str(pendulum_file(tmp_path, mass)), needle=needle)
    code, out, err = run(capsys, "mechanism", "--file", str(pendulum_file(tmp_path, "1")), "--json")
    assert code == 0 and json.loads(out)["bodies"] == ["rod"], err


def test_chain_models_take_numbers_only_and_bound_the_tolerances():
    for mass in (True, "1"):
        with pytest.raises(LinkageError, match=r"m1: m = .*must be a number"):
            make_chain([1.0], [0.5], [mass], [0.1])
    with pytest.raises(LinkageError, match=r"rtol = 1e-300: .*allowed range: 1e-14 <= rtol <= 0.1"):
        validated(Settings, rtol=1e-300)
    with pytest.raises(LinkageError, match=r"samples"):
        validated(Settings, samples="5")


def test_options_given_an_empty_value_are_refused(capsys):
    refused(capsys, "simulate", "--trace=", needle="--trace: empty value")
    refused(capsys, "accelerations", "--preset", "four-bar", "--state=", needle="--state: empty value")
    refused(capsys, "simulate", "--out", "", needle="--out: empty value")
    refused(capsys, "simulate", "--trace=1,1e308", needle="allowed range: -1000 <= along <= 1000 m")


def test_a_state_off_the_loop_is_refused_with_the_gap(capsys):
    line = refused(capsys, "accelerations", "--preset", "four-bar", "--state", "0.3,0.5,1,0,0,0",
                   needle="--state: the start does not close the loop: the tip is 2.34 from the pin")
    assert "allowed 1e-08" in line
    preset = get_preset("four-bar")
    state = ",".join(repr(float(v)) for v in [*preset.theta0, *preset.omega0])
    code, out, err = run(capsys, "accelerations", "--preset", "four-bar", "--state", state)
    assert code == 0 and len(json.loads(out)["theta_ddot"]) == 3, err


def test_a_case_off_its_loop_is_refused_naming_the_case(tmp_path, capsys):
    case = {"links": 2, "params": {"L1": 1, "L2": 1, "d1": 0.5, "d2": 0.5, "m1": 1, "m2": 1, "I1": 0.1, "I2": 0.1},
            "theta": [0.3, -0.2], "pin": [1.9, 0.0]}
    path = tmp_path / "cases.json"
    path.write_text(json.dumps([case]))
    refused(capsys, "accelerations", "--input", str(path), needle="case 0: the start does not close the loop")


# ---------------------------------------------------------------------------------------------------------
# Outputs


def test_an_ensemble_refuses_a_file_type_it_cannot_write(tmp_path, capsys):
    refused(capsys, "ensemble", "--count", "2", "--t-end", "0.1", "--out", str(tmp_path / "x.gif"),
            needle="unknown file type '.gif'; allowed .json, .csv, .png")
    assert not (tmp_path / "x.gif").exists()


def test_a_symbolic_link_as_out_is_refused_and_its_target_left_alone(tmp_path, capsys):
    target = tmp_path / "target.csv"
    target.write_text("keep me\n")
    link = tmp_path / "link.csv"
    link.symlink_to(target)
    refused(capsys, "simulate", "--preset", "single", "--t-end", "0.1", "--samples", "3", "--out", str(link),
            needle="is a symbolic link")
    assert link.is_symlink() and target.read_text() == "keep me\n"


def test_a_name_too_long_is_one_line(tmp_path, capsys):
    refused(capsys, "simulate", "--preset", "single", "--t-end", "0.1", "--out", str(tmp_path / ("x" * 300)),
            needle="--out")
    refused(capsys, "simulate", "--preset", "single", "--t-end", "0.1", "--out", str(tmp_path / ("x" * 250)),
            needle="too long")


@pytest.mark.parametrize("umask, mode", [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_outputs_follow_the_umask(tmp_path, capsys, umask, mode):
    old = os.umask(umask)
    try:
        code, _, err = run(capsys, "simulate", "--preset", "single", "--t-end", "0.1", "--samples", "3", "--out",
                           str(tmp_path / "run.csv"))
        code_map, _, err_map = run(capsys, "chaos-map", "--resolution", "2", "--t-max", "0.1", "--workers", "1",
                                   "--no-progress", "--out", str(tmp_path / "map.png"), "--data",
                                   str(tmp_path / "map.npy"))
    finally:
        os.umask(old)
    assert code == 0 and code_map == 0, err + err_map
    for name in ("run.csv", "map.png", "map.npy"):
        assert stat.S_IMODE((tmp_path / name).stat().st_mode) == mode, name


def test_a_killed_writer_leaves_a_temporary_file_the_next_write_removes(tmp_path):
    out = tmp_path / "run.csv"
    # a writer killed with SIGKILL in the middle of its write (inside fsync), as kill -9 would
    script = ("import os, sys\nfrom physics import file_io as files\n"
              "files.os.fsync = lambda fd: os.kill(os.getpid(), 9)\n"
              "files.write_atomically(sys.argv[1], b'x' * 1000000)\n")
    result = subprocess.run([sys.executable, "-c", script, str(out)], cwd=ROOT, capture_output=True, timeout=120)
    assert result.returncode == -9
    stale = [p.name for p in tmp_path.iterdir()]
    assert len(stale) == 1 and stale[0].startswith(".run.csv.") and stale[0].endswith(".tmp"), stale
    # another target's temporary file and a live writer's stay
    other = tmp_path / ".other.csv.abcdefgh.tmp"
    other.write_text("not ours")
    live = tmp_path / ".run.csv.livewrit.tmp"
    live.write_text("being written")
    with open(live, "rb") as held:
        fcntl.flock(held.fileno(), fcntl.LOCK_EX)
        write_atomically(out, b"done\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([".other.csv.abcdefgh.tmp", ".run.csv.livewrit.tmp",
                                                                 "run.csv"])
    assert out.read_bytes() == b"done\n"


def test_chaos_map_checks_every_output_and_the_machine_before_any_work(tmp_path, capsys, monkeypatch):
    def no_work(*args, **kwargs):
        raise AssertionError("the map was computed before its arguments were checked")

    monkeypatch.setattr(chaos_map, "compute_map", no_work)
    small = ("chaos-map", "--resolution", "4", "--t-max", "0.5", "--workers", "1", "--no-progress")
    refused(capsys, *small, "--out", str(tmp_path), needle=f"--out {tmp_path}: is a folder")
    refused(capsys, *small, "--out", str(tmp_path / "m.png"), "--data", str(tmp_path / "no" / "t.npy"),
            needle=f"--data {tmp_path / 'no' / 't.npy'}: folder")
    monkeypatch.setattr(chaos_map, "available_memory", lambda: 8e9)
    refused(capsys, "chaos-map", "--resolution", "20000", "--workers", "1", "--out", str(tmp_path / "m.png"),
            needle="--resolution = 20000: the map needs about 48 GB, more than half the 8 GB this machine has free; "
                   "use --resolution 5773 or less")
    monkeypatch.setattr(chaos_map, "usable_cores", lambda: 2)
    refused(capsys, *small[:-3], "--workers", "3", "--out", str(tmp_path / "m.png"),
            needle="--workers = 3: this machine gives 2 cores; allowed range 1 <= workers <= 2")
    refused(capsys, "chaos-map", "--resolution", "5000", "--t-max", "100", "--workers", "1",
            "--out", str(tmp_path / "m.png"), needle="pixel-steps, more than the 1e+11")


def test_chaos_map_data_that_cannot_be_written_is_named_as_data(tmp_path, capsys):
    line = refused(capsys, "chaos-map", "--resolution", "2", "--t-max", "0.1", "--workers", "1", "--no-progress",
                   "--out", str(tmp_path / "m.png"), "--data", "/dev/full")
    assert line == "error: --data /dev/full: could not write (No space left on device)"


def test_bench_refuses_an_output_it_cannot_write_before_running(capsys):
    refused(capsys, "bench", "--quick", "--out", "/dev/full", needle="--out /dev/full: is not a folder")


# ---------------------------------------------------------------------------------------------------------
# Mechanisms that cannot run


def _crank_rocker(crank_tip_y: float = 0.1, speed: float | None = None, mass: float | None = None) -> Mechanism:
    document = MECHANISM_PRESETS["crank-rocker"]().model_dump(mode="json")
    for body in document["bodies"]:
        if body["name"] in ("crank", "coupler"):
            body["points"]["A"] = [0.0, crank_tip_y]
        if mass is not None and body["name"] == "rocker":
            body["mass"] = mass
    if speed is not None:
        document["drivers"][0]["speed"] = speed
    return Mechanism.model_validate(document)


def test_every_preset_mechanism_passes_the_full_check():
    for name, build in MECHANISM_PRESETS.items():
        assert check_runnable(build()).q.size == 3 * len(build().bodies), name


@pytest.mark.parametrize("mechanism, needle", [
    (lambda: _crank_rocker(0.25), "the motors cannot drive it through a turn (it locks at t = 0.736 s of 1 s)"),
    (lambda: _crank_rocker(speed=1000.0), f"speed = 1000 rad/s: allowed range -{MAX_MOTOR_SPEED:g} <= speed"),
    (lambda: _crank_rocker(mass=0.0), "body 'rocker': mass = 0 kg: allowed range 1e-06 <= mass <= 1e+06 kg"),
    (lambda: _crank_rocker(mass=5e-324), "body 'rocker': mass = 4.94066e-324 kg: allowed range 1e-06 <= mass"),
])
def test_a_mechanism_that_cannot_run_is_refused_before_it_is_accepted(tmp_path, capsys, mechanism, needle):
    model = mechanism()
    with pytest.raises(LinkageError, match=None) as error:
        check_runnable(model)
    assert needle in str(error.value)
    path = tmp_path / "m.json"
    path.write_text(model.model_dump_json())
    refused(capsys, "mechanism", "--file", str(path), needle=needle)  # without --t-end: no longer exit 0


# ---------------------------------------------------------------------------------------------------------
# Long runs


def test_a_run_out_of_proportion_is_refused_up_front_with_its_estimate(capsys, monkeypatch):
    """The estimate is the probe's own pace: its steps over the time it reached, times t_end. The probe is read
    back here (a chaotic run's reach moves with the last bits of any change: 1290 s on one engine, 1313 s on
    another), so the test checks the arithmetic and the words, not one engine's rounding."""
    probes = []

    def probe(*args, **kwargs):
        probes.append(simulate(*args, **kwargs))
        return probes[-1]

    monkeypatch.setattr(long_run, "simulate", probe)
    line = refused(capsys, "simulate", "--t-end", "1e6")
    assert len(probes) == 1 and probes[0].n_steps == long_run.PROBE_STEPS == 20000
    reached = probes[0].stats["t_reached"]
    assert 100.0 < reached < 1e4  # the seed's triple pendulum at rtol 1e-10 takes about 15 steps a second
    assert (f"t_end = 1e+06 s: about {20000 / reached * 1e6:.3g} integration steps (the first 20000 reached "
            f"t = {reached:.4g} s)") in line
    assert "more than max_steps = 1e+07" in line and "raise --max-steps (at most 1e+09)" in line


@pytest.fixture
def short_segments(monkeypatch):
    """Segments of a few steps, a progress line after each: the segmented path on a run of a second."""
    monkeypatch.setattr(long_run, "PROBE_STEPS", 3)
    monkeypatch.setattr(long_run, "MIN_SEGMENT_STEPS", 2)
    monkeypatch.setattr(long_run, "MAX_SEGMENT_STEPS", 3)
    monkeypatch.setattr(long_run, "MAX_MECHANISM_SEGMENT", 0.05)
    monkeypatch.setattr(long_run, "PROGRESS_EVERY", 0.0)
    monkeypatch.setattr(long_run, "PROGRESS_AFTER", 0.0)
    monkeypatch.setattr(long_run, "SEGMENTED_AFTER", 0.0)
    monkeypatch.setattr(long_run, "PROBE_SPAN", 0.05)


@pytest.mark.parametrize("preset, options", [
    ("triple-a", {}),
    ("four-bar", {"method": "dae"}),
    ("double", {"integrator": "midpoint", "step": 0.01}),
])
def test_a_segmented_run_gives_the_samples_of_one_call(short_segments, monkeypatch, preset, options):
    chosen = get_preset(preset)
    settings = Settings(t_end=3.0, samples=31, **options)
    whole = simulate(chosen.chain, chosen.theta0, chosen.omega0, settings)
    calls = []
    monkeypatch.setattr(long_run, "simulate", lambda *args, **kwargs: calls.append(kwargs) or simulate(*args, **kwargs))
    stream = io.StringIO()
    parts = long_run.simulate_in_segments(chosen.chain, chosen.theta0, chosen.omega0, settings, stream)
    assert parts.success, parts.message
    assert len(calls) >= 3 and all(call.get("continuing") for call in calls[1:])  # it was cut into segments
    assert np.array_equal(parts.t, whole.t)
    for name, column in whole.columns().items():
        assert parts.columns()[name].shape == column.shape, name
    assert np.max(np.abs(parts.theta - whole.theta)) < 1e-6
    lines = stream.getvalue().splitlines()
    assert lines and all(" of 3 s (" in line for line in lines), lines
    assert lines[-1] == "simulated 3 of 3 s (100.00 %), about 0 s left"


def test_ctrl_c_keeps_what_was_computed_in_out_partial(tmp_path, capsys, short_segments, monkeypatch):
    calls = {"count": 0}

    def interrupted_third_segment(*args, **kwargs):
        calls["count"] += 1
        if calls["count"] == 3:
            raise KeyboardInterrupt
        return simulate(*args, **kwargs)

    monkeypatch.setattr(long_run, "simulate", interrupted_third_segment)
    out = tmp_path / "run.csv"
    code, _, err = run(capsys, "simulate", "--preset", "triple-a", "--t-end", "3", "--samples", "301",
                       "--out", str(out))
    assert code == 3 and not out.exists()
    rows = list(csv.reader((tmp_path / "run.csv.partial").read_text().splitlines()))
    reached = float(rows[-1][0])
    assert 0.0 < reached < 3.0 and len(rows) - 1 == round(reached / 0.01) + 1
    assert err.splitlines()[-1] == (f"error: interrupted (Ctrl+C) at t = {err.split('at t = ')[1].split(' s')[0]} s; "
                                    f"the {len(rows) - 1} samples up to t = {reached:.6g} s are in {out}.partial")


def test_a_run_stopped_at_its_start_says_no_sample_was_kept_not_a_time_that_does_not_exist(tmp_path, capsys):
    """Started exactly at the change-point preset's collinear position, the run stops at t = 0 with no sample: its
    one line says the .partial file holds the header alone (it used to quote "the 0 samples up to t = nan s")."""
    out = tmp_path / "run.csv"
    code, _, err = run(capsys, "simulate", "--preset", "change-point", "--t-end", "1",
                       "--set", "theta1=1.5707963267948966", "--set", "theta2=1.5707963267948966",
                       "--set", "theta3=-1.5707963267948966", "--out", str(out))
    assert code == 3 and not out.exists()
    rows = list(csv.reader((tmp_path / "run.csv.partial").read_text().splitlines()))
    assert len(rows) == 1 and rows[0][0] == "t"  # the header alone
    line = err.splitlines()[-1]
    assert line.startswith("error: the system became singular") and "nan" not in line
    assert line.endswith(f"; no sample was computed (the table's header alone is in {out}.partial)")


@pytest.mark.parametrize(("times", "expected"), [
    ([], "; no sample was computed (the table's header alone is in run.csv.partial)"),
    ([0.25], "; the 1 sample, at t = 0.25 s, is in run.csv.partial"),
    ([0.0, 0.5, 1.25], "; the 3 samples up to t = 1.25 s are in run.csv.partial"),
])
def test_a_stopped_runs_note_names_what_was_kept(times, expected):
    assert partial_note(np.array(times), "run.csv.partial") == expected
    assert partial_note(np.array(times), None) == ""


def test_a_long_mechanism_run_is_estimated_reported_and_stopped(tmp_path, capsys, short_segments, monkeypatch):
    monkeypatch.setattr(long_run, "MAX_MECHANISM_SECONDS", 1e-9)
    line = refused(capsys, "mechanism", "--preset", "jansen-leg", "--t-end", "1e4", "--samples", "100000")
    assert "--t-end 10000 with --samples 100000: about" in line and "a mechanism run may take" in line
    monkeypatch.setattr(long_run, "MAX_MECHANISM_SECONDS", 1e9)
    out = tmp_path / "run.csv"
    code, _, err = run(capsys, "mechanism", "--preset", "slider-crank", "--t-end", "0.5", "--samples", "11",
                       "--out", str(out))
    assert code == 0, err
    assert "simulated 0.5 of 0.5 s (100.00 %)" in err
    segmented = np.loadtxt(out, delimiter=",", skiprows=1)
    monkeypatch.setattr(long_run, "SEGMENTED_AFTER", 1e9)
    code, _, err = run(capsys, "mechanism", "--preset", "slider-crank", "--t-end", "0.5", "--samples", "11",
                       "--out", str(out))
    whole = np.loadtxt(out, delimiter=",", skiprows=1)
    assert code == 0 and segmented.shape == whole.shape == (11, whole.shape[1])
    assert np.max(np.abs(segmented[:, 1:3] - whole[:, 1:3])) < 1e-6  # the traced point
    calls = {"count": 0}
    real = mechanism_simulate.simulate_mechanism

    def interrupted(*args, **kwargs):
        calls["count"] += 1
        if calls["count"] == 4:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(long_run, "SEGMENTED_AFTER", 0.0)
    monkeypatch.setattr(mechanism_simulate, "simulate_mechanism", interrupted)
    code, _, err = run(capsys, "mechanism", "--preset", "slider-crank", "--t-end", "0.5", "--samples", "11",
                       "--out", str(tmp_path / "stopped.csv"))
    assert code == 3 and not (tmp_path / "stopped.csv").exists()
    kept = np.loadtxt(tmp_path / "stopped.csv.partial", delimiter=",", skiprows=1, ndmin=2)
    assert 1 <= len(kept) < 11 and "interrupted (Ctrl+C)" in err.splitlines()[-1]


def test_an_edit_of_masses_or_motor_speed_sweeps_nothing_again():
    """The sweep through a turn depends on the geometry and the motors' speed ratios only: a slider dragged in
    the app (a mass, g, the motor's speed) reuses it; a new geometry sweeps again."""
    mechanism = MECHANISM_PRESETS["crank-rocker"]()
    check_runnable(mechanism)
    before = validation._sweep_failure.cache_info()
    heavier = Mechanism.model_validate({**mechanism.model_dump(mode="json"), "g": 3.0})
    faster = _crank_rocker(speed=2.5 * mechanism.drivers[0].speed)
    check_runnable(heavier)
    check_runnable(faster)
    after = validation._sweep_failure.cache_info()
    assert (after.misses, after.hits) == (before.misses, before.hits + 2)
    check_runnable(_crank_rocker(0.11))  # another crank: swept
    assert validation._sweep_failure.cache_info().misses == after.misses + 1
