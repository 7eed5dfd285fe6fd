"""An installation's first compilation is said in every browser of the process, not only on stderr
(app/compile_notice.py; issue 25: "the app showing the same as a notice")."""

from __future__ import annotations

import logging

from app.compile_notice import LOGGER, TITLE, CompileNotices
from app.server import LabServer
from conftest import lab_of
from physics.kernels.first_compile import compile_line, done_line
from physics.notices import notify

mechanism_lab = lab_of("slider-crank")


def test_every_open_session_and_a_newcomer_see_the_line(connect, mechanism_lab):
    _, chain = connect()
    _, mechanism = connect(mechanism_lab)
    line = compile_line("DOP853")
    notify(line, LOGGER)  # what physics.kernels.first_compile.announce does before a compiling call
    said = line.removeprefix("linkage-lab: ")
    assert said.startswith("compiling the DOP853 integrator once for this installation")
    for session in (chain, mechanism):
        assert session.notices.text == f"{TITLE}: {said}", session.notices.text
    _, newcomer = connect()  # arrives while the process is (likely) still compiling
    assert newcomer.notices.text == f"{TITLE}: {said}", newcomer.notices.text


def test_the_notice_comes_down_everywhere_when_the_compilation_is_over(connect, mechanism_lab):
    _, chain = connect()
    _, mechanism = connect(mechanism_lab)
    notify(compile_line("RK45"), LOGGER)
    assert all(session.notices.text.startswith(TITLE) for session in (chain, mechanism))
    logging.getLogger(LOGGER).info(done_line("RK45", 18.0))  # what call_announced logs once the call returned
    assert chain.notices.text is None and mechanism.notices.text is None
    assert not chain.notices.sticky
    _, newcomer = connect()  # arrives after the compilation: nothing to say
    assert newcomer.notices.text is None


def test_the_end_of_a_compilation_leaves_other_notices_alone(connect):
    _, session = connect()
    session.show_notice("Not applied", "m1: must be > 0")
    logging.getLogger(LOGGER).info(done_line("DOP853", 3.0))
    assert session.notices.text == "Not applied: m1: must be > 0"


def test_other_notices_of_physics_are_not_shown_as_a_compilation(connect):
    _, session = connect()
    before = session.notices.text
    notify("linkage-lab: a cache file was damaged; rebuilt", "physics.codegen")
    assert session.notices.text == before


def test_a_stopped_server_no_longer_listens():
    server = LabServer(port=0, warm=False)
    handler = server.compile_notices
    assert handler in logging.getLogger(LOGGER).handlers
    server.stop()
    assert handler not in logging.getLogger(LOGGER).handlers
    assert isinstance(handler, CompileNotices)
