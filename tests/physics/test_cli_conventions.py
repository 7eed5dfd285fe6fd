"""The command-line conventions of both commands (issue 25): every subcommand in ``--help``, ``--version`` from
the one version source, and ``usage:`` naming the command that was typed."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import physics
from physics import cli
from physics.program import program_name

ROOT = Path(__file__).resolve().parents[2]
VENV_BIN = Path(sys.executable).parent


def run(*command: str) -> subprocess.CompletedProcess:
    environment = {**os.environ, "COLUMNS": "200"}
    return subprocess.run(command, capture_output=True, text=True, cwd=ROOT, env=environment, timeout=300)


def dispatched_commands() -> set[str]:
    """Every subcommand main() can run: the parser's own and those dispatched by name before parsing."""
    parser = cli.build_parser()
    (subparsers,) = [a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction"]
    return set(subparsers.choices) | set(cli._EXTERNAL)


def test_help_table_names_exactly_the_dispatched_commands():
    assert set(cli.EXTERNAL_HELP) == set(cli._EXTERNAL)
    assert all(description.strip() and "\n" not in description for description in cli.EXTERNAL_HELP.values())


def test_full_help_lists_every_subcommand_with_a_description():
    result = run(sys.executable, "-m", "physics", "--help")
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("usage: python -m physics ")
    listed = {line.split()[0] for line in result.stdout.splitlines() if line.startswith("    ") and line.split()}
    commands = dispatched_commands()
    assert len(commands) >= 13
    assert commands <= listed, sorted(commands - listed)
    for name, description in cli.EXTERNAL_HELP.items():
        assert f"{name}" in result.stdout and description in " ".join(result.stdout.split())


def test_help_does_not_import_the_external_commands():
    code = ("import sys, contextlib, io\nfrom physics import cli\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n"
            "    try: cli.main(['--help'])\n    except SystemExit: pass\n"
            "print(sorted(m for m, _ in cli._EXTERNAL.values() if m in sys.modules))")
    result = run(sys.executable, "-c", code)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "[]"


def test_a_listed_external_command_runs_its_own_module(capsys):
    # main() dispatches these before parsing; should the listing parser ever reach one, it runs the same command
    args = cli.build_parser().parse_args(["mechanism", "--help"])
    assert args.arguments == ["--help"]
    with pytest.raises(SystemExit) as stop:
        args.func(args)
    assert stop.value.code == 0
    assert capsys.readouterr().out.startswith("usage: python -m physics mechanism")


@pytest.mark.parametrize(("module", "prefix"), [("physics", "linkage-lab "), ("app", "linkage-lab ")])
def test_version_from_the_one_version_source(module, prefix):
    result = run(sys.executable, "-m", module, "--version")
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == f"{prefix}{physics.__version__}"
    assert result.stderr == ""


def test_app_usage_names_the_module_form():
    result = run(sys.executable, "-m", "app", "--help")
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("usage: python -m app ")


@pytest.mark.parametrize(("script", "module"), [("linkage-physics", "physics"), ("linkage-lab", "app")])
def test_console_script_usage_names_the_script(script, module):
    installed = VENV_BIN / script
    if installed.exists():
        result = run(str(installed), "--help")
        assert result.returncode == 0, result.stderr
        assert result.stdout.startswith(f"usage: {script} ")
        version = run(str(installed), "--version")
        assert version.returncode == 0 and version.stdout.strip() == f"linkage-lab {physics.__version__}"
    # the same decision from sys.argv[0], as the console script's wrapper sets it (also when not installed)
    code = (f"import sys; sys.argv[0] = {str(VENV_BIN / script)!r}\n"
            f"from {'physics.cli' if module == 'physics' else 'app.__main__'} import build_parser\n"
            "print(build_parser().format_usage())")
    result = run(sys.executable, "-c", code)
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith(f"usage: {script} ")


def test_program_name_falls_back_to_the_module_form():
    assert program_name("linkage-physics", "python -m physics", "/x/bin/linkage-physics") == "linkage-physics"
    assert program_name("linkage-physics", "python -m physics", r"C:\venv\Scripts\linkage-physics.exe".replace(
        "\\", "/")) == "linkage-physics"
    assert program_name("linkage-physics", "python -m physics", "/x/physics/__main__.py") == "python -m physics"
    assert program_name("linkage-physics", "python -m physics", "/x/bin/pytest") == "python -m physics"
