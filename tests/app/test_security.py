"""The security holes of issue "Hostile input 3", each reproduced as the attack was made (a raw websocket
client speaking viser's protocol, as a hostile script would) and shown closed.

1. A viewer of a presenter-locked lecture uploads a setup or mechanism file and closes its websocket at once:
   the upload finishes after its sender is gone, and a decision that asked "is this sender the presenter?"
   then must answer no (fail closed).
2. Any client asks viser for its public share tunnel (``ShareUrlRequest``): nothing a client sends may open an
   outbound connection.
4. An upload that declares a huge size, or sends more than it declared, must be refused at once and cut off,
   never buffered.
6. No link, notice, download or exported file that the presenter's or a viewer's page can produce carries the
   presenter's secret.
(Hole 5, the page's ``?websocket=`` parameter, is tested in a real browser: tests/browser/test_page_origin.py;
hole 3, the cache, in tests/physics/test_cache_trust.py.)
"""

from __future__ import annotations

import json
import re
import socket
import time
import urllib.parse

import pytest
import viser._viser

from app import viser_compat, wsclient
from app.server import LabServer
from app.wsclient import BackgroundClient, Counts, encode, send_messages, upload_messages
from conftest import wait_until
from physics.mechanism import MECHANISM_PRESETS
from physics.mechanism.files import mechanism_from_bytes

RACES = 15


def _setup_changing_everything() -> bytes:
    """A valid setup file that would turn the lecture into a 12-bar chain with g = 20."""
    return json.dumps({"linkage_lab_setup": 1, "values": {"preset": "chain", "links": 12, "g": 20.0}}).encode()


@pytest.fixture
def lecture():
    server = LabServer(port=0, warm=False, shared=True, preset="triple-a")
    assert server.presenter_url is not None
    assert server.shared_session.player.wait_idle(60)
    yield server
    server.stop()


# ------------------------------------------------------------------------------------------ hole 1
def test_a_viewer_uploading_and_leaving_at_once_changes_nothing(lecture):
    session = lecture.shared_session
    before = (session.params.preset, session.params.n, session.params.chain.g)
    content = _setup_changing_everything()
    uuid = viser_compat.control_id(session.setup_upload)
    # the same upload from the presenter's address is applied (the file is a valid setup)
    for race in range(RACES):
        send_messages(lecture.url, upload_messages(uuid, "lecture.json", content, transfer=f"v{race}"), pause=0)
    time.sleep(1.0)  # the uploads' callbacks run on viser's thread pool after the senders left
    assert (session.params.preset, session.params.n, session.params.chain.g) == before
    assert not lecture.viser.get_clients()
    send_messages(lecture.presenter_url, upload_messages(uuid, "lecture.json", content, transfer="p"), pause=0.2)
    assert wait_until(lambda: lecture.shared_session.params.chain.g == 20.0, timeout=60), \
        "the presenter's own upload was not applied: the test's file is not a valid setup"


