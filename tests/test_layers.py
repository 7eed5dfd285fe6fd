"""The import-layer contracts of pyproject.toml hold, and they bite: a copy of the code where the core imports the
app (the mistake they exist to catch) is reported by ``lint-imports`` and fails it, naming the import."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LINT_IMPORTS = shutil.which("lint-imports", path=str(Path(sys.executable).parent)) or shutil.which("lint-imports")

pytestmark = pytest.mark.skipif(LINT_IMPORTS is None, reason="import-linter is not installed (the 'lint' extra)")


def _copy_project(target: Path) -> None:
    """physics/ and app/ sources (no caches) and pyproject.toml (which holds the contracts), in ``target``."""
    for package in ("physics", "app"):
        shutil.copytree(ROOT / package, target / package, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    shutil.copy(ROOT / "pyproject.toml", target / "pyproject.toml")


def _lint_imports(folder: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(folder))
    return subprocess.run([LINT_IMPORTS, "--config", str(folder / "pyproject.toml"), "--no-cache"], cwd=folder,
                          env=env, capture_output=True, text=True, timeout=300)


def test_the_contracts_hold_on_the_code_as_it_is(tmp_path):
    _copy_project(tmp_path)
    result = _lint_imports(tmp_path)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "BROKEN" not in result.stdout and " KEPT" in result.stdout


@pytest.mark.parametrize(("module", "line", "broken"), [
    ("physics/kinematics.py", "import app.server", "The core never imports a study, the command line or the app"),
    ("physics/simulate/run.py", "from ..studies import report", "The core never imports a study"),
    ("physics/studies/report.py", "import viser", "physics never imports the app or viser"),
    ("app/scene.py", "from physics.kernels import explicit_rk", "The app uses only physics' public API"),
    ("app/readout.py", "import physics.mechanism.engine", "The app uses only physics' public API"),
    ("physics/mechanism/engine.py", "from ..outputs import write_output", "The core never imports a study"),
])
def test_a_deliberate_violation_fails_the_contract(tmp_path, module, line, broken):
    _copy_project(tmp_path)
    path = tmp_path / module
    path.write_text(path.read_text() + f"\n{line}  # deliberate violation\n")
    result = _lint_imports(tmp_path)
    assert result.returncode != 0, result.stdout
    assert "BROKEN" in result.stdout
    assert broken in result.stdout.replace("\n", " ")
    violator = module.removesuffix(".py").replace("/", ".")
    assert violator in result.stdout, result.stdout
