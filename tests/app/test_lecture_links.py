"""Links in a lecture (issue 26): with ``--shared`` and a presenter, the presenter's page opened with a share link
sets up the shared session; a viewer's page with a link is told once that the presenter controls the setup;
the session waits at t = 0, paused, until the presenter presses Play (``autoplay``: it plays), its charts
showing the start sample meanwhile; the Export tab's links and files never carry the presenter's secret; a lone
SIGINT stops a three-process server.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import urllib.parse
from pathlib import Path

import pytest

from app.player import SAMPLE_DT
from app.server import LabServer
from app.session import VIEWERS_LINK
from app.share import SETUP_PATH
from conftest import BrowserStandIn, end_group, wait_until

ROOT = Path(__file__).resolve().parents[2]
LINK = "preset=double&L1=1.5&theta1=60&method=dae"


def _setup_url(page_url: str, query: str) -> str:
    """The websocket address a page opened with ``?query`` connects to (static/page.html)."""
    return page_url + SETUP_PATH + urllib.parse.quote(query, safe="")


@pytest.fixture(scope="module")
def lecture():
    """A lecture as ``python -m app --shared`` starts it: the session waits for the presenter's Play."""
    server = LabServer(port=0, warm=False, shared=True, preset="triple-a", autoplay=False)
    assert server.shared_session.player.wait_idle(120)
    yield server
    server.stop()


def _secret(server: LabServer) -> str:
    return server.presenter_path.removeprefix("/presenter-").removesuffix(".html")


def test_the_lecture_waits_at_the_start_paused_with_the_start_sample_in_its_charts(lecture):
    session = lecture.shared_session
    time.sleep(1.0)  # a session that played would be past t = 0 by now
    assert not session.player.playing
    assert session.player.runs[0].ring.get("t", 0) == 0.0
    assert session.snapshot()["time"] == 0.0
    # not empty charts: the start sample is drawn (one point at t = 0, its energy the start's)
    assert session.energy_plot.points_shown == 1
    assert session.energy_plot.handle.data[0][0] == 0.0
    assert session.energy_plot.handle.data[3][0] == pytest.approx(session.player.runs[0].ring.get("energy", 0))


def test_with_autoplay_the_shared_session_plays_from_the_start():
    server = LabServer(port=0, warm=False, shared=True, preset="double", autoplay=True)
    try:
        assert server.shared_session.player.wait_idle(120)
        assert wait_until(lambda: server.shared_session.snapshot()["time"] > 0.2, timeout=60)
        assert server.shared_session.player.playing
    finally:
        server.stop()


def test_the_presenters_link_sets_up_the_lecture_and_waits_at_its_start(lecture):
    session = lecture.shared_session
    presenter = BrowserStandIn(_setup_url(lecture.presenter_url, LINK))
    try:
        assert wait_until(lambda: session.chain is not None and session.chain.preset == "double"
                          and session.settings.method == "dae", timeout=60), session.label
        assert wait_until(lambda: session.chain.chain.bars[0].L == pytest.approx(1.5)
                          and session.chain.theta0[0] == pytest.approx(1.0471975511965976), timeout=60)
        (client_id,) = lecture.viser.get_clients()
        assert session.may_change(client_id)  # still the presenter, under its address with the link
        assert session.player.wait_idle(120)
        time.sleep(0.5)
        assert not session.player.playing and session.snapshot()["time"] == 0.0  # waits for the presenter's Play
    finally:
        presenter.close()
        wait_until(lambda: not lecture.viser.get_clients(), timeout=10)


def test_a_viewers_link_is_not_applied_and_the_viewer_is_told_once(lecture):
    session = lecture.shared_session
    before = (session.label, session.settings.method, session.setup_pairs())
    viewer = BrowserStandIn(_setup_url(lecture.url, "preset=four-bar&method=lagrange"))
    try:
        told = lambda: [title for _, title in viewer.counts.notifications  # noqa: E731
                        if title == "The presenter controls the setup"]
        assert wait_until(told, timeout=30)
        time.sleep(1.0)
        assert len(told()) == 1
        (client_id,) = lecture.viser.get_clients()
        assert not session.may_change(client_id)
        assert (session.label, session.settings.method, session.setup_pairs()) == before
    finally:
        viewer.close()
        wait_until(lambda: not lecture.viser.get_clients(), timeout=10)


