"""The distribution behaves like a package: what it declares, what it installs, and that the installed copy runs.

* Every third-party module the code under app/ and physics/ imports is declared in pyproject.toml: in the
  runtime dependencies, or (imported lazily, inside a function) in the extra that names it. deptry checks the
  same from the lint step; this test says which import lacks its declaration.
* The wheel installs exactly two top-level packages, ``app`` and ``physics`` (PyPI has unrelated distributions
  named ``static`` and ``benchmarks``), with ``static/`` inside as ``app/static``, ``py.typed`` in both, the
  LICENSE and an SPDX license expression, and the version written once (``physics.__version__``).
* Installed from that wheel into a clean venv and run from outside the repository, ``python -m physics
  presets`` works and ``python -m app`` serves its page (the static files found through importlib.resources).
"""

from __future__ import annotations

import ast
import email
import importlib.metadata
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import time
import tomllib
import urllib.request
import venv
import zipfile
from pathlib import Path

import pytest

import physics

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
FIRST_PARTY = {"app", "physics"}
OPTIONAL_IMPORTS = {"playwright": ("snapshot", "playwright"), "distributed": ("dask", "distributed"),
                    "IPython": ("notebook", "ipython")}
"""Modules the code imports only inside the function that needs them: the extra and the requirement in it that
brings each. Such a module may be absent from the test venv (IPython: Jupyter brings it); it must then be
imported lazily everywhere and its requirement must be in its extra."""


# ------------------------------------------------------------------------------------------ declared modules
def requirement_name(requirement: str) -> str:
    """``"numba>=0.61"`` -> ``"numba"``, normalised as PEP 503 does (``Pillow`` and ``pillow`` are one)."""
    match = re.match(r"[A-Za-z0-9][A-Za-z0-9._-]*", requirement.strip())
    assert match, requirement
    return re.sub(r"[-_.]+", "-", match.group(0)).lower()


