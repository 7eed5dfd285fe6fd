"""The running app: one viser server on 127.0.0.1, a session per browser (or one shared), a cap on sessions.

:class:`LabServer` is what ``python -m app`` starts and what tests start in-process on a free port. Each
browser that connects gets its own :class:`~app.session.Session` (any preset) on its client handle; closing the tab
closes the session (player thread stopped, buffers dropped). Past ``max_sessions`` a browser is turned away
with a message in its page. With ``shared``, one session lives on the server's shared scene and GUI and every
browser watches (and drives) it. With ``processes`` > 1 the server is that many processes on one port, each
a ``LabServer`` with its share of the browsers (app/processes.py); ``seats`` counts the sessions of all of them.
"""

from __future__ import annotations

import contextlib
import io
import ipaddress
import os
import secrets
import socket
import sys
import threading
import time
import traceback

from physics import LinkageError
from physics.mechanism import MECHANISM_PRESETS, Mechanism

from . import lifetime, memory, replay, share, viser_compat
from . import processes as server_processes
from . import warm as warm_up
from .compile_notice import TITLE as COMPILE_TITLE
from .compile_notice import CompileNotices
from .design_view import design_flag_from, sketch_from
from .lab_session import LabSession
from .logs import quietly
from .mechanism_runs import start_state
from .page import READY_HTML, add_alias, page_folder
from .parameters import SessionParameters
from .session import Session, is_mechanism

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8080
DEFAULT_PRESET = "triple-a"
DEFAULT_MAX_SESSIONS = 32
# Own sessions each integrate ahead and render in a server process (app/player.py, app/processes.py); past
# this the 2-core machine of docs/reliability.md cannot keep their frame rate. A larger audience watches one
# --shared session.
MAX_SESSIONS_LIMIT = 100
# Frames per second one server process renders in total. Up to FULL_RATE_SESSIONS sessions animate at 60 fps;
# beyond, they share this budget (at least MIN_SESSION_FPS each), so the one core a process's interpreter may
# use is not spent on frames that viser would drop before sending (measured: python -m app.bench load).
FRAME_BUDGET = 1500.0
FULL_RATE_SESSIONS = 15
MIN_SESSION_FPS = 15.0


SIGNAL_CHECK_SECONDS = 0.25  # how soon serve_forever runs a signal's handler that reached another thread


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def check_bindable(host: str) -> None:
    """Fail early, with the host named, if this machine cannot listen on ``host``."""
    try:
        infos = socket.getaddrinfo(host, 0, type=socket.SOCK_STREAM)
    except OSError as error:
        raise LinkageError(f"--host {host}: cannot resolve ({error.strerror or error})") from None
    family, _, _, _, address = infos[0]
    with socket.socket(family, socket.SOCK_STREAM) as probe:
        try:
            probe.bind((address[0], 0))
        except OSError as error:
            raise LinkageError(f"--host {host}: cannot listen on this address ({error.strerror or error})") from None


VIEWER_LINE = ("**The presenter controls this session.** You are watching: the controls show the presenter's "
               "settings, and changes from this browser are not applied.")
# A viewer's controls, drawn read-only (the server refuses a viewer's changes whatever the page does); the tabs
# stay usable, so a viewer can read the equations and the help.
VIEWER_STYLE = """<style>
.mantine-Slider-root, .mantine-NumberInput-root, .mantine-TextInput-root, .mantine-Select-root,
.mantine-NativeSelect-root, .mantine-Button-root, .mantine-Checkbox-root, .mantine-SegmentedControl-root,
.mantine-ColorInput-root, .mantine-Switch-root { pointer-events: none; opacity: 0.55; }
</style>"""


def lecture_from(setup: list[tuple[str, str]], default: bool) -> tuple[list[tuple[str, str]], bool, list[str]]:
    """A link's ``lecture=1`` (or ``0``) taken out of its setup: whether the session starts in lecture mode
    (``default``: ``--lecture``); see :func:`share.flag_from`."""
    return share.flag_from(setup, "lecture", default, "opens the page in lecture mode")


