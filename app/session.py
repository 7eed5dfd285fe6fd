"""One browser's (or, with ``--shared``, one lecture's) simulation: parameters, runs, playback, lifetime.

A :class:`Session` is built on a target, a ``viser.ClientHandle`` (its own GUI and scene) or the
``viser.ViserServer`` itself (shared by every browser), and assembles its parts:

* :mod:`app.commands` applies every edit by name through the pydantic models (:meth:`Session.set`);
* :class:`~app.frame_view.FrameView` draws the player's frames (poses, traces, arrows, plots, status);
* :class:`~app.camera.CameraDirector` frames the mechanism in each browser;
* :class:`~app.notices.Notices` shows one notice per action;
* :class:`~app.controls.Controls` and :class:`~app.analysis.Analysis` see the session only through
  :class:`~app.ports.SessionPort`.

GUI callbacks call one public method through :meth:`Session.guard`, which turns any exception into a notice in
that browser (and pauses the session when the error is not a plain invalid value), so one session's trouble
never reaches the server or the other sessions. Changing a physical parameter continues the motion from the
displayed state; changing the start (initial angles, mechanism, reset, compare mode) starts again at t = 0.
"""

from __future__ import annotations

import itertools
import math
import threading
import time
import traceback
import warnings
from typing import Callable

import numpy as np

import physics
from physics import LinkageError
from physics.mechanism import MECHANISM_PRESETS
from physics.model import validated

from . import chain_knobs, commands, delivery, export, mechanism_runs, readout, share, viser_compat, warm
from .analysis import Analysis
from .camera import CameraDirector
from .commands import CONTROL, SI
from .controls import Controls
from .divergence import DivergencePlots, reference_spec
from .frame_view import COMPARE_METHODS, FrameView, reactions_available
from .free_body_view import FreeBodyView
from .lab_session import Kind, SessionBase
from .logs import quietly
from .notices import Notices, ViewerRefusals
from .page import READY_HTML
from .parameters import (
    METHOD_LABELS,
    Display,
    SessionParameters,
    in_menu_words,
    methods_for,
    settings_data,
)
from .player import Frame, Player, RunSpec
from .report_tab import ReportTab
from .viser_compat import check_gui_updates

# Show the "deriving equations" notice only when loading takes longer than this: a warm cache loads in well
# under a second; a new mechanism derives and compiles in a few seconds (the very first run of an installation
# also compiles the integrators, about half a minute).
PREPARE_NOTICE_DELAY = 1.0
MAX_GOTO_TIME = 1e5

# Between a browser closing and its session being closed, a frame or two may still be queued to the departed
# connection; viser warns about each. The session stops right after, so these writes are expected.
warnings.filterwarnings("ignore", message=r"Queued a \w+ on a closed connection")

_ids = itertools.count(1)




def _settings_for_chunk(settings, horizon: float, samples: int):
    return settings.model_copy(update={"t_end": horizon, "samples": samples})


