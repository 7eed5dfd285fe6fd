"""The cache runs nothing that this user's Linkage Lab did not write: issue 23's planted-code attacks, replayed.

A folder open to others is refused; after the user applies the printed fix (``chmod 700``), files planted
meanwhile (a generated module with a valid SHA-256 line, a pickle index with or without a tag, files of another
user or writable by group) are discarded and rebuilt with one line, and never run: each planted file would leave
a marker file if it ran. A damaged ``.pyc`` beside a generated module, which Python's import system would run in
place of the module, changes nothing; garbled tags end in a rebuild, never a traceback.

Each case runs ``python -m physics accelerations`` in a fresh process (the real command, on the real paths) on
its own copy of one warmed cache folder, with a key folder of its own (``LINKAGE_LAB_KEY_DIR``): nothing here
touches the user's cache or key.
"""

from __future__ import annotations

import hashlib
import hmac
import importlib.util
import json
import os
import pickle
import py_compile
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import numba
import pytest

# Every test relocates or damages a cache, so some of its processes derive or compile again.
pytestmark = pytest.mark.slow

DAE = [sys.executable, "-m", "physics", "accelerations", "--preset", "triple-b", "--method", "dae"]
LAGRANGE = [sys.executable, "-m", "physics", "accelerations", "--preset", "triple-b", "--method", "lagrange"]
IS_ROOT = hasattr(os, "geteuid") and os.geteuid() == 0
NOBODY = 65534
MAC_MAGIC = b"\nlinkage-lab-hmac-sha256:"


def _env(cache: Path, keys: Path) -> dict:
    env = dict(os.environ)
    env["LINKAGE_LAB_CACHE"] = str(cache)
    env["LINKAGE_LAB_KEY_DIR"] = str(keys)
    return env


def _run(cache: Path, keys: Path, command=DAE) -> subprocess.CompletedProcess:
    return subprocess.run(command, capture_output=True, text=True, env=_env(cache, keys), timeout=600)


def _answer(result: subprocess.CompletedProcess) -> list[float]:
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr, result.stderr
    return json.loads(result.stdout)["theta_ddot"]


def _one_line(result: subprocess.CompletedProcess, *words: str) -> str:
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("linkage-lab: "), result.stderr
    for word in words:
        assert word in lines[0], lines[0]
    return lines[0]


@pytest.fixture(scope="module")
def template(tmp_path_factory):
    """A cache warmed by the DAE and Lagrange commands, its key folder, and the DAE answer (from the run that
    derived and compiled everything)."""
    root = tmp_path_factory.mktemp("trust")
    cache, keys = root / "cache", root / "keys"
    answer = _answer(_run(cache, keys))
    _answer(_run(cache, keys, LAGRANGE))
    return cache, keys, answer


@pytest.fixture
def copy(template, tmp_path):
    """This test's own copy of the warmed cache and key, and the answer."""
    cache, keys, answer = template
    shutil.copytree(cache, tmp_path / "cache", symlinks=True)
    shutil.copytree(keys, tmp_path / "keys", symlinks=True)
    return tmp_path / "cache", tmp_path / "keys", answer


def _generated(cache: Path, method: str = "dae") -> Path:
    """The command's generated system on the mechanism engine (the chain's record names it): the DAE in tree
    coordinates or the tree Lagrange system, its pins' coordinates the bars' absolute angles."""
    (path,) = cache.glob(f"{'treedae' if method == 'dae' else method}-mechanism-absolute-*.py")
    return path


def _numba_file(cache: Path, name: str, suffix: str) -> Path:
    (folder,) = (cache / "numba").glob("kernels-*")
    (path,) = [p for p in folder.glob(f"{name}-*{suffix}") if ".tmp." not in p.name]
    return path


def _settled(cache: Path, keys: Path, answer) -> None:
    """The next run is silent and right: whatever was discarded has been rebuilt for good."""
    again = _run(cache, keys)
    assert _answer(again) == answer and again.stderr == ""


