"""The Dockerfile: reproducible, least-privilege, and the README's own app.

Docker cannot run on our machines, so this test reads the Dockerfile and README.md as text: the base image is
pinned by digest; the project is installed once, as root, non-editable, pinned by the same constraints.txt the
README's install lines use; the image starts the README's app (plus the container-only ``--host 0.0.0.0 --port
8080`` and a session cap within the server's limit), runs as a non-root user, warms the derivation cache at
build time with the installed interpreter, and carries a health check; and the README's ``docker build`` /
``docker run`` lines build and publish this image.
"""

from __future__ import annotations

import json
import re
import shlex
from pathlib import Path

import pytest

from app.server import MAX_SESSIONS_LIMIT

ROOT = Path(__file__).resolve().parents[1]
DOCKERFILE = ROOT / "Dockerfile"
README = ROOT / "README.md"
CONTAINER_PORT = 8080


# --------------------------------------------------------------------------------------------- parsing
def parse_dockerfile(text: str) -> list[tuple[str, str]]:
    """``(INSTRUCTION, arguments)`` pairs, comments dropped and continuation lines joined."""
    instructions: list[tuple[str, str]] = []
    pending = ""
    for raw_line in text.splitlines():
        line = raw_line.strip()
        if not line or line.startswith("#"):
            continue
        if line.endswith("\\"):
            pending += line[:-1].strip() + " "
            continue
        pending += line
        keyword, _, arguments = pending.strip().partition(" ")
        instructions.append((keyword.upper(), arguments.strip()))
        pending = ""
    assert not pending, f"Dockerfile ends inside a continued line: {pending!r}"
    return instructions


def command_words(arguments: str) -> list[str]:
    """Words of a RUN/CMD argument, in exec form (JSON list) or shell form."""
    if arguments.startswith("["):
        words = json.loads(arguments)
        assert all(isinstance(word, str) for word in words), arguments
        return words
    return shlex.split(arguments)


def normalized(command: str) -> str:
    return " ".join(shlex.split(command))


def chained(command: str) -> list[str]:
    """``a && b && c`` -> ``["a", "b", "c"]``, each normalized."""
    return [normalized(part) for part in command.split("&&") if part.strip()]


def starts_app(command: str) -> bool:
    words = shlex.split(command)
    runs_module = len(words) >= 3 and Path(words[0]).name.startswith("python") and words[1:3] == ["-m", "app"]
    return (runs_module or words[:1] == ["linkage-lab"]) and "snapshot" not in words


def readme_code_lines() -> list[str]:
    """Every command line inside the README's fenced code blocks (prompts and comments stripped)."""
    assert README.exists(), "README.md is missing: the Dockerfile must follow its install and start commands"
    lines: list[str] = []
    inside = False
    for raw_line in README.read_text(encoding="utf-8").splitlines():
        if raw_line.strip().startswith("```"):
            inside = not inside
            continue
        if not inside:
            continue
        line = raw_line.strip()
        if line.startswith("$ "):
            line = line[2:]
        line = line.split(" #", 1)[0].strip()
        if line and not line.startswith("#"):
            lines.append(line)
    return lines


def readme_setup_and_start() -> tuple[list[str], str]:
    """The README's first line that starts the app: the commands chained before the start (making an
    environment, ``pip install``) and the start command itself."""
    for line in readme_code_lines():
        parts = chained(line)
        for index, part in enumerate(parts):
            if starts_app(part):
                setup = parts[:index]
                assert any(re.search(r"\bpip install\b", command) for command in setup), (
                    f"the README's start line {line!r} does not install the project first"
                )
                return setup, part
    raise AssertionError("README.md has no fenced line that installs and starts the app (`... pip install . && python -m app`)")


@pytest.fixture(scope="module")
def instructions() -> list[tuple[str, str]]:
    assert DOCKERFILE.exists(), "Dockerfile is missing"
    return parse_dockerfile(DOCKERFILE.read_text(encoding="utf-8"))


def only(instructions, keyword: str) -> list[str]:
    return [arguments for name, arguments in instructions if name == keyword]


def run_commands(instructions) -> list[tuple[int, str]]:
    """``(instruction index, command)`` for every command the RUN lines execute (``&&`` chains split)."""
    return [
        (index, part)
        for index, (name, arguments) in enumerate(instructions)
        if name == "RUN"
        for part in chained(" ".join(command_words(arguments)) if arguments.startswith("[") else arguments)
    ]


# ----------------------------------------------------------------------------------------------- tests
def test_parser_joins_continuations_and_reads_exec_form():
    parsed = parse_dockerfile('FROM x\n# note\nRUN a \\\n    b && c\nCMD ["python", "-m", "app"]\n')
    assert parsed == [("FROM", "x"), ("RUN", "a b && c"), ("CMD", '["python", "-m", "app"]')]
    assert command_words(parsed[2][1]) == ["python", "-m", "app"]
    assert chained(parsed[1][1]) == ["a b", "c"]
    assert starts_app(".venv/bin/python -m app") and not starts_app("python -m app snapshot --json")


def test_base_image_is_slim_python_pinned_by_digest(instructions):
    base = only(instructions, "FROM")
    assert len(base) == 1, base
    assert re.fullmatch(r"python:3\.\d+-slim(-bookworm)?@sha256:[0-9a-f]{64}", base[0]), (
        f"the base image must be a slim Python pinned by digest (name:tag@sha256:...): {base[0]}"
    )


def install_commands(instructions) -> list[tuple[int, str]]:
    return [(index, command) for index, command in run_commands(instructions) if re.search(r"\bpip install\b", command)]