class Session(SessionBase):
    """State and behaviour of one simulation shown in one browser (or in all, when shared)."""

    kind: Kind = "chain"

    def __init__(
        self,
        target,
        *,
        preset: str = "triple-a",
        links: int | None = None,
        method: str | None = None,
        shared: bool = False,
        autoplay: bool = True,
        simulate: Callable | None = None,
    ) -> None:
        self.id = next(_ids)
        self.target = target
        self.shared = shared
        self.closed = False
        self.created = time.time()
        self._lock = threading.RLock()
        # --shared with a presenter: whether a browser (client id) may change anything (None: every browser may)
        self.is_presenter: Callable[[int], bool] | None = None
        # a general mechanism's preset chosen in the menu: the server replaces this session (app/server.py)
        self.on_switch: Callable[..., None] | None = None  # (name, optional setup)
        self.params = SessionParameters.from_preset(preset, links=links, method=method)
        self._user_paused = not autoplay
        self._start_params: SessionParameters | None = None  # parameters of the latest start (t = 0)
        self._last_good_params: SessionParameters | None = None  # of the latest start that could move
        self.player = Player(
            simulate=simulate or physics.simulate,
            make_settings=_settings_for_chunk,
            on_frame=self._on_frame,
            on_failure=self._on_failure,
            prepare=self._prepare,
            name=f"player-{self.id}",
            ready_for_frame=None if shared else (lambda: delivery.caught_up(target)),
        )
        try:
            self.notices = Notices(self._clients, self._refresh_status, self._connection_open)
            self.view = FrameView(target, self.player.lock, lambda: self.notices.text)
            self.camera = CameraDirector(target, shared)
            self.controls = Controls(self, target.gui)
            check_gui_updates(target.gui, self._refuse_update, self.may_change, ViewerRefusals(target, shared))
            viser_compat.guard_messages()  # malformed messages dropped before viser reads them (one log line)
            self.view.panel = self.controls
            self.view.divergence = DivergencePlots(target.gui, COMPARE_METHODS, self.controls.divergence_plot)
            self.analysis = Analysis(self, self.controls, target.scene)
            self.free_body = FreeBodyView(target.scene, lambda: self.view.display.arrow_scale,
                                          redraw=self.player.touch)
            self.report = ReportTab(self, self.controls, self.free_body)
            self._label_changed()
            self.view.build(self.params)
            self.view.show_start(self.params)
            self.frame_camera(force=True)
            self._restart_fresh(play=autoplay)
            target.gui.add_html(READY_HTML)  # the page's loading screen gives way to the panel (app/page.py)
        except BaseException:
            self.player.stop()  # no thread left behind by a session that could not start
            raise

    # ================================================================== the port (what the panel reads)
    @property
    def setup(self) -> SessionParameters:
        return self.params

    @property
    def display(self) -> Display:
        return self.view.display

    @property
    def compare(self) -> bool:
        return self.view.compare

    @property
    def reactions_on(self) -> bool:
        return self.view.reactions_on

    @property
    def trace_seconds(self) -> float:
        return self.view.display.trace_seconds

    @property
    def reaction_scale(self) -> float:
        return self.view.display.arrow_scale

    @property
    def notice(self) -> str | None:
        return self.notices.text

    # the view's parts, by the names scripts and tests know
    scene = property(lambda self: self.view.scene)
    trace = property(lambda self: self.view.trace)
    arrows = property(lambda self: self.view.arrows)
    compare_scenes = property(lambda self: self.view.compare_scenes)
    last_frame = property(lambda self: self.view.last_frame)
    frames_sent = property(lambda self: self.view.frames_sent)

    def displayed_state(self) -> tuple[float, np.ndarray, np.ndarray] | None:
        return self.player.current_state()

    def state_at(self, t: float, exact: bool = False) -> tuple[np.ndarray, np.ndarray] | None:
        """The displayed run's ``(theta, omega)`` at time ``t`` (interpolated between samples; ``exact``: only at
        a sample's time), if stored."""
        return self.player.state_at(t, exact)

    # ================================================================== error boundary and notices
    def guard(self, action: Callable[[], object]) -> object:
        """Run one GUI action; show any error as a notice in this browser instead of raising.

        An invalid value (LinkageError) leaves the session as it was and puts the controls back on the values
        in force; anything else pauses it and offers Reset. Returns the action's result, or None after an error.
        """
        try:
            return action()
        except LinkageError as error:
            self.show_notice("Not applied", in_menu_words(str(error)), color="yellow")
            self.controls.sync_all()
        except Exception as error:  # the boundary: nothing escapes into viser's callback thread
            traceback.print_exc()
            quietly(self.player.pause, "pausing after an error")
            self.show_notice(
                "Session paused",
                f"{type(error).__name__}: {error}. Press Reset to start again.",
                color="red",
            )
        return None

    def load_setup(self, pairs: list[tuple[str, str]], where: str = "the setup") -> None:
        """Apply a share link's or a setup file's ``(name, value)`` pairs (app/share.py): the mechanism first,
        then each value; what the models refuse is listed in one notice, the rest applied.

        A setup that names its preset (every saved one does) starts from that preset's values, as a general
        mechanism's does: what the file leaves out is the preset's, not an edit made before loading it. The
        integration choices in force (``--method``, the panel's) are kept unless the file names them. A file
        that names no preset is a patch on what is shown."""
        preset, links, refused = share.start_of(pairs, self.params.preset, None)
        if any(name == "preset" for name, _ in pairs) or preset != self.params.preset or links is not None:
            self.set_mechanism(preset, links)
        refused += share.apply_setup(pairs, lambda name, text: self.set(name, text, CONTROL))
        if refused:
            self.show_notice(f"Not applied from {where}", "; ".join(refused))

    def upload_setup(self, client_id: int | None, name: str, content: bytes) -> None:
        """A setup file chosen in the Export tab (a viewer of a presenter's session may not load one)."""
        if not self.may_change(client_id):
            raise LinkageError("setup file: the presenter controls this session")
        saved = share.setup_from_state(content, f"setup file {name[:60]!r}")
        if saved.names_a_mechanism and self.on_switch is not None:  # a general mechanism's: its session loads it
            if saved.mechanism is not None:
                mechanism_runs.start_state(saved.mechanism)  # it must assemble before this session goes
            self.on_switch(saved.preset or saved.label, saved)
            return
        self.load_setup(saved.pairs, saved.where)

    def set_link_value(self, name: str, text: str) -> None:
        """One value of a share link or a setup file, in the panel's units (degrees, milliseconds)."""
        self.set(name, text, CONTROL)

    def set_value(self, name: str, text: str) -> None:
        """One ``snapshot --set NAME=VALUE``, in SI units as ``python -m physics --set``."""
        self.set(name, text)

    def _refuse_update(self, handle, problem: str) -> None:
        """A value no browser sends for this control (a hostile client's): a notice, and the controls put back
        on the values in force (runs on viser's event loop; nothing was applied)."""
        self.show_notice("Not applied", f"{handle.label}: {problem}", color="yellow")
        quietly(self.controls.sync_all, "putting the controls back after a refused value")

    def clear_notice(self) -> None:
        self.notices.clear()

    def _refresh_status(self) -> None:
        if not self.closed:
            self.controls.show_status(self.view.status_text(self.player.playing, self.player.real_time_factor()))

    def _label_changed(self) -> None:
        p = self.params
        self.view.label = f"{METHOD_LABELS.get(p.method, p.method)} · {p.integrator}"

    # ================================================================== camera
    def frame_camera(self, force: bool = False, client=None) -> None:
        """Frame the mechanism (all cameras of the session, or only ``client``'s)."""
        self.camera.frame(self.params.L, self.params.pin, force=force, client=client)

    # ================================================================== edits by name
    def set(self, name: str, value, units: str = SI) -> None:
        """Change one value by the names of ``python -m physics --set`` (``L2``, ``m3``, ``theta1``, ``g``, ...),
        a Settings field (``method``, ``integrator``, ``rtol``, ``step``, ``stabilization``, ``baumgarte_alpha``,
        ``baumgarte_beta``, ``damping``), ``pin_x``/``pin_y``, ``trace`` (a traced-point label) or a display
        setting (``speed``, ``trace_seconds``, ``arrow_scale``). ``value`` is a number or a text; in SI units
        (radians, seconds) unless ``units=CONTROL`` (degrees, milliseconds, as the panel shows them).
        LinkageError (nothing changed) when the models refuse it."""
        if name in commands.DISPLAY_NAMES:
            self._set_display(name, value, units)
            return
        with self._lock:
            edit = commands.apply(self.params, name, value, units)
            if name in ("integrator", "rtol", "step") and self.compare:
                self._check_compare(edit.params)
            if edit.restart:
                self.params = edit.params
                self._restart_fresh()
            else:
                try:
                    self._commit(edit.params)
                except (ArithmeticError, np.linalg.LinAlgError) as error:  # closing the loop with extreme values
                    raise LinkageError(f"{name} = {value!r}: too extreme to go on with ({error})") from None
            if edit.geometry:
                self.view.resize(self.params)
                self.frame_camera()
            if not reactions_available(self.params):
                self.view.hide_arrows()
            self._label_changed()
            self.controls.sync_after(name)

    def set_start(self, theta0, omega0, play: bool = False) -> None:
        """Start again at t = 0 from ``(theta0, omega0)`` (n,) in radians (a rest position, app/rest_view.py);
        paused unless ``play``. LinkageError when the models refuse the state."""
        with self._lock:
            self.params = self.params.replaced(theta0=np.array(theta0, dtype=float),
                                               omega0=np.array(omega0, dtype=float))
            self._user_paused = not play
            self._restart_fresh(play=play)
            self.controls.sync_all()

    def set_typed(self, name: str, text: str) -> None:
        """A value typed into its box, in the control's units (degrees, milliseconds), parsed here."""
        self.set(name, text, units=CONTROL)

    def _set_display(self, name: str, value, units: str) -> None:
        display = commands.apply_display(self.view.display, name, value, units)
        self.view.display = display
        self.player.set_speed(display.speed)
        self.player.touch()
        self.controls.sync_after(name)

    def set_camera_view(self, view: str) -> None:
        """``"front"`` (the plane of the motion as a drawing) or ``"3d"``: every camera of this session reframed."""
        self.camera.set_view(view)
        self.view.floor.visible = view != "front"  # a front view is a drawing of the plane: no floor below it

    def set_reactions(self, on: bool) -> None:
        """Reaction arrows on or off (their length: ``set("arrow_scale", ...)``)."""
        self.view.reactions_on = bool(on)
        if not on:
            self.view.hide_arrows()
        self.player.touch()

    def set_compare(self, on: bool) -> None:
        """Run all three formulations from the same start, drawn as three translucent mechanisms."""
        with self._lock:
            if on:
                self._check_compare(self.params)
            self.view.compare = bool(on)
            self.view.build(self.params)
            self.controls.sync_compare()
            if self.view.divergence is not None:
                self.view.divergence.set_visible(self.compare)
            self._restart_fresh()

    def set_mechanism(self, name: str, links: int | None = None) -> None:
        """Load a preset (``links`` for ``chain``), keeping the integration choices where they apply. A general
        mechanism's preset (``jansen-leg``, ...) hands the browser to a mechanism session (``on_switch``, given
        by the server: app/mechanism_session.py)."""
        if isinstance(name, str) and name in MECHANISM_PRESETS and self.on_switch is not None:
            self.on_switch(name)
            return
        if not isinstance(name, str) or name not in physics.preset_names():
            allowed = [*physics.preset_names(), *(MECHANISM_PRESETS if self.on_switch is not None else ())]
            raise LinkageError(f"mechanism = {name!r}: allowed {', '.join(allowed)}")
        with self._lock:
            old = self.params
            new = SessionParameters.from_preset(name, links=links if name == "chain" else None)
            method = old.method if old.method in methods_for(new.chain) else new.method
            kept = {**settings_data(old.settings), "method": method, "trace": new.trace}
            self.params = new.replaced(settings=validated(physics.Settings, **kept))
            self._layout_changed()

    def set_links(self, links) -> None:
        number = commands.parse_links(links)
        if self.params.preset != "chain":
            raise LinkageError("links: only the 'chain' mechanism has a variable number of bars")
        self.set_mechanism("chain", links=number)

    def _layout_changed(self) -> None:
        self._label_changed()
        self.view.build(self.params)
        self.view.show_start(self.params)
        self.controls.rebuild()
        self.report.rebuild()
        self.frame_camera(force=True)
        self._restart_fresh()

    # ================================================================== runs
    @staticmethod
    def _check_compare(params: SessionParameters) -> None:
        """Compare mode runs every formulation with the same settings: all of them must accept those settings
        (the variational integrator, for one, exists for Lagrange only). LinkageError names the one that does not."""
        for method in COMPARE_METHODS:
            try:
                params.settings_for(method)
            except LinkageError as error:
                raise LinkageError(f"compare mode: {error}") from None

    def _specs(self) -> list[RunSpec]:
        p = self.params
        if self.compare:
            specs = [RunSpec(method, p.chain, p.settings_for(method)) for method in COMPARE_METHODS]
            return [*specs, reference_spec(p, COMPARE_METHODS)]  # drawn only in the divergence plots
        return [RunSpec("main", p.chain, p.settings)]

    def _restart_fresh(self, play: bool | None = None) -> None:
        """Start again at t = 0 from the initial state (reset, new start, new mechanism, compare mode)."""
        p = self.params
        specs = self._specs()
        starts = [(p.theta0.copy(), p.omega0.copy()) for _ in specs]
        self._start_params = p
        self.view.segment_t0 = 0.0
        self.clear_notice()
        if play is None:
            play = not self._user_paused
        self.player.restart(specs, 0.0, starts, keep_history=False, play=play)

    def _commit(self, new: SessionParameters) -> None:
        """Adopt ``new`` parameters and go on from the displayed state (a physical parameter changed); a closed
        loop's state is first put back exactly on its loop, and if it cannot close with the new values,
        LinkageError is raised before anything is changed."""
        state = self.player.current_state() if not self.compare else None
        if state is not None and len(state[1]) != new.n:
            state = None  # the displayed run is of another mechanism: start afresh
        if state is not None and new.pinned:
            t, theta, omega = state
            theta, omega = chain_knobs.close_loop(new, theta, omega)  # a pinned chain put on its loop
            state = (t, theta, omega)
        self.params = new
        if state is None:
            self._restart_fresh()
            return
        t, theta, omega = state
        self.view.segment_t0 = t
        self.clear_notice()
        self.player.restart(self._specs(), t, [(theta, omega)], keep_history=True)

    def _prepare(self, spec: RunSpec, theta0: np.ndarray, omega0: np.ndarray) -> None:
        """Have the run's code loaded and its integrator compiled before its first chunk (app/warm.py), with a
        notice in the page when this takes a while (a cold cache: deriving and compiling)."""
        if warm.is_ready(spec.chain, spec.settings):
            return
        method = spec.settings.method
        shown: list = []

        def show() -> None:
            label = METHOD_LABELS.get(method, method)
            closure = "closed loop" if spec.pinned else "open chain"
            shown.extend(self.notices.progress(
                "Deriving equations...",
                f"{label}, {spec.n} bars, {closure}: preparing the equations of motion. The first time, sympy "
                "derives them and LLVM compiles them (a few seconds; the first run of an installation also "
                "compiles the integrators, about half a minute); afterwards they load from the cache.",
            ))
            self.controls.show_status(f"**Deriving equations...** ({label}, {spec.n} bars, {closure})")

        timer = threading.Timer(PREPARE_NOTICE_DELAY, show)
        timer.daemon = True
        timer.start()
        try:
            warm.ensure_ready(spec.chain, spec.settings, theta0, omega0, cancelled=self.player.superseded)
        finally:
            timer.cancel()
            self.notices.dismiss(shown)

    # ================================================================== frames (player thread)
    def _on_frame(self, frame: Frame) -> None:
        if self.closed or not self._connection_open():
            return
        runs = {run.spec.label: run for run in self.player.runs}
        self.view.draw(frame, runs, self.player.playing, self.player.real_time_factor())
        self.free_body.update(frame, runs)
        self.analysis.on_frame(frame.t, frame.restarted)
        if self._start_params is not self._last_good_params and any(len(run.ring) > 1 for run in runs.values()):
            self._last_good_params = self._start_params

    def _on_failure(self, message: str) -> None:
        stuck = all(len(run.ring) <= 1 for run in self.player.runs)
        hint = ("This start cannot move. Press Reset to go back to the last start that ran."
                if stuck else "Press Reset to start again.")
        self.show_notice("Simulation stopped", in_menu_words(f"{message}. {hint}"), color="red", seconds=None)

    # ================================================================== playback
    def play(self) -> None:
        self._user_paused = False
        if self.last_frame is not None and not self.player.restart_pending and any(
            run.failed for run in self.player.runs
        ):
            t_last = min(run.ring.t_last for run in self.player.runs)
            if self.player.display_time >= t_last - 1e-9:
                raise LinkageError("the simulation stopped here; press Reset (or change a parameter) to go on")
        self.player.play()

    def pause(self) -> None:
        self._user_paused = True
        self.player.pause()
        self.player.touch()  # the status line says "paused" at once (a paused player draws no new frame)

    def step(self) -> None:
        self._user_paused = True
        self.player.step()

    def refresh_plots(self) -> None:
        """Redraw the chosen plot now (it was just chosen; a paused player draws no new frame)."""
        self.player.touch()

    def scrub(self, t) -> None:
        """Show time ``t`` of the run so far (the timeline), paused there; Play goes on from it."""
        number = commands.parse_number("timeline", commands.TIMELINE, t)
        if not 0.0 <= number <= MAX_GOTO_TIME:
            raise LinkageError(f"timeline = {number:g} s: allowed range 0 <= timeline <= {MAX_GOTO_TIME:g} s")
        self._user_paused = True
        self.player.seek(number, timeout=0.0)  # returns at once; the player shows it when it can

    def reset(self) -> None:
        """Start again at t = 0. If the current start cannot move at all (a singular position), go back to
        the last start that did, so Reset always recovers."""
        with self._lock:
            self.player.error = None
            stuck = bool(self.player.runs) and all(
                run.failed is not None and len(run.ring) <= 1 for run in self.player.runs
            )
            good = self._last_good_params
            if stuck and good is not None and good is not self.params:
                layout = (good.n, good.pinned) != (self.params.n, self.params.pinned)
                self.params = good
                self._label_changed()
                if layout:
                    self.view.build(good)
                    self.controls.rebuild()
                    self.report.rebuild()
                else:
                    self.view.resize(good)
                self.controls.sync_all()
                self.frame_camera()
            self._restart_fresh()

    def goto_time(self, t: float, timeout: float = 120.0) -> bool:
        """Pause at simulated time ``t`` from the start (for pictures and tests); True when shown."""
        if not (math.isfinite(t) and 0.0 <= t <= MAX_GOTO_TIME):
            raise LinkageError(f"time = {t}: allowed range 0 <= time <= {MAX_GOTO_TIME:g}")
        with self._lock:
            self._user_paused = True
            self._restart_fresh(play=False)
        self.player.wait_idle(timeout)
        return self.player.seek(t, timeout)

    # ================================================================== analysis tab
    def work_precision_chart(self) -> None:
        """Compute the work-precision chart for the current parameters in a worker; shown in the Analysis tab."""
        self.analysis.work_precision_chart()

    def chaos_map(self) -> None:
        """Compute a small chaos map of the double pendulum in a worker; shown in the Analysis tab."""
        self.analysis.chaos_map()

    def set_ensemble(self, on: bool, count=None) -> None:
        """Draw (or stop drawing) ``count`` copies whose initial angles differ by 1e-9 rad."""
        self.analysis.set_ensemble(on, count)

    # ================================================================== export and snapshot (app/readout.py)
    def history(self, label: str = "main") -> dict:
        """The stored samples of one run up to the displayed time (for export), as arrays."""
        return readout.history(self.player, label)

    def export_csv(self) -> bytes:
        return export.to_csv(self.history(), self.params)

    def export_json(self) -> bytes:
        return export.to_json(self.history(), self.params, self.run_label())

    def export_html(self) -> str:
        return readout.replay(self.history(), self.params, self.run_label())

    def run_label(self) -> str:
        p = self.params
        return f"{p.preset} ({p.n} bars), {METHOD_LABELS.get(p.method, p.method)}, {p.integrator}"

    def download(self, kind: str, client=None) -> None:
        """Send the run (``csv``, ``json``, ``html``) or the equations (``tex``) to ``client`` (or this
        session's browser(s))."""
        name, content = readout.download_file(self, kind)
        (client or self.target).send_file_download(name, content)

    def snapshot(self) -> dict:
        """JSON-able state for tests and ``python -m app snapshot --json`` (docs/app.md lists the keys)."""
        return readout.snapshot(self)

    # ================================================================== lifetime
    def close(self, clean: bool = False) -> None:
        """Stop the player and drop the scene (the server calls this when the browser goes away); with
        ``clean`` remove every node and control too (the browser stays: a switch to a mechanism session)."""
        if not self._stop():
            return
        self.controls.close()
        self.analysis.remove()
        self.report.remove()
        if self.shared or clean:  # the scene and panel outlive this session: clean them
            self.view.remove()
            self.controls.remove()
            if self.view.divergence is not None:
                self.view.divergence.remove()
