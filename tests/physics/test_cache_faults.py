"""The cache trusts nothing on disk: every damaged, half-written, raced, foreign or read-only cache still gives
the right answer, with at most one line on stderr and never a traceback.

Each case runs ``python -m physics accelerations`` in a fresh process on its own copy of one warmed cache
folder (so numba's kernels are compiled once for the whole module), after damaging that copy.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest

# Every test damages or relocates a cache, so its processes compile the kernels again (10-30 s apiece).
pytestmark = pytest.mark.slow

COMMAND = [sys.executable, "-m", "physics", "accelerations", "--preset", "triple-a", "--method", "lagrange",
           "--state", "0.3,-0.2,0.5,0.1,0.0,-0.4"]
DAMAGES = {
    "truncated": lambda data: data[: len(data) // 2],
    "empty": lambda data: b"",
    "garbage": lambda data: os.urandom(max(len(data), 64)),
    "flipped": lambda data: data[: len(data) // 2] + bytes([data[len(data) // 2] ^ 0xFF]) + data[len(data) // 2 + 1:],
}


def _env(cache: Path, **extra) -> dict:
    env = dict(os.environ)
    env["LINKAGE_LAB_CACHE"] = str(cache)
    env.update(extra)
    return env


def _run(cache: Path, **extra) -> subprocess.CompletedProcess:
    return subprocess.run(COMMAND, capture_output=True, text=True, env=_env(cache, **extra), timeout=600)


def _answer(result: subprocess.CompletedProcess) -> list[float]:
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr, result.stderr
    return json.loads(result.stdout)["theta_ddot"]


@pytest.fixture(scope="module")
def template(tmp_path_factory):
    """A cache folder warmed by one run, and the answer it gave."""
    folder = tmp_path_factory.mktemp("template") / "cache"
    answer = _answer(_run(folder))
    return folder, answer


@pytest.fixture
def cache(template, tmp_path):
    folder, answer = template
    copy = tmp_path / "cache"
    shutil.copytree(folder, copy, symlinks=True)
    return copy, answer


def _generated_source(folder: Path) -> Path:
    """The command's generated system: the triple pendulum's tree Lagrange system on the mechanism engine (its
    pins' coordinates the bars' absolute angles), which the chain's record names."""
    (path,) = folder.glob("lagrange-mechanism-absolute-*.py")
    return path


def _numba_file(folder: Path, name: str, suffix: str) -> Path:
    """One of numba's files for a once-compiled kernel (generated code keeps no machine code on disk)."""
    (base,) = (folder / "numba").glob("kernels-*")
    (path,) = [p for p in base.glob(f"{name}-*{suffix}") if not p.name.endswith(".sha256")]
    return path


def _one_warning(stderr: str) -> None:
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert lines and all(line.startswith("linkage-lab: ") for line in lines), stderr
    assert len(lines) <= 2, stderr


@pytest.mark.parametrize("damage", sorted(DAMAGES))
def test_damaged_generated_source_is_rebuilt(cache, damage):
    folder, answer = cache
    path = _generated_source(folder)
    path.write_bytes(DAMAGES[damage](path.read_bytes()))
    result = _run(folder)
    assert _answer(result) == answer
    _one_warning(result.stderr)
    assert _answer(_run(folder)) == answer and _run(folder).stderr == ""  # rebuilt for good


@pytest.mark.parametrize("name", ["system.solve_states", "linear.ldlt_solve"])
@pytest.mark.parametrize("suffix", [".nbi", ".nbc"])
@pytest.mark.parametrize("damage", sorted(DAMAGES))
def test_damaged_compiled_code_is_detected_and_rebuilt(cache, name, suffix, damage):
    folder, answer = cache
    path = _numba_file(folder, name, suffix)
    path.write_bytes(DAMAGES[damage](path.read_bytes()))
    result = _run(folder)
    assert _answer(result) == answer
    if name == "system.solve_states":  # the command's entry kernel: its files are read, checked and rebuilt
        _one_warning(result.stderr)
        assert f"compiled-code cache file for {name}" in result.stderr
    else:  # its machine code is inside the entry kernel's file: this file is never read, so does no harm
        assert result.stderr == ""
    again = _run(folder)
    assert _answer(again) == answer and again.stderr == ""


def test_stale_half_written_files_are_ignored(cache):
    folder, answer = cache
    source = _generated_source(folder)
    (folder / f".{source.stem}.abc123.tmp").write_text(source.read_text()[:100])
    index = _numba_file(folder, "system.solve_states", ".nbi")
    partial = index.with_name(index.name + ".tmp.0123456789abcdef")
    partial.write_bytes(index.read_bytes()[:10])
    old = time.time() - 7200
    os.utime(partial, (old, old))
    result = _run(folder)
    assert _answer(result) == answer and result.stderr == ""
    assert not partial.exists()  # a temporary file older than an hour is removed