def interpreter_of(instructions) -> str:
    """The interpreter beside the pip that installed the project (``/opt/x/bin/pip`` -> ``/opt/x/bin/python``)."""
    pip = shlex.split(install_commands(instructions)[0][1])[0]
    return str(Path(pip).with_name("python"))


def test_install_is_pinned_non_editable_and_owned_by_root(instructions):
    """The runtime user can run the installed app but not change it: installed before the first USER line
    (as root), not editable (no link back to sources the user could edit), outside the user's home."""
    installs = install_commands(instructions)
    assert len(installs) == 1, f"expected one pip install, found {installs}"
    index, command = installs[0]
    words = shlex.split(command)
    assert "-e" not in words and "--editable" not in words, f"the image's install must not be editable: {command}"
    assert "-c" in words and words[words.index("-c") + 1].endswith("constraints.txt"), (
        f"the image's install must be pinned by constraints.txt: {command}"
    )
    users = [position for position, (name, _) in enumerate(instructions) if name == "USER"]
    assert users and index < users[0], "the project must be installed as root, before the first USER line"
    interpreter = Path(words[0])
    assert interpreter.is_absolute() and not str(interpreter).startswith("/home/"), (
        f"install outside the runtime user's home: {interpreter}"
    )
    assert not any("chown" in arguments or "chmod" in arguments for name, arguments in instructions if name in ("RUN", "COPY")), (
        "nothing may hand the installed files to the runtime user"
    )


def test_readme_installs_use_the_same_constraints_file():
    lines = [line for line in readme_code_lines() if re.search(r"\bpip install\b", line)]
    assert lines, "README.md has no install line"
    for line in lines:
        words = shlex.split(line.replace("&&", " "))
        assert "-c" in words and words[words.index("-c") + 1] == "constraints.txt", (
            f"the README's install line must use the pinned versions (pip install -c constraints.txt ...): {line}"
        )
    pins = [row for row in (ROOT / "constraints.txt").read_text(encoding="utf-8").splitlines() if row and not row.startswith("#")]
    assert all(re.fullmatch(r"[a-z0-9_.-]+==[0-9][0-9a-z.+!-]*", row) for row in pins), pins
    for package in ("viser", "numpy", "scipy", "sympy", "pydantic", "numba", "llvmlite"):
        assert any(row.startswith(f"{package}==") for row in pins), f"constraints.txt does not pin {package}"


def test_image_starts_the_readme_app_on_all_interfaces_with_a_session_cap(instructions):
    cmd = only(instructions, "CMD")
    assert len(cmd) == 1, f"expected one CMD, found {cmd}"
    words = command_words(cmd[0])
    _, start = readme_setup_and_start()
    start_words = shlex.split(start)
    installed_python = interpreter_of(instructions)
    assert words[0] == installed_python, f"CMD must run the installed interpreter {installed_python}: {words}"
    assert words[1 : len(start_words)] == start_words[1:], f"CMD {words} does not run the README's {start!r}"
    assert words[words.index("--host") + 1] == "0.0.0.0", words
    assert words[words.index("--port") + 1] == str(CONTAINER_PORT), words
    cap = int(words[words.index("--max-sessions") + 1])
    assert 1 <= cap <= MAX_SESSIONS_LIMIT, f"the image's session cap {cap} is outside 1..{MAX_SESSIONS_LIMIT}"
    assert only(instructions, "EXPOSE") == [str(CONTAINER_PORT)]


def test_runs_as_non_root_and_warms_the_cache_at_build_time(instructions):
    users = [(index, arguments) for index, (name, arguments) in enumerate(instructions) if name == "USER"]
    assert users and users[-1][1] not in ("root", "0"), f"the image must run as a non-root user, USER lines: {users}"
    commands = run_commands(instructions)
    installed_python = interpreter_of(instructions)
    warm = [index for index, command in commands if command.startswith(f"{installed_python} -m physics warm")]
    assert warm, f"no RUN line warms the derivation cache with the app's interpreter ({installed_python} -m physics warm)"
    assert users[-1][0] < warm[0], "the cache must be warmed as the user that runs the app (after the last USER)"


def test_healthcheck_requests_the_app_page_inside_the_container(instructions):
    checks = only(instructions, "HEALTHCHECK")
    assert len(checks) == 1, checks
    assert "CMD" in checks[0] and f"http://127.0.0.1:{CONTAINER_PORT}/" in checks[0], checks[0]
    assert "urllib.request" in checks[0], "the slim image has no curl: the check uses python's urllib"


def test_readme_docker_lines_build_and_run_this_image():
    lines = [shlex.split(line) for line in readme_code_lines()]
    builds = [words for words in lines if words[:2] == ["docker", "build"]]
    runs = [words for words in lines if words[:2] == ["docker", "run"]]
    assert builds, "README.md has no `docker build` line"
    assert runs, "README.md has no `docker run` line"
    build = builds[0]
    assert build[-1] == ".", f"`docker build` should build this directory: {build}"
    tag = build[build.index("-t") + 1]
    run = runs[0]
    assert tag in run, f"`docker run` should run the image built above ({tag}): {run}"
    published = run[run.index("-p") + 1]
    assert published.endswith(f":{CONTAINER_PORT}"), f"`docker run -p` must publish container port {CONTAINER_PORT}"
    assert published.startswith("127.0.0.1:"), "publish on the host's loopback only, as the app itself binds by default"


def test_dockerignore_keeps_the_build_context_small():
    ignored = (ROOT / ".dockerignore").read_text(encoding="utf-8").split()
    for entry in (".git", "**/__pycache__", ".venv"):
        assert entry in ignored, f".dockerignore should list {entry}"
