"""The derivation cache: reused across processes without sympy, private, rebuilt when corrupted or truncated."""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest

# Every test starts processes on a fresh cache folder, so each compiles the kernels again (20-50 s apiece).
pytestmark = pytest.mark.slow

PROBE = r"""
import json, sys
from physics.codegen import load_compiled
c = load_compiled("lagrange", 2, False)
acc, cond = c.accel([0.3, -0.2], [0.1, 0.0], [1, 1, 0.5, 0.5, 1, 1, 0.2, 0.3, 1.0, 0, 0, 0])
print(json.dumps({"from_cache": c.from_cache, "sympy": "sympy" in sys.modules, "path": str(c.path),
                  "acc": list(acc)}))
"""


def _probe(env):
    result = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, env=env, timeout=300)
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout.strip().splitlines()[-1])


def _env(**extra):
    env = dict(os.environ)
    env.pop("LINKAGE_LAB_CACHE", None)
    env.update(extra)
    return env


def test_second_run_reuses_the_cache_without_sympy(tmp_path):
    env = _env(LINKAGE_LAB_CACHE=str(tmp_path / "cache"))
    first = _probe(env)
    second = _probe(env)
    assert first["from_cache"] is False and first["sympy"] is True
    assert second["from_cache"] is True and second["sympy"] is False
    assert first["acc"] == second["acc"]
    folder = tmp_path / "cache"
    assert stat.S_IMODE(folder.stat().st_mode) == 0o700
    assert stat.S_IMODE(Path(first["path"]).stat().st_mode) == 0o600


def test_xdg_cache_home_is_respected_and_override_wins(tmp_path):
    xdg = tmp_path / "xdg"
    entry = _probe(_env(XDG_CACHE_HOME=str(xdg)))
    assert Path(entry["path"]).parent == xdg / "linkage-lab"
    override = tmp_path / "override"
    entry = _probe(_env(XDG_CACHE_HOME=str(xdg), LINKAGE_LAB_CACHE=str(override)))
    assert Path(entry["path"]).parent == override


def test_truncated_entry_is_rebuilt(tmp_path):
    env = _env(LINKAGE_LAB_CACHE=str(tmp_path))
    first = _probe(env)
    path = Path(first["path"])
    text = path.read_text()
    path.write_text(text[: len(text) // 2])
    again = _probe(env)
    assert again["from_cache"] is False
    assert again["acc"] == first["acc"]
    assert _probe(env)["from_cache"] is True


def test_corrupted_entry_is_rebuilt(tmp_path):
    env = _env(LINKAGE_LAB_CACHE=str(tmp_path))
    first = _probe(env)
    path = Path(first["path"])
    # an edit that still parses as Python (a wrong number) must not be trusted either
    text = path.read_text().replace("fmul double", "fadd double", 1)
    path.write_text(text)
    again = _probe(env)
    assert again["from_cache"] is False
    assert again["acc"] == first["acc"]