class _WritesMarker:
    """Unpickling this creates the marker file: proof that a planted pickle ran."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (open, (str(self.marker), "w"))


def _planted_module(original: str, marker: Path) -> str:
    """The generated module with code that leaves a marker, ending in a valid SHA-256 line (the old check)."""
    body = original.rstrip("\n").rpartition("\n")[0]
    body = f"import pathlib\npathlib.Path({str(marker)!r}).write_text('ran')\n" + body
    return body + "\n# sha256: " + hashlib.sha256(body.encode()).hexdigest() + "\n"


# ----------------------------------------------------------------------------------------------- (a) the printed fix
def test_code_planted_while_the_folder_was_open_never_runs_after_chmod_700(copy, tmp_path):
    cache, keys, answer = copy
    cache.chmod(0o777)
    refused = _run(cache, keys)
    assert _answer(refused) == answer
    _one_line(refused, str(cache), "writable by group or others", f"chmod 700 {cache}")
    # meanwhile another user rewrites the generated module (a valid SHA-256 line), then the user applies the fix
    marker = tmp_path / "planted-module-ran"
    module = _generated(cache)
    module.write_text(_planted_module(module.read_text(), marker))
    cache.chmod(0o700)
    result = _run(cache, keys)
    assert _answer(result) == answer
    _one_line(result, str(module), "not trusted", "MAC")
    assert not marker.exists()
    _settled(cache, keys, answer)
    assert not marker.exists()


def test_a_module_tagged_with_another_key_or_renamed_from_another_entry_is_discarded(copy, tmp_path):
    cache, keys, answer = copy
    marker = tmp_path / "forged-module-ran"
    module = _generated(cache)
    body = _planted_module(module.read_text(), marker).rstrip("\n").rpartition("\n")[0]
    forged_tag = hmac.new(os.urandom(32), body.encode(), hashlib.sha256).hexdigest()  # the attacker's own key
    module.write_text(body + "\n# hmac-sha256: " + forged_tag + "\n")
    result = _run(cache, keys)
    assert _answer(result) == answer and not marker.exists()
    _one_line(result, "not trusted", "MAC differs")
    # a valid file of another mechanism under this one's name: the MAC binds the name
    module.write_bytes(_generated(cache, "lagrange").read_bytes())
    result = _run(cache, keys)
    assert _answer(result) == answer
    _one_line(result, str(module), "MAC differs")
    _settled(cache, keys, answer)


# ---------------------------------------------------------------------------------------------- (b) planted pickles
@pytest.mark.parametrize("tag", ["none", "another key", "old sha256 sidecar"])
@pytest.mark.parametrize("suffix", [".nbi", ".nbc"])
def test_a_planted_numba_pickle_is_never_unpickled(copy, tmp_path, suffix, tag):
    cache, keys, answer = copy
    marker = tmp_path / "planted-pickle-ran"
    target = _numba_file(cache, "system.solve_states", suffix)
    evil = pickle.dumps(_WritesMarker(marker))
    payload = pickle.dumps(numba.__version__, protocol=-1) + evil if suffix == ".nbi" else evil
    if tag == "another key":
        payload += MAC_MAGIC + hmac.new(os.urandom(32), payload, hashlib.sha256).hexdigest().encode() + b"\n"
    target.write_bytes(payload)
    if tag == "old sha256 sidecar":  # what the old check accepted
        info = target.stat()
        sidecar = target.with_name(target.name + ".sha256")
        sidecar.write_text(f"{hashlib.sha256(payload).hexdigest()} {info.st_size} {info.st_mtime_ns}\n")
    assert pickle.loads(evil) is not None and marker.exists()  # the payload does what it says when unpickled
    marker.unlink()
    result = _run(cache, keys)
    assert _answer(result) == answer
    _one_line(result, "system.solve_states", "not trusted")
    assert not marker.exists()
    _settled(cache, keys, answer)
    assert not marker.exists()


# ------------------------------------------------------------------------------------- (c) owner and mode of files
def _make_group_writable(path: Path) -> None:
    path.chmod(stat.S_IMODE(path.stat().st_mode) | 0o020)


def _give_away(path: Path) -> None:
    os.chown(path, NOBODY, NOBODY)


CASES = {
    "module group-writable": (lambda cache: _generated(cache), _make_group_writable, "writable by group or others"),
    "index group-writable": (lambda cache: _numba_file(cache, "system.solve_states", ".nbi"), _make_group_writable,
                             "writable by group or others"),
    "module of another user": (lambda cache: _generated(cache), _give_away, "owned by another user"),
    "data of another user": (lambda cache: _numba_file(cache, "system.solve_states", ".nbc"), _give_away,
                             "owned by another user"),
    "numba folder open": (lambda cache: cache / "numba", lambda path: path.chmod(0o777),
                          "writable by group or others"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_file_or_folder_of_another_user_or_writable_by_others_is_discarded(copy, case):
    cache, keys, answer = copy
    locate, damage, words = CASES[case]
    if damage is _give_away and not IS_ROOT:
        pytest.skip("giving a file to another user needs root")
    path = locate(cache)
    damage(path)
    result = _run(cache, keys)
    assert _answer(result) == answer
    _one_line(result, words)
    info = locate(cache).stat()  # rebuilt: this user's again, and private
    assert info.st_uid == os.getuid() and not stat.S_IMODE(info.st_mode) & 0o022
    _settled(cache, keys, answer)


# ---------------------------------------------------------------------------------------- (d) a damaged .pyc beside
def test_a_damaged_pyc_beside_a_generated_module_never_changes_the_result(copy, tmp_path):
    cache, keys, answer = copy
    module = _generated(cache)
    source = module.read_text()
    damaged = source.replace("fmul double", "fadd double", 1)  # 4 bytes of the IR string
    assert damaged != source and len(damaged) == len(source)
    # a .pyc that Python's import system takes for this module: same size and time as the real source
    stand_in = tmp_path / module.name
    stand_in.write_text(damaged)
    info = module.stat()
    os.utime(stand_in, ns=(info.st_atime_ns, info.st_mtime_ns))
    pyc = Path(importlib.util.cache_from_source(str(module)))
    py_compile.compile(str(stand_in), cfile=str(pyc), doraise=True)
    spec = importlib.util.spec_from_file_location("probe_of_the_stale_pyc", module)
    assert spec is not None and spec.loader is not None
    imported = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(imported)
    assert "fadd double" in imported.LLVM_IR and imported.LLVM_IR not in source  # an import would run the damage
    result = _run(cache, keys)
    assert _answer(result) == answer and result.stderr == ""
    assert not (cache / "__pycache__").exists()  # nor does a run leave bytecode of its own


# --------------------------------------------------------------------------------------------- (e) garbled tags
GARBLED = {
    "module MAC line not UTF-8": lambda cache: _garble_module_tag(_generated(cache)),
    "index tag not UTF-8": lambda cache: _garble_trailer(_numba_file(cache, "system.solve_states", ".nbi")),
    "data tag cut short": lambda cache: _cut_trailer(_numba_file(cache, "system.solve_states", ".nbc")),
}


def _garble_module_tag(path: Path) -> None:
    data = path.read_bytes()
    body = data.rstrip(b"\n").rpartition(b"\n")[0]
    path.write_bytes(body + b"\n# hmac-sha256: \xff\xfe\x80" + os.urandom(61) + b"\n")


def _garble_trailer(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[:-65] + b"\xff\xfe" + os.urandom(62) + b"\n")


def _cut_trailer(path: Path) -> None:
    path.write_bytes(path.read_bytes()[:-10])


@pytest.mark.parametrize("case", sorted(GARBLED))
def test_a_garbled_tag_is_rebuilt_with_one_line(copy, case):
    cache, keys, answer = copy
    GARBLED[case](cache)
    result = _run(cache, keys)
    assert _answer(result) == answer
    _one_line(result, "not trusted")
    _settled(cache, keys, answer)


def test_a_garbled_sidecar_left_by_the_old_design_is_never_read(copy):
    cache, keys, answer = copy
    index = _numba_file(cache, "system.solve_states", ".nbi")
    index.with_name(index.name + ".sha256").write_bytes(b"\xff\xfe\x00" + os.urandom(80))
    result = _run(cache, keys)
    assert _answer(result) == answer and result.stderr == ""


# --------------------------------------------------------------------------------------------------- the key
def test_the_key_is_made_once_private_and_outside_the_cache(template):
    cache, keys, _ = template
    key = keys / "cache.key"
    info = key.stat()
    assert info.st_size == 32 and stat.S_IMODE(info.st_mode) == 0o600 and info.st_uid == os.getuid()
    assert not stat.S_IMODE(keys.stat().st_mode) & 0o077
    assert cache not in key.parents and not list(cache.rglob("*.key"))


KEY_FAULTS = {
    "readable by others": (lambda keys: (keys / "cache.key").chmod(0o644), "readable or writable by others"),
    "of another user": (lambda keys: os.chown(keys / "cache.key", NOBODY, NOBODY), "owned by another user"),
    "its folder open": (lambda keys: keys.chmod(0o777), "writable by group or others"),
    "too short": (lambda keys: (keys / "cache.key").write_bytes(b"short"), "holds 5 bytes"),
}


@pytest.mark.parametrize("fault", sorted(KEY_FAULTS))
def test_a_key_others_could_read_or_replace_is_refused_for_a_private_temporary_cache(copy, fault):
    cache, keys, answer = copy
    damage, words = KEY_FAULTS[fault]
    if fault == "of another user" and not IS_ROOT:
        pytest.skip("giving a file to another user needs root")
    before = sorted(path.name for path in cache.rglob("*"))
    damage(keys)
    result = _run(cache, keys)
    assert _answer(result) == answer
    _one_line(result, "cache key", words, "private temporary cache")
    assert sorted(path.name for path in cache.rglob("*")) == before  # the cache folder was not used


def test_processes_making_the_key_at_once_all_get_the_same_complete_key(tmp_path):
    keys = tmp_path / "keys"
    child = ("import sys; from pathlib import Path; from physics.cache_folder import _key_problem; "
             "key, problem = _key_problem(Path(sys.argv[1]) / 'cache.key'); "
             "print(key.hex() if key else 'refused: ' + str(problem))")
    racers = [subprocess.Popen([sys.executable, "-c", child, str(keys)], stdout=subprocess.PIPE, text=True)
              for _ in range(6)]
    answers = {racer.communicate(timeout=120)[0].strip() for racer in racers}
    assert len(answers) == 1, answers
    (answer,) = answers
    assert answer == (keys / "cache.key").read_bytes().hex() and len(answer) == 64
    assert sorted(path.name for path in keys.iterdir()) == ["cache.key"]  # no temporary file left behind


def test_a_key_that_is_a_symlink_is_refused(tmp_path):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.write_bytes(os.urandom(32))
    elsewhere.chmod(0o600)
    keys = tmp_path / "keys"
    keys.mkdir(mode=0o700)
    (keys / "cache.key").symlink_to(elsewhere)
    child = ("import sys; from pathlib import Path; from physics.cache_folder import _key_problem; "
             "print(_key_problem(Path(sys.argv[1]) / 'cache.key'))")
    result = subprocess.run([sys.executable, "-c", child, str(keys)], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("(None, ") and "cannot be read" in result.stdout
