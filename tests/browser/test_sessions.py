"""Three pages at once get three sessions; closing one releases its session and leaves the others serving."""

from __future__ import annotations

import numpy as np

from .conftest import wait_until


def test_three_pages_three_sessions_and_closing_one_releases_it(start_lab):
    lab = start_lab(preset="double")
    pages = [lab.open_page() for _ in range(3)]
    sessions = [page.session for page in pages]
    assert len({id(session) for session in sessions}) == 3
    assert len({session.id for session in sessions}) == 3
    assert len(lab.server.sessions) == 3

    # each page shows its own session: three different starts, each page at its own session's poses
    for angle, page in zip((0.4, 1.2, 2.0), pages):
        page.session.set("theta1", angle)
        page.show_time(0.0)
    tips = [np.array(page.session.snapshot()["joints"][-1]) for page in pages]
    assert min(np.linalg.norm(a - b) for i, a in enumerate(tips) for b in tips[i + 1 :]) > 0.1
    for page in pages:
        page.wait_for_server_poses()

    # closing the middle tab releases its session: removed from the server, player stopped
    closing = pages[1]
    released = closing.session
    closing.close()
    wait_until(lambda: released.closed and len(lab.server.sessions) == 2, message="the closed tab's session to go")
    wait_until(lambda: not released.player.alive, message="the closed session's player thread to stop")
    assert closing.client_id not in lab.server.sessions
    assert lab.server.closed_sessions >= 1

    # the other two keep their own sessions and keep serving
    for page, session in ((pages[0], sessions[0]), (pages[2], sessions[2])):
        assert page.session is session and not session.closed
        session.set("theta1", -0.7)
        page.show_time(0.5)
