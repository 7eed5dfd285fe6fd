"""No path of any one machine in the repository (issue 28): the tracked text files name no home folder, no
/work/ or /root/ folder and no Windows or macOS user folder; ``/tmp/`` appears only where a command example uses
it as a scratch folder, in the files listed below (each with the reason), so a new one is a decision, not an
accident. Paths inside the container image the Dockerfile builds (``/home/lab``, its user) are the image's own."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# A folder of one machine or user: a home folder (other than the image's user, lab), root's, the workspace's,
# macOS and Windows user folders.
MACHINE_PATH = re.compile(r"(?<![\w.~-])(/home/(?!lab\b)[\w.-]+|/root/|/work/|/Users/[\w.-]+|[A-Za-z]:\\+Users\\+)")
TEMPORARY_PATH = re.compile(r"(?<![\w.~-])/tmp/")

# Files whose command examples use /tmp/ as a scratch folder anyone's machine has (reasons in each file).
SCRATCH_EXAMPLES = {
    "BENCHMARKS.md": "worktrees of earlier commits and cache folders for the measurements' commands",
    "CONTRIBUTING.md": "a throw-away virtual environment that re-pins constraints.txt",
    "constraints.txt": "the same throw-away virtual environment, in its header",
    "Dockerfile": "the build context copied in and removed in one layer",
    "README.md": "the bench command's output folder",
    "docs/physics.md": "a private cache folder for the examples (LINKAGE_LAB_CACHE) and their outputs",
    "docs/stability.md": "the output folders of the studies' command examples (bench, the stability study)",
    "docs/stability/work-precision.json": "the command that wrote it, as it was run",
}


def tracked_text_files() -> list[Path]:
    names = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    files = []
    for name in names.decode().split("\0"):
        path = ROOT / name
        if not name or not path.is_file():
            continue
        data = path.read_bytes()
        if b"\0" in data[:8192]:
            continue  # binary
        files.append(path)
    return files


def offending_lines(pattern: re.Pattern, allowed: set[str]) -> list[str]:
    found = []
    for path in tracked_text_files():
        name = path.relative_to(ROOT).as_posix()
        if name in allowed:
            continue
        for number, line in enumerate(path.read_text(errors="replace").splitlines(), start=1):
            if pattern.search(line):
                found.append(f"{name}:{number}: {line.strip()[:120]}")
    return found


def test_no_machine_or_user_folder_is_named():
    this_file = Path(__file__).relative_to(ROOT).as_posix()
    assert offending_lines(MACHINE_PATH, {this_file}) == []


def test_temporary_folders_appear_only_in_listed_scratch_examples():
    this_file = Path(__file__).relative_to(ROOT).as_posix()
    assert offending_lines(TEMPORARY_PATH, {this_file, *SCRATCH_EXAMPLES}) == []
    for name in SCRATCH_EXAMPLES:  # the list stays exact: an entry whose file no longer needs it is removed
        assert TEMPORARY_PATH.search((ROOT / name).read_text()), name


def test_the_patterns_catch_what_they_should():
    for line in ("see /home/alice/notes.md", "/root/.cache", "/work/shared/seed/x.md", "C:\\Users\\bob", "/Users/eve"):
        assert MACHINE_PATH.search(line), line
    for line in ("/home/lab/.cache", "docs/seed-report.md", "~/home/x", "file:///usr/share"):
        assert not MACHINE_PATH.search(line), line