def third_party_imports(folder: Path, root: Path = ROOT) -> dict[str, list[tuple[str, bool]]]:
    """``{top-level module: [(file:line, at module level), ...]}`` for every import under ``folder`` of a module
    that is neither the standard library nor first-party (places relative to ``root``)."""
    found: dict[str, list[tuple[str, bool]]] = {}
    for path in sorted(folder.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        at_module_level = {id(node) for node in tree.body}
        for statement in tree.body:  # imports guarded by `if`/`try` at module level still load with the module
            if isinstance(statement, (ast.If, ast.Try)):
                at_module_level |= {id(node) for node in ast.walk(statement)}
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                top = name.split(".")[0]
                if top in sys.stdlib_module_names or top in FIRST_PARTY or top == "__future__":
                    continue
                where = f"{path.relative_to(root).as_posix()}:{node.lineno}"
                found.setdefault(top, []).append((where, id(node) in at_module_level))
    return found


def test_every_imported_module_is_declared():
    runtime = {requirement_name(item) for item in PYPROJECT["project"]["dependencies"]}
    extras = {extra: {re.sub(r"[<>=!~;\s].*", "", item) for item in items}  # name[extras], no version
              for extra, items in PYPROJECT["project"]["optional-dependencies"].items()}
    distributions = importlib.metadata.packages_distributions()
    imports: dict[str, list[tuple[str, bool]]] = {}
    for folder in sorted(FIRST_PARTY):
        for name, places in third_party_imports(ROOT / folder).items():
            imports.setdefault(name, []).extend(places)
    assert {"numba", "llvmlite", "PIL", "tqdm", "websockets", "msgspec", "zstandard", "annotated_types"} <= set(imports), (
        "the scan no longer sees imports the code is known to make"
    )
    problems = []
    for module, places in sorted(imports.items()):
        owners = {requirement_name(name) for name in distributions.get(module, [])}
        if not owners and module in OPTIONAL_IMPORTS:
            owners = {OPTIONAL_IMPORTS[module][1]}  # not installed here: the table names its distribution
        if not owners:
            problems.append(f"{module} (imported at {places[0][0]}) is not installed, so no distribution provides it")
        elif owners & runtime:
            continue
        elif module in OPTIONAL_IMPORTS and OPTIONAL_IMPORTS[module][1] in extras[OPTIONAL_IMPORTS[module][0]]:
            eager = [where for where, module_level in places if module_level]
            if eager:
                problems.append(f"{module} comes with the '{OPTIONAL_IMPORTS[module][0]}' extra only, but "
                                f"{eager[0]} imports it when the module loads")
        else:
            problems.append(f"{module} (distribution {', '.join(sorted(owners))}, imported at {places[0][0]}) is "
                            "not in [project].dependencies of pyproject.toml")
    assert not problems, "\n".join(problems)


def test_the_import_scan_tells_module_level_from_lazy(tmp_path):
    """The scan that feeds the check above: the standard library and first-party imports are left out; a module
    imported inside a function is marked lazy, one imported at the top (or under a module-level ``try``) is not."""
    (tmp_path / "probe.py").write_text(
        "import zstandard\nimport physics.model\ntry:\n    import tqdm\nexcept ImportError:\n    tqdm = None\n"
        "def f():\n    import playwright.sync_api\n    import json\n", encoding="utf-8")
    found = third_party_imports(tmp_path, root=tmp_path)
    assert found == {"zstandard": [("probe.py:1", True)], "tqdm": [("probe.py:4", True)],
                     "playwright": [("probe.py:8", False)]}


def test_numba_floor_brings_the_llvmlite_pass_manager():
    """physics/codegen/native.py calls llvmlite's new pass manager (0.44+); numba 0.61 is the first release
    whose llvmlite is 0.44 (numba 0.60 pins llvmlite < 0.44). The declared floors say so."""
    declared = {requirement_name(item): item for item in PYPROJECT["project"]["dependencies"]}
    assert "create_pass_builder" in (ROOT / "physics" / "codegen" / "native.py").read_text(encoding="utf-8")
    assert re.search(r">=\s*0\.(4[4-9]|[5-9]\d)", declared["llvmlite"]), declared["llvmlite"]
    assert re.search(r">=\s*0\.(6[1-9]|[7-9]\d)", declared["numba"]), declared["numba"]


def test_setuptools_packages_are_the_folders():
    """pyproject lists the packages by hand (``app.static`` is mapped to the top-level static/): every folder
    of app/ and physics/ with an ``__init__.py`` is in the list, and nothing else but ``app.static``."""
    folders = {".".join(path.parent.relative_to(ROOT).parts)
               for top in FIRST_PARTY for path in (ROOT / top).rglob("__init__.py")}
    listed = set(PYPROJECT["tool"]["setuptools"]["packages"])
    assert listed == folders | {"app.static"}, sorted(listed ^ (folders | {"app.static"}))
    assert PYPROJECT["tool"]["setuptools"]["package-dir"] == {"app.static": "static"}


# ------------------------------------------------------------------------------------------------- the wheel
@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The project built as a wheel without build isolation (no network), from a copy that also holds
    benchmarks/ and tests/, so that leaving them out is the configuration's doing."""
    folder = tmp_path_factory.mktemp("wheel")
    source = folder / "source"
    source.mkdir()
    for item in ("physics", "app", "benchmarks", "static", "tests"):
        shutil.copytree(ROOT / item, source / item, ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "output"))
    for item in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy(ROOT / item, source / item)
    result = subprocess.run([sys.executable, "-m", "pip", "wheel", str(source), "--no-deps", "--no-build-isolation",
                             "-w", str(folder / "dist"), "-q"], capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    return next((folder / "dist").glob("*.whl"))


@pytest.mark.slow  # builds a wheel (a few seconds)
def test_the_wheel_installs_app_and_physics_only_with_their_data(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    top_level = {name.split("/")[0] for name in names if not name.split("/")[0].endswith(".dist-info")}
    assert top_level == {"app", "physics"}, sorted(top_level)
    static_files = {"app/static/" + p.relative_to(ROOT / "static").as_posix()
                    for p in (ROOT / "static").rglob("*") if p.is_file()}
    assert {"app/static/page.html", "app/static/help.md"} <= static_files <= names, sorted(static_files - names)
    assert {"app/py.typed", "physics/py.typed"} <= names
    packages = {path.parent.relative_to(ROOT).as_posix() + "/__init__.py"
                for top in FIRST_PARTY for path in (ROOT / top).rglob("__init__.py")}
    assert packages <= names, sorted(packages - names)
    for module in ("physics/studies/report.py", "physics/registry.py", "physics/kernels/abi.py",
                   "physics/simulate/scipy_backend.py", "app/session.py", "app/resources.py"):
        assert module in names, module
    dist_info = f"linkage_lab-{physics.__version__}.dist-info"
    assert f"{dist_info}/licenses/LICENSE" in names
    metadata = email.message_from_bytes(zipfile.ZipFile(wheel).read(f"{dist_info}/METADATA"))
    assert metadata["Version"] == physics.__version__
    assert metadata["License-Expression"] == "MIT"
    assert metadata["Requires-Python"] == PYPROJECT["project"]["requires-python"]
    assert "Typing :: Typed" in metadata.get_all("Classifier")
    runtime = {requirement_name(item) for item in PYPROJECT["project"]["dependencies"]}
    required = {requirement_name(item) for item in metadata.get_all("Requires-Dist") if "extra ==" not in item}
    assert required == runtime


def clean_venv(folder: Path) -> Path:
    """A new venv whose own site-packages comes first and which borrows the running venv's packages after it
    (a .pth line), so the wheel can be installed with --no-deps and no network. The running venv's editable
    install is not active there (its .pth hook runs only in that venv's own site-packages)."""
    venv.EnvBuilder(with_pip=False).create(folder)
    python = folder / "bin" / "python"
    site_packages = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                                   capture_output=True, text=True, check=True).stdout.strip()
    (Path(site_packages) / "zz_borrowed_packages.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    return python


@pytest.mark.slow  # a wheel, a venv, an install and the app's start
def test_the_installed_wheel_runs_the_cli_and_the_app(wheel, tmp_path):
    python = clean_venv(tmp_path / "venv")
    install = subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps",
                              "--no-index", "-q", str(wheel)], capture_output=True, text=True, timeout=300)
    assert install.returncode == 0, install.stderr
    outside = tmp_path / "elsewhere"  # not the repository: `python -m` puts the working folder first on sys.path
    outside.mkdir()
    env = {key: value for key, value in os.environ.items() if key not in ("PYTHONPATH", "PYTHONHOME")}
    where = subprocess.run([str(python), "-c", "import app, physics, app.resources as r, app.session as c; "
                            "print(app.__file__); print(physics.__file__); print(r.static_folder()); "
                            "print((c.STATIC / 'help.md').is_file())"],
                           cwd=outside, env=env, capture_output=True, text=True, timeout=120)
    assert where.returncode == 0, where.stderr
    app_file, physics_file, static, help_found = where.stdout.split()
    installed = str(tmp_path / "venv")
    assert app_file.startswith(installed) and physics_file.startswith(installed), where.stdout
    assert static.startswith(installed) and static.endswith("app/static"), static
    assert help_found == "True", "the Help tab's text (app/static/help.md) is missing from the installed copy"

    presets = subprocess.run([str(python), "-m", "physics", "presets"], cwd=outside, env=env,
                             capture_output=True, text=True, timeout=300)
    assert presets.returncode == 0, presets.stderr
    assert "triple-a" in presets.stdout and "four-bar" in presets.stdout, presets.stdout

    server = subprocess.Popen([str(python), "-m", "app", "--port", "0", "--processes", "1"], cwd=outside, env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        assert server.stdout is not None
        lines: list[str] = []
        url = None
        while url is None:
            line = server.stdout.readline()
            assert line, f"the app ended before serving: {''.join(lines)}"
            lines.append(line)
            match = re.search(r"serving at (http://\S+)", line)
            url = match.group(1) if match else None
        deadline = time.monotonic() + 120  # a bound on a hang, not a speed figure
        while True:
            try:
                with urllib.request.urlopen(url, timeout=30) as response:
                    status, page = response.status, response.read().decode("utf-8", "replace")
                break
            except OSError:
                assert time.monotonic() < deadline, f"no answer from {url}"
                time.sleep(0.5)
        assert status == 200
        assert "linkage-lab-loading" in page, "the page lacks the loading screen of app/static/page.html"
    finally:
        server.terminate()
        try:
            server.wait(timeout=30)
        except subprocess.TimeoutExpired:
            server.kill()
            server.wait()
