"""An installation's first run says, in one line through logging, that it compiles an integrator once; cached runs
say nothing (physics.kernels.first_compile)."""

from __future__ import annotations

import logging
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numba import njit

from physics.kernels import first_compile
from physics.notices import StderrLines

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def fresh_process_state(monkeypatch):
    """As in a new process: nothing announced, no kernel looked at."""
    monkeypatch.setattr(first_compile, "_announced", [])
    monkeypatch.setattr(first_compile, "_checked", set())


def test_a_kernel_compiles_until_its_first_call_and_never_after():
    @njit
    def twice(x):
        return 2.0 * x

    arguments = (np.ones(3),)
    assert first_compile.will_compile(twice, arguments)
    twice(*arguments)
    assert not first_compile.will_compile(twice, arguments)
    assert first_compile.will_compile(twice, (np.ones(3, dtype=np.int64),))  # other types: another compilation


def test_one_line_through_logging_before_the_first_compilation_only(fresh_process_state, caplog):
    @njit
    def first(x):
        return x + 1.0

    @njit
    def second(x):
        return x - 1.0

    with caplog.at_level(logging.WARNING, logger="physics"):
        first_compile.announce(first, (1.0,), "RK45")
        first_compile.announce(first, (1.0,), "RK45")
        first_compile.announce(second, (1.0,), "midpoint")  # the same wait: not said twice
    assert [(record.name, record.getMessage()) for record in caplog.records] == [
        ("physics.kernels", first_compile.compile_line("RK45"))]
    assert caplog.records[0].getMessage().startswith("linkage-lab: compiling the RK45 integrator once")


def test_the_end_of_a_said_compilation_is_logged_below_the_command_lines_threshold(fresh_process_state, caplog):
    @njit
    def third(x):
        return x * 3.0

    with caplog.at_level(logging.INFO, logger="physics"):
        assert first_compile.call_announced(third, (2.0,), "RK45") == 6.0
        assert first_compile.call_announced(third, (2.0,), "RK45") == 6.0  # compiled: nothing more
    said = [(record.name, record.levelno, record.getMessage()) for record in caplog.records]
    assert said[0] == ("physics.kernels", logging.WARNING, first_compile.compile_line("RK45"))
    assert len(said) == 2 and said[1][:2] == ("physics.kernels", logging.INFO)
    assert said[1][2].startswith("linkage-lab: compiled the RK45 integrator in ")


def test_the_command_lines_printer_prints_notices_only(capsys):
    """The end of a compilation (INFO) is for the app; the command line keeps its one line."""
    logger = logging.getLogger("physics.tests.stderr_lines")  # a logger of its own: no other test's handlers
    logger.propagate, logger.level = False, logging.INFO
    handler = StderrLines()
    logger.addHandler(handler)
    try:
        logger.info(first_compile.done_line("RK45", 2.0))
        logger.warning(first_compile.compile_line("RK45"))
    finally:
        logger.removeHandler(handler)
    assert capsys.readouterr().err.splitlines() == [first_compile.compile_line("RK45")]


def test_nothing_is_said_for_a_kernel_already_compiled(fresh_process_state, caplog):
    @njit
    def ready(x):
        return x

    ready(1.0)
    with caplog.at_level(logging.WARNING, logger="physics"):
        first_compile.announce(ready, (1.0,), "DOP853")
    assert caplog.records == []


def _simulate(cache: Path) -> subprocess.CompletedProcess:
    environment = {**os.environ, "LINKAGE_LAB_CACHE": str(cache), "PYTHONPATH": str(ROOT)}
    environment.pop("NUMBA_CACHE_DIR", None)
    # MATLAB's ode45: a run the numba kernel integrates (RK45 and DOP853 runs, stabilised or not, take the drivers
    # generated as LLVM IR, which compile in a fraction of a second and say nothing: test_samples_ir.py)
    command = [sys.executable, "-m", "physics", "simulate", "--preset", "four-bar", "--integrator", "ode45",
               "--t-end", "0.2", "--samples", "3", "--out", os.devnull]
    return subprocess.run(command, cwd=ROOT, env=environment, capture_output=True, text=True, timeout=900)


@pytest.mark.slow
def test_an_empty_cache_says_it_compiles_once_and_the_next_run_is_silent(tmp_path):
    cache = tmp_path / "cache"
    first = _simulate(cache)
    assert first.returncode == 0, first.stderr
    assert first.stderr.splitlines() == [first_compile.compile_line("ode45")]
    second = _simulate(cache)
    assert second.returncode == 0, second.stderr
    assert second.stderr == ""