def test_a_killed_build_leaves_nothing_that_breaks_the_next_run(cache):
    folder, answer = cache
    for path in folder.glob("*.py"):
        path.unlink()
    process = subprocess.Popen(COMMAND, env=_env(folder), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(1.5)  # inside the derivation or the compilation
    process.send_signal(signal.SIGKILL)
    process.wait(timeout=60)
    result = _run(folder)
    assert _answer(result) == answer and "Traceback" not in result.stderr


@pytest.mark.parametrize("racers", [2, 4])
def test_processes_building_the_same_entry_at_once_all_get_the_right_answer(cache, racers):
    folder, answer = cache
    for path in folder.glob("*.py"):
        path.unlink()
    processes = [subprocess.Popen(COMMAND, env=_env(folder), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                  text=True) for _ in range(racers)]
    for process in processes:
        stdout, stderr = process.communicate(timeout=600)
        assert process.returncode == 0, stderr
        assert "Traceback" not in stderr, stderr
        assert json.loads(stdout)["theta_ddot"] == answer
    assert _answer(_run(folder)) == answer


def test_a_folder_writable_by_others_is_refused_and_the_run_goes_on(cache):
    folder, answer = cache
    planted = _generated_source(folder)
    planted.write_text("raise SystemExit('planted')\n" + planted.read_text())  # run, it would end the process
    folder.chmod(0o777)
    result = _run(folder)
    assert _answer(result) == answer
    _one_warning(result.stderr)
    assert str(folder) in result.stderr and "writable by group or others" in result.stderr
    assert "chmod 700" in result.stderr or "LINKAGE_LAB_CACHE" in result.stderr


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() != 0, reason="changing a folder's owner needs root")
def test_a_folder_owned_by_another_user_is_refused_and_the_run_goes_on(cache):
    folder, answer = cache
    os.chown(folder, 65534, 65534)  # nobody
    result = _run(folder)
    assert _answer(result) == answer
    _one_warning(result.stderr)
    assert str(folder) in result.stderr and "owned by another user" in result.stderr


def test_a_read_only_folder_works_through_a_private_temporary_cache(cache):
    folder, answer = cache
    for path in folder.glob("*.py"):
        path.unlink()  # nothing to load: it would have to build, and cannot write here
    if os.geteuid() == 0:
        # root writes through permission bits: make the folder immutable instead (ext4's chattr +i)
        made = subprocess.run(["chattr", "+i", str(folder)], capture_output=True, text=True)
        if made.returncode != 0:
            pytest.skip(f"cannot make a folder read-only for root here: {made.stderr.strip()}")
        undo = ["chattr", "-i", str(folder)]
    else:
        folder.chmod(0o500)
        undo = ["chmod", "700", str(folder)]
    try:
        result = _run(folder)
    finally:
        subprocess.run(undo, check=True)
    assert _answer(result) == answer
    _one_warning(result.stderr)
    assert "is read-only" in result.stderr


def test_cache_command_shows_and_clears(cache):
    folder, _ = cache
    info = subprocess.run([sys.executable, "-m", "physics", "cache", "--info", "--json"], capture_output=True,
                          text=True, env=_env(folder), timeout=120)
    assert info.returncode == 0, info.stderr
    data = json.loads(info.stdout)
    assert data["folder"] == str(folder)
    assert {(e["method"], e["links"], e["closure"]) for e in data["mechanisms"]} == {("lagrange", 3, "open")}
    assert data["bytes"]["kernels_machine_code"] > 0 and data["total_bytes"] == sum(data["bytes"].values())
    cleared = subprocess.run([sys.executable, "-m", "physics", "cache", "--clear"], capture_output=True, text=True,
                             env=_env(folder), timeout=120)
    assert cleared.returncode == 0 and "removed 1 mechanisms" in cleared.stdout
    assert folder.is_dir() and not any(folder.iterdir())
    assert stat.S_IMODE(folder.stat().st_mode) == 0o700


@pytest.mark.parametrize("kind", ["a file", "under a file"])
def test_a_cache_path_that_cannot_be_a_folder_falls_back_to_a_private_cache(template, tmp_path, kind):
    _, answer = template
    blocker = tmp_path / "blocker"
    blocker.write_text("not a folder")
    path = blocker if kind == "a file" else blocker / "cache"
    result = _run(path)
    assert _answer(result) == answer
    _one_warning(result.stderr)
    assert str(path) in result.stderr and ("is not a folder" in result.stderr or "cannot be created" in result.stderr)
