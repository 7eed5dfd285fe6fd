"""--shared with a presenter lock: only the browser that opened the presenter's secret address changes anything;
a viewer's changes are refused by the server (whatever its page does), put back in its page, and it is told why.
"""

from __future__ import annotations

import subprocess
import sys
import time
import urllib.request

import pytest

from app import viser_compat
from app.server import LabServer
from app.wsclient import BackgroundClient, send_values
from conftest import wait_until


@pytest.fixture(scope="module")
def shared():
    server = LabServer(port=0, warm=False, shared=True, preset="triple-a")
    assert server.shared_session.player.wait_idle(60)
    yield server
    server.stop()


def _gravity(server):
    """The gravity knob's slider of the shared session's panel (the one session hosts every chain preset)."""
    return server.shared_session._knob_handles["g"]


def test_the_presenter_address_is_secret_and_serves_the_page(shared):
    url = shared.presenter_url
    assert url is not None and url.startswith(shared.url + "/presenter-") and url.endswith(".html")
    token = url.rsplit("presenter-", 1)[1].removesuffix(".html")
    assert len(token) >= 24  # 18 random bytes
    page = urllib.request.urlopen(url, timeout=30).read().decode()
    assert 'id="linkage-lab-loading"' in page
    other = LabServer(port=0, warm=False, shared=True, preset="single")
    try:
        assert other.presenter_url.rsplit("/", 1)[1] != url.rsplit("/", 1)[1]  # a new secret per server
    finally:
        other.stop()


def test_a_viewer_changes_nothing_and_the_presenter_changes_everything(shared):
    session = shared.shared_session
    before = session.params.chain.g
    viewer = BackgroundClient(shared.url)
    try:
        assert wait_until(lambda: len(shared.viser.get_clients()) >= 1, timeout=30)
        send_values(shared.url, [(viser_compat.control_id(_gravity(shared)), before + 1.0)])
        time.sleep(0.5)
        assert session.params.chain.g == before, "a viewer's change was applied"
        send_values(shared.presenter_url, [(viser_compat.control_id(_gravity(shared)), before + 1.0)])
        assert wait_until(lambda: session.params.chain.g == pytest.approx(before + 1.0), timeout=30)
    finally:
        viewer.close()
        session.set("g", before)


def test_a_viewer_is_told_and_its_control_is_put_back(shared):
    session = shared.shared_session
    viewer = BackgroundClient(shared.url)
    try:
        assert wait_until(lambda: len(shared.viser.get_clients()) == 1, timeout=30)
        (client_id,) = shared.viser.get_clients()
        assert not session.may_change(client_id)
        uuid = viser_compat.control_id(_gravity(shared))
        viewer.send_value(uuid, 7.0)
        viewer.send_value(uuid, 8.0)
        told = lambda: [title for _, title in viewer.counts.notifications  # noqa: E731
                        if title == "The presenter controls this session"]
        assert wait_until(told, timeout=10)
        time.sleep(0.5)
        assert len(told()) == 1  # once, not once per step of a drag
        put_back = [updates["value"] for u, updates in list(viewer.counts.gui_updates) if u == uuid]
        assert put_back and put_back[-1] == pytest.approx(session.params.chain.g)
        assert session.params.chain.g not in (7.0, 8.0)
    finally:
        viewer.close()


def test_the_command_prints_the_presenter_and_viewer_addresses():
    proc = subprocess.Popen([sys.executable, "-m", "app", "--shared", "--port", "0"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        lines = [proc.stdout.readline() for _ in range(3)]
    finally:
        proc.terminate()  # a graceful stop (app/lifetime.py); its speed is tests/app/test_signals.py's to check
        proc.wait(120)
    assert lines[0].startswith("Linkage Lab serving at http://127.0.0.1:"), lines
    viewer_url = lines[0].split()[4]
    assert lines[1].startswith("Presenter (only this browser can change anything") and \
        f"{viewer_url}/presenter-" in lines[1], lines
    assert lines[2].strip() == f"Viewers: {viewer_url}", lines


def test_a_viewer_reads_the_equations_on_its_own_page_and_changes_nothing_shared(shared):
    """Issue 26: a viewer could not open the equations until the presenter did. A viewer's press of "Show the
    equations" opens them in a window of its own page; the panel everyone sees, the notices and the other
    viewers' pages stay as they were. Any other control stays the presenter's."""
    session = shared.shared_session
    reader, other = BackgroundClient(shared.url), BackgroundClient(shared.url)
    try:
        assert wait_until(lambda: len(shared.viser.get_clients()) >= 2, timeout=30)
        shared_content, notice = session.equations.content, session.notices.text
        reader.send_value(viser_compat.control_id(session.equations_button), True)
        assert reader.wait_for(lambda counts: counts.by_type["GuiModalMessage"] >= 1, timeout=120), \
            "the viewer who pressed got no window of equations"
        time.sleep(0.5)
        assert other.counts.by_type["GuiModalMessage"] == 0, "another viewer's page got the window too"
        assert not session._equations_shown and session.equations.content == shared_content
        assert session.notices.text == notice
        # a control that changes the session is still refused to a viewer
        before = session.params.chain.g
        send_values(shared.url, [(viser_compat.control_id(_gravity(shared)), before + 1.0)])
        time.sleep(0.5)
        assert session.params.chain.g == before
    finally:
        reader.close()
        other.close()


def test_the_presenters_press_shows_the_equations_to_everyone(shared):
    session = shared.shared_session
    send_values(shared.presenter_url, [(viser_compat.control_id(session.equations_button), True)])
    assert wait_until(lambda: session._equations_shown and "Deriving" not in session.equations.content, timeout=120)
    assert "<math" in session.equations.content or "\\(" in session.equations.content or "A x = b" in \
        session.equations.content


def test_a_viewer_saves_the_design_to_its_own_machine_and_changes_nothing_shared(shared):
    """Issue 27: in a lecture the viewers can save the presenter's design. A viewer's "Save the design" sends the
    file to that viewer's page alone; the design, the notices and the other viewers' pages stay as they were."""
    session = shared.shared_session
    reader, other = BackgroundClient(shared.url), BackgroundClient(shared.url)
    try:
        assert wait_until(lambda: len(shared.viser.get_clients()) >= 2, timeout=30)
        notice = session.notices.text
        told, others_told = (client.counts.by_type["NotificationShowMessage"] for client in (reader, other))
        # with nothing designed yet, the refusal goes to the viewer's page alone
        reader.send_value(viser_compat.control_id(session.design_view.save_buttons), "TOML")
        assert reader.wait_for(lambda counts: counts.by_type["NotificationShowMessage"] > told, timeout=60), \
            "the viewer was not told why nothing was saved"
        time.sleep(0.5)
        assert session.notices.text == notice and other.counts.by_type["NotificationShowMessage"] == others_told
        session.design_view.start_from_preset()  # the presenter opens the linkage shown as a design
        design, notice = session.design_view.design, session.notices.text
        assert design.bodies
        reader.send_value(viser_compat.control_id(session.design_view.save_buttons), "TOML")
        assert reader.wait_for(lambda counts: counts.by_type["FileTransferStartDownload"] >= 1, timeout=60), \
            "the viewer who pressed Save got no file"
        time.sleep(0.5)
        assert other.counts.by_type["FileTransferStartDownload"] == 0, "another viewer's page got the file too"
        assert session.design_view.design == design and session.notices.text == notice
    finally:
        reader.close()
        other.close()