def test_a_viewer_uploading_a_mechanism_and_leaving_changes_nothing():
    server = LabServer(port=0, warm=False, shared=True, preset="slider-crank")
    try:
        session = server.shared_session
        assert wait_until(lambda: session.reference is not None, timeout=60)
        shown = session.reference.model_dump_json()
        content = MECHANISM_PRESETS["crank-rocker"]().model_dump_json().encode()
        mechanism_from_bytes(content, "crank-rocker.json")  # a file the presenter could load
        uuid = viser_compat.control_id(session.upload)
        for race in range(RACES // 2):
            send_messages(server.url, upload_messages(uuid, "x.json", content, transfer=f"v{race}"), pause=0)
        time.sleep(1.0)
        assert server.shared_session is session and session.reference.model_dump_json() == shown
    finally:
        server.stop()


def test_an_unknown_sender_is_no_presenter(lecture):
    assert not lecture.is_presenter(None)
    assert not lecture.is_presenter(10_000)  # never connected
    assert not lecture.shared_session.may_change(None)


# ------------------------------------------------------------------------------------------ hole 2
def test_no_client_message_opens_the_share_tunnel(lecture, monkeypatch):
    looked_up: list[str] = []
    real = socket.getaddrinfo

    def watched(host, *args, **kwargs):
        looked_up.append(str(host))
        return real(host, *args, **kwargs)

    monkeypatch.setattr(socket, "getaddrinfo", watched)
    tunnels: list[tuple] = []  # viser's tunnel connects from a process of its own: watch it being made
    monkeypatch.setattr(viser._viser, "ViserTunnel", lambda *args, **kwargs: tunnels.append(args))
    counts = Counts()
    viewer = BackgroundClient(lecture.url, counts)
    try:
        assert wait_until(lambda: counts.frames > 0, timeout=30)
        viewer.send(encode({"type": "ShareUrlRequest"}))
        viewer.send(encode({"type": "ShareUrlDisconnect"}))
        time.sleep(2.0)
    finally:
        viewer.close()
    outside = [host for host in looked_up if host not in ("127.0.0.1", "localhost", "::1")]
    assert outside == [], f"the server looked up {outside}"
    assert counts.by_type["ShareUrlUpdated"] == 0
    assert tunnels == [] and getattr(lecture.viser, "_share_tunnel", None) is None, tunnels


# ------------------------------------------------------------------------------------------ hole 4
def _upload_states(server) -> dict:
    return server.shared_session.target.gui._current_file_upload_states


def test_an_upload_declaring_more_than_the_limit_is_refused_at_once(lecture):
    uuid = viser_compat.control_id(lecture.shared_session.setup_upload)
    start = {"type": "FileTransferStartUpload", "source_component_uuid": uuid, "transfer_uuid": "big",
             "filename": "big.json", "mime_type": "application/json", "part_count": 80_000,
             "size_bytes": 40 * 10**9}
    counts = Counts()
    presenter = BackgroundClient(lecture.presenter_url, counts)
    try:
        assert wait_until(lambda: counts.frames > 0, timeout=30)
        presenter.send(encode(start))
        presenter.send(encode({"type": "FileTransferPart", "source_component_uuid": uuid, "transfer_uuid": "big",
                               "part_index": 0, "content": b"x" * (512 * 1024)}))
        assert wait_until(lambda: any("1,000,000" in text for text in _notices(lecture)), timeout=10), \
            "the presenter was not told the file is too large"
        assert "big" not in _upload_states(lecture)
    finally:
        presenter.close()


def _notices(server) -> list[str]:
    notice = server.shared_session.notice
    return [] if notice is None else [notice]


def test_a_client_sending_more_than_it_declared_is_cut_off(lecture):
    uuid = viser_compat.control_id(lecture.shared_session.setup_upload)
    start = {"type": "FileTransferStartUpload", "source_component_uuid": uuid, "transfer_uuid": "liar",
             "filename": "s.json", "mime_type": "application/json", "part_count": 1, "size_bytes": 1000}
    counts = Counts()
    presenter = BackgroundClient(lecture.presenter_url, counts)
    try:
        assert wait_until(lambda: counts.frames > 0, timeout=30)
        presenter.send(encode(start))
        assert wait_until(lambda: "liar" in _upload_states(lecture), timeout=10)
        for index in range(3):
            presenter.send(encode({"type": "FileTransferPart", "source_component_uuid": uuid,
                                   "transfer_uuid": "liar", "part_index": index, "content": b"x" * 400_000}))
        assert wait_until(lambda: not lecture.viser.get_clients(), timeout=10), "the client was not cut off"
        assert "liar" not in _upload_states(lecture)
    finally:
        presenter.close()


def test_held_upload_bytes_stay_within_the_announced_limit(lecture):
    """Many announced transfers from one browser: at most two are kept, each at most the limit."""
    uuid = viser_compat.control_id(lecture.shared_session.setup_upload)
    counts = Counts()
    presenter = BackgroundClient(lecture.presenter_url, counts)
    try:
        assert wait_until(lambda: counts.frames > 0, timeout=30)
        for index in range(20):
            presenter.send(encode({"type": "FileTransferStartUpload", "source_component_uuid": uuid,
                                   "transfer_uuid": f"t{index}", "filename": "s.json", "mime_type": "x",
                                   "part_count": 2, "size_bytes": 900_000}))
        time.sleep(1.0)
        assert len(_upload_states(lecture)) == viser_compat.UPLOADS_PER_CLIENT
    finally:
        presenter.close()
    assert wait_until(lambda: not _upload_states(lecture), timeout=10)  # dropped with the client


def test_upload_problem_accepts_what_a_browser_sends_and_nothing_else():
    part = viser_compat.UPLOAD_PART_BYTES
    assert viser_compat.upload_problem(0, 0) is None
    assert viser_compat.upload_problem(1, 1) is None
    assert viser_compat.upload_problem(part + 1, 2) is None
    assert viser_compat.upload_problem(viser_compat.UPLOAD_LIMIT_BYTES, 2) is None
    for size, parts in [(viser_compat.UPLOAD_LIMIT_BYTES + 1, 2), (-1, 0), (10, 2), (10, 0), (True, 1),
                        (1.5, 1), ("10", 1), (10, None)]:
        assert viser_compat.upload_problem(size, parts) is not None, (size, parts)


# ------------------------------------------------------------------------------------------ hole 6
def test_nothing_the_pages_produce_carries_the_secret(lecture):
    secret = lecture.presenter_path.removeprefix("/presenter-").removesuffix(".html")
    panel = lecture.shared_session  # the one session: its panel's handles are attributes
    # every button of the panel that makes a link, a download or a file: the run's CSV and JSON are the two
    # buttons of the "Download the run" row (pressed by sending their label), the HTML replay its own button
    presses = [(panel.share_button, True), (panel.save_setup, True), (panel.equations_button, True),
               (panel.equations_tex, True), (panel.download_buttons, "CSV"), (panel.download_buttons, "JSON"),
               (panel.export_html, True)]
    recorded = {"presenter": Counts(), "viewer": Counts()}
    for counts in recorded.values():
        counts.payloads = []
    presenter = BackgroundClient(lecture.presenter_url, recorded["presenter"])
    viewer = BackgroundClient(lecture.url, recorded["viewer"])
    try:
        assert wait_until(lambda: all(c.frames > 0 for c in recorded.values()), timeout=30)
        for client in (presenter, viewer):
            for button, value in presses:
                client.send_value(viser_compat.control_id(button), value)
        assert wait_until(lambda: recorded["presenter"].by_type["FileTransferPart"] >= 5, timeout=60), \
            "the presenter's downloads did not arrive"
        assert wait_until(lambda: "[This setup](/" in panel.share_link.content, timeout=30)  # the setup's link
        time.sleep(1.0)
    finally:
        presenter.close()
        viewer.close()
    for who, counts in recorded.items():
        assert counts.payloads, who
        carrying = [i for i, payload in enumerate(counts.payloads) if secret.encode() in payload]
        assert carrying == [], f"{who}: frames {carrying[:5]} carry the presenter's secret"
        # a relative link is resolved by the page against its own address: the presenter's is secret
        targets = [m.decode("utf-8", "replace") for payload in counts.payloads
                   for m in re.findall(rb"\]\(([/?h][\w/?=&%.:+~-]*)\)|href=\"([/?h][\w/?=&%.:+~-]*)\"", payload)
                   for m in m if m]
        assert any("preset=" in target for target in targets), "the setup link was not among the frames"
        resolved = [urllib.parse.urljoin(lecture.presenter_url, target) for target in targets]
        assert not [url for url in resolved if secret in url], f"{who}: a link resolves to the presenter's page"
    assert "presenter-" not in panel.share_link.content
    assert secret not in "".join(_notices(lecture))


def test_the_link_for_this_setup_is_on_the_root_address(lecture):
    panel = lecture.shared_session  # the one session: its panel's handles are attributes
    panel.show_link()
    assert "](/?preset=triple-a" in panel.share_link.content, panel.share_link.content


def test_the_raw_client_reaches_the_upload_handler(lecture):
    """The attack tests above depend on this client speaking viser's upload protocol: shown with a harmless
    valid file from the presenter (its notice is a refusal naming the file, not silence)."""
    uuid = viser_compat.control_id(lecture.shared_session.setup_upload)
    send_messages(lecture.presenter_url, upload_messages(uuid, "not-json.json", b"{ nope"), pause=0.2)
    assert wait_until(lambda: any("not valid JSON" in text for text in _notices(lecture)), timeout=30), \
        _notices(lecture)
    assert wsclient.encode({"type": "x"})
