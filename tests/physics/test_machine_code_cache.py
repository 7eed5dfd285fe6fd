"""The machine code of generated LLVM IR is compiled once per installation and loaded only when this user's
Linkage Lab wrote it (physics/codegen/machine_code.py).

Each case runs a small child process that compiles one IR module through :class:`physics.codegen.native.NativeModule`
(the path every generated system takes) and calls it: a second process loads the object file instead of
compiling; a damaged, foreign, open or re-keyed file is discarded with one line on stderr, compiled again, and
the answer is the same bits. The module calls ``llvm.sin.f64``, so a loaded object must have its call into the
C library resolved as a compiled one does.
"""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from physics import cache_folder
from physics.codegen import machine_code

IS_ROOT = hasattr(os, "geteuid") and os.geteuid() == 0
NOBODY = 65534
IR = """declare double @llvm.sin.f64(double)

define double @rhs(double* noalias %y, double* noalias %params, double* noalias %dydt) {
entry:
  %a = load double, double* %y
  %p = load double, double* %params
  %b = call double @llvm.sin.f64(double %a)
  %c = fmul double %b, %p
  store double %c, double* %dydt
  ret double 2.5
}
"""
CHILD = r"""
import ctypes, json, sys
from physics import cache_folder
from physics.codegen import machine_code
from physics.codegen.native import NativeModule

module = NativeModule(sys.argv[1])
function = ctypes.CFUNCTYPE(ctypes.c_double, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p)(module.addresses["rhs"])
y, params, out = (ctypes.c_double * 1)(0.5), (ctypes.c_double * 1)(3.0), (ctypes.c_double * 1)()
returned = function(y, params, out)
print(json.dumps({"counts": machine_code.COUNTS, "value": out[0].hex(), "returned": returned,
                  "names": sorted(module.addresses), "numba": "numba" in sys.modules}))
"""
EXPECTED = {"value": (3.0 * __import__("math").sin(0.5)).hex(), "returned": 2.5, "names": ["rhs"]}


def _run(cache: Path, keys: Path, ir: str = IR) -> tuple[dict, list[str]]:
    env = dict(os.environ, LINKAGE_LAB_CACHE=str(cache), LINKAGE_LAB_KEY_DIR=str(keys))
    result = subprocess.run([sys.executable, "-c", CHILD, ir], capture_output=True, text=True, env=env, timeout=300)
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout.strip().splitlines()[-1])
    if ir == IR:
        assert {key: report[key] for key in EXPECTED} == EXPECTED
    assert report["numba"] is False  # compiling or loading a generated module needs no numba
    return report, [line for line in result.stderr.splitlines() if line.strip()]


def _object_file(cache: Path) -> Path:
    return cache / machine_code.FOLDER / machine_code.object_name(IR, "system-O2")


def _loaded_quietly(cache: Path, keys: Path) -> None:
    report, lines = _run(cache, keys)
    assert report["counts"] == {"compiled": 0, "loaded": 1} and lines == []


@pytest.fixture
def warmed(tmp_path):
    """A cache holding the module's object file, written by one process that compiled it."""
    cache, keys = tmp_path / "cache", tmp_path / "keys"
    report, lines = _run(cache, keys)
    assert report["counts"] == {"compiled": 1, "loaded": 0} and lines == []
    return cache, keys


def test_a_second_process_loads_the_machine_code_without_compiling(warmed):
    cache, keys = warmed
    info = _object_file(cache).stat()
    assert stat.S_IMODE(info.st_mode) == 0o600 and info.st_uid == os.getuid()
    assert stat.S_IMODE((cache / machine_code.FOLDER).stat().st_mode) == 0o700
    _loaded_quietly(cache, keys)


