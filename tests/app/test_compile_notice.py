"""An installation's first compilation is said in every browser of the process, not only on stderr
(app/compile_notice.py; issue 25: "the app showing the same as a notice")."""

from __future__ import annotations

import logging

from app.compile_notice import LOGGER, TITLE, CompileNotices
from app.server import LabServer
from conftest import lab_of
from physics.kernels.first_compile import compile_line
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