def test_a_guessed_presenter_address_with_a_link_is_a_viewer(lecture):
    session = lecture.shared_session
    before = session.setup_pairs()
    wrong = lecture.url + "/presenter-" + "A" * 24 + ".html"
    viewer = BrowserStandIn(_setup_url(wrong, "preset=chain&links=5"))
    try:
        assert wait_until(lambda: len(lecture.viser.get_clients()) == 1, timeout=30)
        (client_id,) = lecture.viser.get_clients()
        assert not session.may_change(client_id)
        time.sleep(1.0)
        assert session.setup_pairs() == before
    finally:
        viewer.close()
        wait_until(lambda: not lecture.viser.get_clients(), timeout=10)


def test_the_export_tab_gives_the_viewers_link_and_this_setups_link_without_the_secret(lecture):
    session = lecture.shared_session
    secret = _secret(lecture)
    assert VIEWERS_LINK in session.share_link.content  # there before any button is pressed
    session.guard(session.show_link)
    content = session.share_link.content
    assert "[Viewers' link](/)" in content
    assert f"(/{session.link_query()})" in content
    # a run to download (the lecture waits at its start): seek blocks until the display shows the time, since
    # the downloads hold the samples up to the displayed time, not the ones simulated ahead of it
    assert session.player.seek(30 * SAMPLE_DT, timeout=60)
    files = {kind: session.download_file(kind)[1] for kind in ("csv", "json", "setup", "html")}
    texts = {"link": content, "notice": session.notices.text or "", "status": session.status.content,
             **{kind: data.decode("utf-8", "replace") for kind, data in files.items()}}
    json.loads(files["setup"])  # a real setup file was searched
    assert len(files["csv"].splitlines()) >= 1 and "<html" in texts["html"].lower()
    for where, text in texts.items():
        assert secret not in text, where
        assert "presenter-" not in text, where


def _serving_children(pid: int) -> list[int]:
    """The server processes and workers below ``pid`` (multiprocessing's resource tracker left out: it ends on
    its own once its pipe closes)."""
    found = []
    for child in subprocess.run(["pgrep", "-P", str(pid)], capture_output=True, text=True).stdout.split():
        try:
            command = Path(f"/proc/{child}/cmdline").read_bytes().replace(b"\0", b" ")
        except OSError:
            continue
        if b"resource_tracker" not in command:
            found.append(int(child))
    return found


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_a_lone_sigint_to_the_main_process_of_three_stops_them_all():
    """With browsers open on it: each process stops its sessions and workers side by side (they took longer
    than the grace period one after another, and a sibling still starting was killed only after 5 s)."""
    command = subprocess.Popen([sys.executable, "-m", "app", "--port", "0", "--processes", "3"], cwd=ROOT,
                               env=os.environ.copy(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               start_new_session=True)  # its own group: the SIGINT below reaches it alone
    browsers: list[BrowserStandIn] = []
    try:
        line = command.stdout.readline()
        assert "serving at http://" in line and "3 processes" in line, line
        url = line.split("serving at ")[1].split()[0]
        browsers = [BrowserStandIn(url) for _ in range(4)]
        assert wait_until(lambda: min(b.counts.bar_updates() for b in browsers) >= 3, timeout=120)
        children = _serving_children(command.pid)
        assert len(children) >= 2, children
        os.kill(command.pid, signal.SIGINT)
        started = time.monotonic()
        command.wait(15)
        assert wait_until(lambda: not any(_alive(pid) for pid in children), timeout=15.0 - (time.monotonic() - started)), \
            [pid for pid in children if _alive(pid)]
        err = command.stderr.read()
        assert command.returncode == 0, (command.returncode, err[-2000:])  # an orderly stop, not the grace timer
        assert "Traceback" not in err, err[-2000:]
    finally:
        end_group(command, *browsers)