class LabServer:
    """A viser server with Linkage Lab sessions. ``stop()`` closes every session and frees the port."""

    def __init__(
        self,
        host: str = DEFAULT_HOST,
        port: int = DEFAULT_PORT,
        *,
        preset: str = DEFAULT_PRESET,
        links: int | None = None,
        method: str | None = None,
        max_sessions: int = DEFAULT_MAX_SESSIONS,
        shared: bool = False,
        warm: bool = True,
        processes: int = 1,
        seats: server_processes.Seats | None = None,
        reuse_port: bool = False,
        setup: list[tuple[str, str]] | None = None,
        presenter: bool = True,
        mechanism: Mechanism | None = None,
        mechanism_label: str | None = None,
        lecture: bool = False,
        autoplay: bool = True,
    ) -> None:
        if not 0 <= int(port) <= 65535:
            raise LinkageError(f"--port {port}: allowed range 0 <= port <= 65535 (0 picks a free port)")
        if not 1 <= int(max_sessions) <= MAX_SESSIONS_LIMIT:
            raise LinkageError(
                f"--max-sessions {max_sessions}: allowed range 1 <= max-sessions <= {MAX_SESSIONS_LIMIT} "
                "(own sessions each integrate in this process; use --shared for a larger audience)"
            )
        # a general mechanism to start with: a file (--mechanism) or a preset of physics.mechanism
        if mechanism is None and is_mechanism(preset):
            mechanism, mechanism_label = MECHANISM_PRESETS[preset](), preset
        self.mechanism, self.mechanism_label = mechanism, mechanism_label
        if mechanism is not None:
            start_state(mechanism)  # it must assemble (LinkageError naming the joint that stays open)
            preset, warm = DEFAULT_PRESET, False  # the chain a switch from it starts with
        # validate the start mechanism once, before anything listens (raises LinkageError naming the field)
        SessionParameters.from_preset(preset, links=links, method=method)
        if not 1 <= int(processes) <= server_processes.MAX_PROCESSES:
            raise LinkageError(f"--processes {processes}: allowed range 1 <= processes <= "
                               f"{server_processes.MAX_PROCESSES}")
        check_bindable(host)
        processes = 1 if shared else int(processes)  # one shared session lives in one process
        if processes > 1 and not server_processes.shares_ports():
            print(f"linkage-lab: --processes {processes}: this system cannot share a port between processes; "
                  "serving from one", file=sys.stderr)
            processes = 1
        if processes > 1:  # siblings share the port (app/processes.py): reserve one nothing else holds
            port = server_processes.reserve_port(host, int(port))
            reuse_port = True
        # start loading the compiled equations now, in parallel with the server's start (see app/warm.py)
        self._warm_thread = warm_up.start_warm_up(preset, links, method) if warm else None
        import viser  # noqa: PLC0415 - after the warm-up thread started: it loads compiled code meanwhile

        self.host = host
        self.requested_port = int(port)
        self.preset, self.links, self.method = preset, links, method
        self.max_sessions = int(max_sessions)
        self.shared = shared
        self.lecture = lecture  # --lecture: every session starts in lecture mode (app/lecture.py)
        self.setup = list(setup or [])  # --state: the saved setup every new session starts from (app/share.py)
        # --shared: False (the command's default) waits at t = 0, paused, until the presenter presses Play
        self.autoplay = autoplay
        self.started = time.time()
        binding = server_processes.reuse_port_binding() if reuse_port else contextlib.nullcontext()
        page = viser_compat.serving_page_from(page_folder())  # the loading screen from the first paint
        with contextlib.redirect_stdout(io.StringIO()), binding, page:  # viser's banner: we print the real URL
            self.viser = viser.ViserServer(host=host, port=int(port), label="Linkage Lab", verbose=False)
        viser_compat.refuse_share_tunnel(self.viser)  # before any browser can ask for it
        self.viser.scene.set_up_direction("+z")
        self.viser.gui.configure_theme(control_width="large", show_share_button=False)
        self._lock = threading.Lock()
        self.sessions: dict[int, LabSession] = {}  # this process's own sessions
        self.turned_away: set[int] = set()
        self.seats = seats or server_processes.Seats(shared=processes > 1)  # sessions of all processes
        self.shared_session: LabSession | None = None
        self.closed_sessions = 0
        self.trimmer = memory.Trimmer()  # returns what closed sessions freed to the system (app/memory.py)
        # an installation's first compilation (about 20 s) said in every browser, not only on stderr
        self.compile_notices = CompileNotices(self._open_sessions).attach()
        # --shared: only the browser that opened the presenter's secret address may change anything
        self.presenter_path: str | None = None
        self._presenters: set[int] = set()  # browsers seen connected on the presenter's address
        if shared and presenter:
            name = f"presenter-{secrets.token_urlsafe(18)}.html"
            if add_alias(name):
                self.presenter_path = "/" + name
        if shared:
            self.shared_session = self._start_session(self.viser, preset, links, shared=True)
            if self.setup:
                self.shared_session.load_setup(self.setup, "the setup file")
            if lecture:
                self.shared_session.set_lecture(True)
            if not autoplay:  # loading the setup may have played it: the lecture starts when the presenter says
                self.shared_session.wait_at_start()
        self.viser.on_client_connect(self._connect)
        self.viser.on_client_disconnect(self._disconnect)
        self.siblings: server_processes.Siblings | None = None
        if processes > 1:
            options = {"host": host, "preset": preset, "links": links, "method": method,
                       "max_sessions": max_sessions, "warm": warm, "setup": self.setup,
                       "mechanism": mechanism, "mechanism_label": mechanism_label, "lecture": lecture}
            try:
                self.siblings = server_processes.start_siblings(processes - 1, self.port, options, self.seats)
            except BaseException:
                self.stop()
                raise

    # ------------------------------------------------------------------ address
    @property
    def port(self) -> int:
        """The port really served (viser moves to the next free one when the requested one is busy)."""
        return self.viser.get_port()

    @property
    def url(self) -> str:
        host = self.host if ":" not in self.host else f"[{self.host}]"
        return f"http://{host}:{self.port}"

    # ------------------------------------------------------------------ sessions
    @property
    def presenter_url(self) -> str | None:
        """``--shared``: the address whose browser controls the session (None without a presenter lock)."""
        return None if self.presenter_path is None else self.url + self.presenter_path

    def _connect(self, client) -> None:
        if self.shared_session is not None:
            self._seat_in_audience(client)
            self.shared_session.frame_camera(client=client)  # the newcomer only; the others keep their view
            self._shared_link(client)
            return
        if not self.seats.take(self.max_sessions):
            with self._lock:
                self.turned_away.add(client.client_id)
            self._turn_away(client)
            return
        session = None
        try:
            setup, refused = self._setup_of(client)
            setup, lecture_mode, refused_lecture = lecture_from(setup, self.lecture)
            refused += refused_lecture
            setup, design_mode, refused_design = design_flag_from(setup)  # ?design=1 (app/design_view.py)
            refused += refused_design
            setup, sketch, refused_sketch = sketch_from(setup)  # ?sketch=: a design's link (app/design_view.py)
            refused += refused_sketch
            preset, links, not_started = share.start_of(setup, self.preset, self.links, mechanisms=True)
            named = dict(setup).get("preset") == preset  # the link's own preset wins over the server's start
            session = self._start_session(client, preset, links, shared=False,
                                          mechanism=preset if named and is_mechanism(preset) else None,
                                          chain=named and not is_mechanism(preset))
            # the link's values by the names of the session's panel, chain or mechanism
            refused += not_started + share.apply_setup(setup, session.set_link_value)
            if lecture_mode:
                session.set_lecture(True)
            if (design_mode or sketch is not None) and (designer := getattr(session, "design_view", None)):
                if sketch is not None:
                    designer.open_design(sketch)
                designer.set_designing(True)
            if refused:
                session.show_notice("Not applied from the link", "; ".join(refused))
            elif (compiling := self.compile_notices.line) is not None:  # arrived while the process compiles
                session.show_notice(COMPILE_TITLE, compiling, color="blue")
        except Exception as error:  # never let one browser's start take the server down
            traceback.print_exc()
            reason = f"{type(error).__name__}: {error}"
            quietly(lambda: client.add_notification("Could not start a session", reason, color="red"),
                    "telling a browser its session failed")
        finally:
            kept = False
            with self._lock:
                if session is not None and client.client_id in self.viser.get_clients():
                    self.sessions[client.client_id] = session
                    kept = True
            if not kept:
                if session is not None:  # the browser left while its session was being built
                    self._closed(session)
                    session = None
                self.seats.release()
            self._rebalance()

    def _start_session(self, target, preset: str, links: int | None, *, shared: bool,
                       mechanism: str | None = None, chain: bool = False,
                       saved: share.SavedSetup | None = None) -> LabSession:
        """The one session (app/session.py) on ``target``: the server's mechanism when it starts with one
        (``--mechanism``, a mechanism preset), ``mechanism`` when a link names one, a setup file's description
        (``saved``), or else the chain ``preset`` (``chain``: whatever the server starts with; a share link names
        it), hosted as the chain written as a mechanism. Its menu then goes to any preset in the same session."""
        play = self.autoplay or not shared  # a lecture waits for the presenter's Play (--autoplay: it plays)
        if saved is not None and saved.mechanism is not None:
            session: LabSession = Session(target, saved.mechanism, label=saved.label, shared=shared, autoplay=play)
        elif mechanism is None and self.mechanism is not None and not chain:
            session = Session(target, self.mechanism, label=self.mechanism_label, shared=shared, autoplay=play)
        elif mechanism is not None:
            session = Session(target, MECHANISM_PRESETS[mechanism](), label=mechanism, shared=shared, autoplay=play)
        else:
            params = SessionParameters.from_preset(preset, links=links, method=self.method)
            session = Session.for_chain(target, params, shared=shared, autoplay=play)
        if shared and self.presenter_path is not None:
            session.is_presenter = self.is_presenter
        return session

    def is_presenter(self, client_id: int | None) -> bool:
        """Whether this browser opened the presenter's address. Fails closed: an unknown sender, a connection
        never seen open on that address (a viewer's upload finishing after it left) or a viser that hides the
        path is no presenter. A browser seen connected on the presenter's address stays one, so that what it
        sent just before leaving is still its own (viser never reuses a client id within a server)."""
        if client_id is None or self.presenter_path is None:
            return False
        with self._lock:
            if client_id in self._presenters:
                return True
        path = viser_compat.connection_path(self.viser, client_id)
        # the presenter's page opened with a share link connects under its own address (static/page.html)
        if path != self.presenter_path and not (path or "").startswith(self.presenter_path + share.SETUP_PATH):
            return False
        with self._lock:
            self._presenters.add(client_id)
        return True

    def _seat_in_audience(self, client) -> None:
        """A browser of the shared session other than the presenter's is a viewer: its controls are drawn
        read-only and a line says who controls (the server refuses its changes in any case)."""
        if self.presenter_path is None or self.is_presenter(client.client_id):
            return

        def tell() -> None:
            client.gui.add_markdown(VIEWER_LINE, order=-1000.0)
            client.gui.add_html(VIEWER_STYLE)

        quietly(tell, "showing a viewer who controls the session")

    def _shared_link(self, client) -> None:
        """A share link opened on the shared session: the presenter's page (or anyone's, without a presenter
        lock) applies its setup to the session, which then waits at t = 0 unless ``autoplay``; a viewer's page
        is told once that the presenter controls the setup (nothing applied)."""
        session = self.shared_session
        if session is None:
            return
        path = viser_compat.connection_path(self.viser, client.client_id) or ""
        presenter = self.presenter_path is None or self.is_presenter(client.client_id)
        if presenter and self.presenter_path is not None and path.startswith(self.presenter_path):
            path = path[len(self.presenter_path):]
        try:
            pairs = share.setup_from_path(path)
        except LinkageError as error:
            reason = str(error)
            quietly(lambda: client.add_notification("Link not applied", reason, color="yellow"),
                    "telling a browser its link was refused")
            return
        if not pairs:
            return
        if not presenter:
            quietly(lambda: client.add_notification(
                "The presenter controls the setup", "This page's link is not applied: everyone watches the "
                "presenter's session, set up from the presenter's page.", color="blue", auto_close_seconds=None),
                "telling a viewer the presenter controls the setup")
            return
        pairs, design_mode, refused_design = design_flag_from(pairs)  # ?design=1: the presenter designs
        pairs, sketch, refused_sketch = sketch_from(pairs)  # a design's link (app/design_view.py)
        if refused_design + refused_sketch:
            session.show_notice("Not applied from the link", "; ".join(refused_design + refused_sketch))
        if pairs:
            session.guard(lambda: session.open_setup(share.SavedSetup(pairs, where="the link")))
            if not self.autoplay:
                session.wait_at_start()
        if (designer := getattr(session, "design_view", None)) is not None:
            if sketch is not None:
                session.guard(lambda: (designer.open_design(sketch), designer.set_designing(True)))
            elif design_mode:
                session.guard(lambda: designer.set_designing(True))

    def _setup_of(self, client) -> tuple[list[tuple[str, str]], list[str]]:
        """The setup a share link carries (app/share.py), and why it cannot be read if so."""
        try:
            link = share.setup_from_path(viser_compat.connection_path(self.viser, client.client_id)) or []
        except LinkageError as error:
            return list(self.setup), [str(error)]
        return share.merged(self.setup, link), []

    def _rebalance(self) -> None:
        """Share the frame budget among the sessions (see FRAME_BUDGET)."""
        with self._lock:
            sessions = list(self.sessions.values())
        count = max(len(sessions), 1)
        fps = 60.0 if count <= FULL_RATE_SESSIONS else max(MIN_SESSION_FPS, min(60.0, FRAME_BUDGET / count))
        for session in sessions:
            session.player.frame_interval = 1.0 / fps

    def _turn_away(self, client) -> None:
        text = (
            "## Linkage Lab is full\n\n"
            f"This server runs at most **{self.max_sessions}** simulations at once, and all are in use. "
            "Close another tab, or try again in a moment (reload this page)."
        )

        def tell() -> None:
            client.gui.add_markdown(text)
            client.gui.add_html(READY_HTML)  # the loading screen gives way to this message
            client.add_notification("Server full", f"At most {self.max_sessions} sessions; reload later.",
                                    color="red", auto_close_seconds=None)

        quietly(tell, "telling a browser the server is full")  # it may have left already

    def _disconnect(self, client) -> None:
        with self._lock:
            session = self.sessions.pop(client.client_id, None)
            self.turned_away.discard(client.client_id)
        if session is not None:
            self._closed(session)
            session = None  # this frame runs on (_rebalance): it must not be what keeps the session
            self.seats.release()  # a seat is free only once the trim that frees its session is asked for
        self._rebalance()

    def _closed(self, session: LabSession) -> None:
        """Close a session that has left ``sessions`` and ask the memory trim for it. The trim waits for what
        may still hold it after this returns (its player's thread finishing a chunk; this very callback and
        viser's pool item holding the client until they return) before it counts the session as released."""
        session.close()
        with self._lock:
            self.closed_sessions += 1
        player = getattr(session, "player", None)  # its thread may outlive close() (a chunk still in a worker)
        self.trimmer.request(finishing=player.thread if player is not None else None, closed=session)

    def _open_sessions(self) -> list[LabSession]:
        """Every session of this process that browsers watch (own sessions and the shared one)."""
        with self._lock:
            sessions = list(self.sessions.values())
        return sessions + ([self.shared_session] if self.shared_session is not None else [])

    def session_for(self, client_id: int) -> LabSession | None:
        with self._lock:
            return self.sessions.get(client_id)

    def wait_for_sessions(self, count: int, timeout: float = 30.0) -> list[LabSession]:
        """Block until ``count`` sessions exist (tests); returns them."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with self._lock:
                if len(self.sessions) >= count:
                    return list(self.sessions.values())
            time.sleep(0.01)
        raise TimeoutError(f"expected {count} sessions, have {len(self.sessions)} after {timeout} s")

    # ------------------------------------------------------------------ lifetime
    @property
    def pids(self) -> list[int]:
        """Every process serving this server (this one first)."""
        return [os.getpid(), *(self.siblings.pids if self.siblings is not None else [])]

    def stop(self) -> None:
        siblings = getattr(self, "siblings", None)
        if siblings is not None:  # they stop their sessions while this process stops its own
            siblings.ask_to_stop()
        with self._lock:
            sessions = list(self.sessions.values())
            self.sessions.clear()
        # closed side by side: each waits for its own player thread, and one after another they outlasted the
        # grace period of app/lifetime.py with a few browsers open
        closers = [threading.Thread(target=session.close, name="session-close", daemon=True) for session in sessions]
        for closer in closers:
            closer.start()
        for closer in closers:
            closer.join()
            self.seats.release()
        if siblings is not None:
            siblings.stop()
            self.siblings = None
        if self.shared_session is not None:
            self.shared_session.close()
        with contextlib.redirect_stdout(io.StringIO()):
            self.viser.stop()
        replay.stop_recorder()
        self.trimmer.stop()
        self.compile_notices.detach()

    def serve_forever(self) -> None:
        """Serve until Ctrl+C, SIGTERM or SIGHUP (app/lifetime.py), then stop every session and process."""
        try:
            lifetime.wait_for_stop(SIGNAL_CHECK_SECONDS)
        except KeyboardInterrupt:  # a Ctrl+C with no handler installed (a test's server in the main thread)
            pass
        finally:
            self.stop()
