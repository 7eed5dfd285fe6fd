"""A newcomer's first steps, as the README and CONTRIBUTING.md give them.

* The README's ``python -m physics`` examples (its "Command line" block) run as written, with the venv's
  interpreter for ``python`` (the README says to activate .venv or prefix ``.venv/bin/``) and every ``--out``
  moved into a temporary folder; each exits 0 and writes what it names. Left out, with the reason: the examples
  in :data:`SKIPPED`, which take minutes of CPU time (each has its own tests on short horizons).
* The example files the README names ship with the repository.
* After ``.venv/bin/pre-commit install`` a commit works without the venv active: the hooks name the venv's tools.
"""

from __future__ import annotations

import shlex
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from benchmarks import speed

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"

SKIPPED = {
    "warm": "derives and compiles every preset's mechanisms (minutes on an empty cache; tests/physics/test_cli.py)",
    "bench": "the work-precision study (minutes; tests/physics/test_bench.py runs it on short horizons)",
    "physics.stability": "the stability study's figures (minutes; tests/physics/test_stability.py runs it short)",
    "chaos-map": "a 400x400 map of runs (minutes; tests/physics/test_chaos.py runs small maps)",
    "ensemble": "1000 copies for 30 s (about 20 CPU s; tests/physics/test_ensemble.py runs short fans)",
}
"""First word after ``python -m physics`` (or the module) -> why the example is not run here."""


def command_line_block() -> list[str]:
    """The commands of the README's "Command line" section (its first fenced bash block), comments removed."""
    text = README.read_text(encoding="utf-8")
    section = text.split("\n## Command line\n", 1)[1].split("\n## ", 1)[0]
    block = section.split("```bash\n", 1)[1].split("```", 1)[0]
    return [" ".join(shlex.split(line, comments=True)) for line in block.splitlines() if line.strip()]


def physics_examples() -> list[str]:
    return [line for line in command_line_block() if line.startswith(("python -m physics ", "python -m physics."))]


def example_key(line: str) -> str:
    words = shlex.split(line)
    return words[2] if words[2] != "physics" else words[3]


def with_outputs_in(words: list[str], folder: Path) -> tuple[list[str], list[Path]]:
    """``words`` with every ``--out PATH`` replaced by ``folder / name-of-PATH``, and those paths."""
    words, outputs = list(words), []
    for index, word in enumerate(words[:-1]):
        if word == "--out":
            outputs.append(folder / Path(words[index + 1]).name)
            words[index + 1] = str(outputs[-1])
    return words, outputs


def test_the_readme_block_is_read():
    examples = physics_examples()
    assert len(examples) >= 15, examples
    keys = {example_key(line) for line in examples}
    assert set(SKIPPED) <= keys, f"SKIPPED names examples the README no longer has: {sorted(set(SKIPPED) - keys)}"
    assert all("[" not in line for line in examples), "an example holds [optional] notation, not a runnable command"


def test_the_files_the_readme_names_ship():
    for line in physics_examples():
        words = shlex.split(line)
        for flag in ("--input", "--mechanism"):
            if flag in words:
                named = ROOT / words[words.index(flag) + 1]
                assert named.is_file(), f"the README's `{line}` names {named}, which does not ship"


def test_the_readme_says_to_use_the_venv():
    text = README.read_text(encoding="utf-8")
    section = text.split("\n## Command line\n", 1)[1].split("```bash", 1)[0]
    assert "source .venv/bin/activate" in section and ".venv/bin/" in section, (
        "the Command line section must say to activate .venv (or prefix .venv/bin/) before its bare `python` lines"
    )


@pytest.mark.slow  # each example is a process of its own (a few seconds each on a warm cache)
@pytest.mark.parametrize("line", physics_examples())
def test_readme_physics_example_runs_as_written(line, tmp_path):
    key = example_key(line)
    if key in SKIPPED:
        pytest.skip(SKIPPED[key])
    words, outputs = with_outputs_in(shlex.split(line), tmp_path)
    words[0] = sys.executable
    result = subprocess.run(words, cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, f"{line}\n{result.stderr}"
    for output in outputs:
        assert output.exists(), f"{line} did not write {output.name}"
        assert output.stat().st_size > 0 or any(output.iterdir()), f"{line} wrote an empty {output.name}"
    if not outputs:
        assert result.stdout.strip(), f"{line} printed nothing"


def test_pre_commit_hooks_run_without_the_venv_active(tmp_path):
    """pre-commit runs hooks with the PATH it was given; a hook whose entry is a bare `ruff` is refused
    ("Executable `ruff` not found") unless the venv is active. Every entry names the tool inside .venv/."""
    hooks = [hook for repo in yaml.safe_load((ROOT / ".pre-commit-config.yaml").read_text(encoding="utf-8"))["repos"]
             for hook in repo["hooks"]]
    assert hooks
    for hook in hooks:
        tool = hook["entry"].split()[0]
        assert tool.startswith(".venv/bin/") and hook["language"] == "system", hook
    if Path(sys.prefix) != ROOT / ".venv":
        pytest.skip(f"the tests run from {sys.prefix}, not the README's .venv: the hooks' tools are not there")
    for hook in hooks:
        assert (ROOT / hook["entry"].split()[0]).exists(), hook["entry"]
    env = {"HOME": str(tmp_path), "PATH": "/usr/bin:/bin", "PRE_COMMIT_HOME": str(tmp_path / "pre-commit")}
    for hook_id in ("ruff", "deptry"):  # the quick ones; mypy and import-linter are called the same way
        result = subprocess.run([str(ROOT / ".venv" / "bin" / "pre-commit"), "run", hook_id, "--files",
                                 "app/resources.py"], cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
        assert result.returncode == 0 and "Passed" in result.stdout, result.stdout + result.stderr


def test_the_speed_benchmark_writes_into_a_private_folder_by_default(tmp_path, monkeypatch, capsys):
    """``python -m benchmarks.speed`` without --out used a fixed name in the shared temporary folder (another
    user could plant a file or a link there). Now each run gets a new folder of its own (mode 0700)."""
    monkeypatch.setattr(speed.tempfile, "tempdir", str(tmp_path))
    assert speed.main(["--sections", ","]) == 0  # no section: the run writes its header and machine only
    written = Path(capsys.readouterr().out.strip().splitlines()[-1].removeprefix("wrote "))
    assert written.name == "speed.json" and written.parent.parent == tmp_path
    assert written.parent.stat().st_mode & 0o777 == 0o700
    assert '"command": "python -m benchmarks.speed --sections ,"' in written.read_text()
    assert speed.default_out().parent != written.parent
