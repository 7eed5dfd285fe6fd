"""The library's notices go through logging (physics.notices, issue 25): a program can silence or redirect them;
unconfigured, and in the commands, they are the same one line on stderr as before."""

from __future__ import annotations

import logging
import os
import subprocess
import sys

import pytest

from physics import cli
from physics.cache_folder import warn
from physics.long_run import ProgressLine
from physics.notices import LOGGER_NAME, StderrLines

NOTICE = ("import logging, sys\n"
          "if sys.argv[1] == 'quiet': logging.getLogger('physics').setLevel(logging.ERROR)\n"
          "from physics.cache_folder import warn\n"
          "warn('a damaged cache file was rebuilt')\n")


def run_python(*arguments: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, *arguments], capture_output=True, text=True, timeout=300,
                          env={**os.environ})


@pytest.fixture
def physics_logger():
    logger = logging.getLogger(LOGGER_NAME)
    level, handlers = logger.level, list(logger.handlers)
    yield logger
    logger.setLevel(level)
    logger.handlers[:] = handlers


def test_unconfigured_a_notice_is_its_one_line_on_stderr_and_logging_silences_it():
    shown = run_python("-c", NOTICE, "shown")
    assert shown.returncode == 0, shown.stderr
    assert shown.stderr == "linkage-lab: a damaged cache file was rebuilt\n"
    quiet = run_python("-c", NOTICE, "quiet")
    assert quiet.returncode == 0, quiet.stderr
    assert quiet.stderr == ""


def test_a_notice_is_a_warning_record_under_physics_and_set_level_silences_it(physics_logger, caplog):
    with caplog.at_level(logging.DEBUG):
        warn("rebuilt one file")
    records = [r for r in caplog.records if r.name.startswith("physics")]
    assert [(r.name, r.levelno, r.getMessage()) for r in records] == [
        ("physics.cache", logging.WARNING, "linkage-lab: rebuilt one file")]
    caplog.clear()
    physics_logger.setLevel(logging.ERROR)
    warn("rebuilt another file")
    assert [r for r in caplog.records if r.name.startswith("physics")] == []


def test_progress_lines_go_through_logging_unless_given_a_stream(physics_logger, caplog, monkeypatch):
    monkeypatch.setattr("physics.long_run.PROGRESS_EVERY", 0.0)
    with caplog.at_level(logging.DEBUG):
        ProgressLine(10.0).update(5.0, seconds_left=1.0)
    assert [(r.name, r.getMessage()) for r in caplog.records] == [
        ("physics.long_run", "simulated 5 of 10 s (50.00 %), about 1 s left")]


def test_the_command_prints_a_notice_as_the_same_line_once(physics_logger, capsys):
    cli.main(["presets"])  # installs the command's handler (idempotent)
    cli.main(["presets"])
    assert sum(isinstance(h, StderrLines) for h in physics_logger.handlers) == 1
    capsys.readouterr()
    warn("rebuilt one file")
    assert capsys.readouterr().err == "linkage-lab: rebuilt one file\n"
    physics_logger.setLevel(logging.ERROR)
    warn("rebuilt another file")
    assert capsys.readouterr().err == ""