DAMAGES = {
    "truncated": lambda data: data[: len(data) // 2],
    "empty": lambda data: b"",
    "garbage": lambda data: os.urandom(max(len(data), 64)),
    "flipped": lambda data: data[:100] + bytes([data[100] ^ 0xFF]) + data[101:],
    "without its tag": lambda data: data[: data.rindex(cache_folder.MAC_MAGIC)],
}


@pytest.mark.parametrize("damage", sorted(DAMAGES))
def test_a_damaged_object_file_is_rebuilt_with_one_line(warmed, damage):
    cache, keys = warmed
    path = _object_file(cache)
    path.write_bytes(DAMAGES[damage](path.read_bytes()))
    report, lines = _run(cache, keys)
    assert report["counts"] == {"compiled": 1, "loaded": 0}
    assert len(lines) == 1 and lines[0].startswith("linkage-lab: machine-code cache file"), lines
    assert "discarded and rebuilt" in lines[0]
    _loaded_quietly(cache, keys)


def test_an_object_file_written_under_another_key_is_refused(warmed, tmp_path):
    cache, keys = warmed
    report, lines = _run(cache, tmp_path / "other-keys")
    assert report["counts"] == {"compiled": 1, "loaded": 0}
    assert len(lines) == 1 and "MAC differs" in lines[0], lines
    _loaded_quietly(cache, tmp_path / "other-keys")


def test_another_modules_object_file_under_this_ones_name_is_refused(warmed):
    """The tag binds the bytes to their file name: another module's valid object file copied under this
    module's name (what a planted copy would be) is not loaded."""
    cache, keys = warmed
    path = _object_file(cache)
    other_ir = IR.replace("ret double 2.5", "ret double 1.5")
    report, _ = _run(cache, keys, other_ir)
    assert report["counts"] == {"compiled": 1, "loaded": 0} and report["returned"] == 1.5
    other = cache / machine_code.FOLDER / machine_code.object_name(other_ir, "system-O2")
    path.write_bytes(other.read_bytes())
    report, lines = _run(cache, keys)
    assert report["counts"] == {"compiled": 1, "loaded": 0}
    assert len(lines) == 1 and "MAC differs" in lines[0], lines
    _loaded_quietly(cache, keys)


def _give_away(path: Path) -> None:
    os.chown(path, NOBODY, NOBODY)


def _make_group_writable(path: Path) -> None:
    path.chmod(stat.S_IMODE(path.stat().st_mode) | 0o020)


@pytest.mark.parametrize("case", ["group-writable", "of another user"])
def test_an_object_file_of_another_user_or_writable_by_others_is_refused(warmed, case):
    if case == "of another user" and not IS_ROOT:
        pytest.skip("giving a file to another user needs root")
    cache, keys = warmed
    path = _object_file(cache)
    (_give_away if case == "of another user" else _make_group_writable)(path)
    report, lines = _run(cache, keys)
    assert report["counts"] == {"compiled": 1, "loaded": 0}
    words = "owned by another user" if case == "of another user" else "writable by group or others"
    assert len(lines) == 1 and words in lines[0], lines
    info = _object_file(cache).stat()
    assert info.st_uid == os.getuid() and stat.S_IMODE(info.st_mode) == 0o600
    _loaded_quietly(cache, keys)


@pytest.mark.parametrize("case", ["open to others", "of another user"])
def test_a_machine_code_folder_not_private_is_discarded_with_one_line(warmed, case):
    if case == "of another user" and not IS_ROOT:
        pytest.skip("giving a folder to another user needs root")
    cache, keys = warmed
    folder = cache / machine_code.FOLDER
    if case == "of another user":
        _give_away(folder)
    else:
        folder.chmod(0o777)
    report, lines = _run(cache, keys)
    assert report["counts"] == {"compiled": 1, "loaded": 0}  # its files went with it
    assert len(lines) == 1 and "machine-code cache: folder" in lines[0], lines
    info = folder.stat()
    assert info.st_uid == os.getuid() and stat.S_IMODE(info.st_mode) == 0o700
    _loaded_quietly(cache, keys)


def test_the_file_name_changes_with_the_ir_and_with_what_is_done_to_it():
    name = machine_code.object_name(IR, "system-O2")
    assert name != machine_code.object_name(IR + "\n", "system-O2")
    assert name != machine_code.object_name(IR, "driver-O0")
    assert name == machine_code.object_name(IR, "system-O2")


def test_defined_functions_are_read_from_the_ir_text():
    text = IR + '\ndefine i64 @"integrate_rk45"(i8* %layout) {\nentry:\n  ret i64 0\n}\n'
    assert machine_code.defined_functions(text) == {"rhs", "integrate_rk45"}
