"""One browser's (or, with ``--shared``, one lecture's) linkage: a triple pendulum, a four-bar, a slider-crank, a
six-bar, a Jansen leg: the app's one session class (issue 24), every linkage a mechanism.

A :class:`Session` runs any mechanism of ``physics.mechanism``: the player (app/player.py, through
:class:`app.mechanism_runs.MechanismSpec`), batched scene nodes, notices, presenter lock and delivery pacing,
and a panel generated from the
mechanism's description (app/mechanism_edits.py): per body its size, mass and inertia, per motor its speed or
torque, gravity; the formulation (DAE, Lagrange, Newton-Euler on a spanning tree, or the reduced model for
mobility 1) and the stabilisation; the traced point (any named point of any body); reaction arrows at the
pins; energy and, for a speed motor, the driving torque over time.

It can also host a chain (issue 24, "One app session"): :meth:`Session.for_chain` runs a chain preset's
:class:`app.parameters.SessionParameters` as ``physics.mechanism.chains.chain_mechanism`` hanging down, from the
chain's own start, with the chain's knobs and names (app/chain_knobs.py: ``L1``, ``m2``, ``g``, ``theta1``,
``pin_x``, ``damping``, the number of bars), every edit through the chain's command layer (app/commands.py), the
chain session's share link and a four-bar's reach line; ``self.chain`` holds the chain's parameters in force
(None for a mechanism). The server opens every preset in this one session, and its menu goes from any preset to
any other in the same session (the browser keeps its seat, its panel and its tabs). A hosted chain answers
as the chain session did (its snapshot, downloads, ``params``, ``set``, ``set_start``, ``history``, ...).
Every GUI callback goes through :meth:`guard`: a refused value is one notice naming the body or joint, the field
and the allowed range, and the session goes on.
"""

from __future__ import annotations

import dataclasses
import html
import math
import threading
import traceback
import urllib.parse
from pathlib import Path
from typing import Any, Callable, cast

import numpy as np

from physics import LinkageError, Settings, preset_names
from physics.mechanism import MECHANISM_PRESETS, Mechanism, analyse, structure_key
from physics.mechanism.assembly import mobility_text_for
from physics.mechanism.chains import chain_state
from physics.mechanism.files import mechanism_from_bytes
from physics.mechanism.singularity import NEAR_SINGULAR_CONDITION
from physics.mechanism.topology import joint_bodies
from physics.model import FIXED_STEP_INTEGRATORS, INTEGRATOR_NAMES, validated

from . import chain_contract, chain_knobs, commands, delivery, lecture, panel_rows, readout, share, viser_compat
from .camera import CameraDirector
from .commands import CONTROL, DISPLAY_NAMES, SI, TIMELINE, apply_display, parse_number, read_number
from .design_view import DesignView
from .divergence import VISIBLE_GAP
from .drag_start import DragStart
from .free_body_view import FreeBodyView, fbd_command
from .lab_session import SessionBase
from .logs import quietly
from .mechanism_analysis import MechanismAnalysis
from .mechanism_compare import COMPARE_METHODS, MechanismCompare, compare_specs
from .mechanism_edits import (
    START_NAMES,
    Knob,
    apply_edit,
    apply_setting,
    knobs,
    settings_knobs,
    shown_value,
    start_knobs,
    start_value,
)
from .mechanism_runs import (
    MechanismSettings,
    MechanismSpec,
    allowed_integrators,
    centres_at,
    check_integrator,
    check_method,
    is_reduced,
    points_at,
    route_options,
    run_file,
    start_state,
    torque_rows,
)
from .mechanism_scene import MechanismScene
from .mechanism_start import FreeCoordinate, free_coordinates, pose_with, velocities_with
from .mechanism_workers import POOL
from .notices import NOTICE_SECONDS, Notices, ViewerRefusals
from .number_inputs import TYPING_PAUSE_S, NumberInputs
from .overlays import (
    ENERGY_COLORS,
    METHOD_COLORS,
    Plot,
    ReactionArrows,
    TraceLine,
    chart_color,
    relative_drift,
    status_markdown,
)
from .page import READY_HTML
from .parameters import (
    METHOD_LABELS,
    Display,
    SessionParameters,
    in_menu_words,
    method_from_label,
    method_label,
    settings_data,
)
from .phase_view import BAR_COLORS, phase_picture
from .player import SAMPLE_DT, Frame, Player
from .report_view import SeedReportPanel
from .resources import STATIC
from .rest_view import MechanismRests, RestPositionsPanel
from .scene import pose_disc
from .text import markdown_literal
from .viser_compat import check_gui_updates

METHODS = {"dae": "DAE (maximal coordinates)", "lagrange": "Lagrange (spanning tree)",
           "newton_euler": "Newton–Euler (spanning tree)", "reduced": "Reduced (1 dof)",
           "reduced_fixed": "Reduced, first free joint fixed (1 dof)"}
STABILIZATIONS = ("projection", "baumgarte", "none")
START_KINDS = {name for names in START_NAMES.values() for name in (names[0], names[2])}
SETTING_KNOBS = tuple(knob.name for knob in settings_knobs(MechanismSettings()))
PLOT_SECONDS = 20.0
PLOT_EVERY = 12  # frames between plot updates (5 Hz, as the chain panel)
STATUS_EVERY = 15
REFUSED = "Not applied"  # the title of a refused value's notice (taken down by the next action applied)
ARROW_FRACTION = 0.25  # at the default arrow scale the largest pin force is drawn this fraction of the size long
RESIDUAL_TITLE = "Constraint residual (largest |Φ(q)|)"
PREPARED_HERE: set[tuple] = set()  # what _prepare has made ready for the chains this process runs itself
PREPARE_STEPS = 10  # integrator steps of the compiling call before a run's first chunk (see _prepare)
PREPARE_NOTICE_DELAY = 1.0
MAX_GOTO_TIME = 1e5  # as the chain session's
TRANSPORT = ("Play", "Pause", "Step", "Reset")  # the Playback row: the page's keys Space, S and R press them
DOWNLOADS = ("CSV", "JSON")  # the run, as the mechanism command writes it
MECHANISM_HELP = """**The scene:** each body in its colour (a bar, or a plate's outline); dark balls are pins, small grey
ones other named points, white ones centres of mass; grey blocks are ground points and a grey line a slider's
guide. The magenta line is the traced point's last seconds (the trace length, 4 s at first).

**Playback:** Play, Pause, Step (one sample, 1/60 s), Reset (the start in force, t = 0); the keys Space, S and
R press them. **Timeline:** drag back through the run so far (it pauses there). **View:** Front (the plane of
the motion as a drawing) or 3D; the F key presses Front. **Plot:** energy (and, without a motor, its relative
error), the coordinates the start is set by over time (for a mechanism its motors fix, the angle of each body
a motor turns), or the phase portrait of the first of them. A mechanism with a loop shows its constraint
residual too.

**Mechanism tab:** a chain preset brings the chain panel back; a mechanism preset or your file starts here. The
line under it gives the bodies, joints, mobility and motors. **Bodies and motors:** size (m: the body is scaled
about its first point and the mechanism re-assembled; the run starts again), m (kg), I (kg·m²), a motor's speed
(°/s) or torque (N·m), a gear pair's ratio and offset (°), g (m/s²). **Start (t = 0):** for a mechanism its
motors leave free, the angle (or position) and speed of each free coordinate; the rest of the mechanism is
assembled around them. A value that cannot be used is refused with a notice naming the body or joint, the
field and the range.

**Simulation tab:** the method (DAE: maximal coordinates, every reaction in one solve; Lagrange and
Newton-Euler: spanning tree, cut joints closed by multipliers; Reduced: one joint coordinate, mobility 1), the
integrator (variational: Lagrange only; the reduced model: DOP853), its tolerance or fixed step, and how the
loops stay closed. They go on from the displayed state. **Compare formulations:** Newton-Euler (blue),
Lagrange (orange) and the DAE (green) from the same start; under the panel, how far their traced points part,
and each one's error against a converged run.

**Display tab:** playback speed, trace length, the traced point, reaction arrows and their scale, and the
free-body diagram of the chosen body at the time
shown (couples are listed).

**Export:** a link to this setup; the setup saved as a file (a file's mechanism inside it) and loaded back (a
chain's setup brings the chain panel back); the run up to the time shown as CSV or JSON, or as an HTML replay
that plays without the server. **Equations:** the system
A x = b the chosen method integrates, for this mechanism.

**Plots:** energy (kinetic, potential, total) and, for a motor holding a speed, the torque it must give
(inverse dynamics). The status line shows the energy error of an undriven mechanism, the largest constraint
residual, and warns near a singular pose (a change point or a dead centre).
"""

def _choice(field: str, value: object, allowed: list[str]) -> None:
    """A menu's value: one of ``allowed`` (a client may send anything: a list, None, markup)."""
    if not isinstance(value, str) or value not in allowed:
        raise LinkageError(f"{field} = {value!r}: allowed values {', '.join(allowed)}")


def plotted_coordinates(mechanism: Mechanism, free: tuple[FreeCoordinate, ...]) -> tuple[FreeCoordinate, ...]:
    """The coordinates the Plot menu draws over time and in the phase portrait: the start's free ones (what the
    Start folder sets); for a mechanism its motors fix (mobility 0) the angle of each body a motor turns (what
    one watches go round), so that the menu shows a motion for every mechanism."""
    if free:
        return free
    names = [body.name for body in mechanism.bodies]
    joints = {joint.name: joint for joint in mechanism.joints}
    turned: list[FreeCoordinate] = []
    for driver in mechanism.drivers:
        ends = joint_bodies(joints[driver.joint]) if driver.joint in joints else None
        body = next((end for end in ends or () if end in names), None)
        if body is not None and all(c.body != body for c in turned):
            turned.append(FreeCoordinate(body, "angle", 3 * names.index(body) + 2))
    return tuple(turned)


def coordinate_label(coordinate: FreeCoordinate) -> str:
    """A plotted coordinate as the Start folder names it, without "start": ``crank: angle (°)``."""
    return f"{coordinate.body}: {START_NAMES[coordinate.axis][1].removeprefix('start ')}"


def coordinate_unit(coordinate: FreeCoordinate) -> str:
    """The unit a coordinate is shown in, as in the Start folder: ° for an angle, m for a place."""
    return "°" if coordinate.angular else "m"


class CallableButton:
    """A panel button that is also a call: ``session.export_html`` is the Export tab's "Save HTML replay" button
    (its handle's members, for the panel and its tests) and ``session.export_html()`` the chain session's call of
    that name (the replay's page), so that callers of either kind of session keep working."""

    def __init__(self, handle, call: Callable[[], Any]) -> None:
        object.__setattr__(self, "_handle", handle)
        object.__setattr__(self, "_call", call)

    def __call__(self) -> Any:
        return self._call()

    def __getattr__(self, name: str) -> Any:
        return getattr(self._handle, name)

    def __setattr__(self, name: str, value: Any) -> None:
        setattr(self._handle, name, value)


def chain_help() -> str:
    """A chain's Help text (static/help.md)."""
    help_file = STATIC / "help.md"
    return help_file.read_text(encoding="utf-8") if help_file.exists() else "See docs/app.md."


def mechanism_names() -> list[str]:
    return list(MECHANISM_PRESETS)


VIEWERS_LINK = ("[Viewers' link](/) (right-click to copy): the page every student opens to watch this lecture "
                "(the server's address, without the presenter's secret).")
"""A --shared session's Export tab: the address to give the audience (a relative link: the browser completes it
with the server's own address, never with the page the presenter opened)."""


def is_mechanism(name: str) -> bool:
    return name in MECHANISM_PRESETS


class Session(SessionBase):
    """A general mechanism shown in one browser (``target`` a client) or in all (``shared``, the server)."""

    def __init__(self, target, mechanism: Mechanism, *, label: str | None = None, shared: bool = False,
                 autoplay: bool = True, chain: SessionParameters | None = None) -> None:
        # a hosted chain (app/chain_knobs.py): its parameters in force (chain, settings, start); None: a mechanism
        self.chain = chain
        self.target = target
        self.shared = shared
        self.closed = False
        self.label = label or mechanism.name  # the menu's entry: a preset's name or the file's
        self.reference = mechanism  # as loaded: the sliders' ranges and "Reset to the preset's values"
        self.mechanism = mechanism
        self.settings = MechanismSettings(trace=mechanism.trace) if chain is None else chain_knobs.hosted_settings(chain)
        self.is_presenter: Callable[[int], bool] | None = None
        self._prepared: set[tuple] = set()  # what _prepare has compiled in this session's worker
        self.id = id(self)
        self._lock = threading.RLock()
        self.reactions_on = False
        self.compare = False  # the three formulations side by side (app/mechanism_compare.py)
        self.frames_sent = 0
        self.q0, self.qdot0, self.mobility, _ = self._start_of(mechanism)  # LinkageError: the file cannot assemble
        self.sketch_q = self.q0  # the assembled sketch: the start controls' ranges are around it
        self.free: tuple[FreeCoordinate, ...] = ()  # the coordinates a start is set by (app/mechanism_start.py)
        self.worker = POOL.acquire()  # where this session's chunks are computed (app/mechanism_workers.py)
        self.energy_ref: float | None = None
        self._equations_shown = False  # the Equations tab was asked for: it follows the method
        self._equations_generation = 0  # how many times: only the latest derivation is shown (an older may end later)
        self._ran_from: SessionParameters | None = None  # a hosted chain's latest start that ran (Reset's way back)
        self.display = Display()  # playback speed, trace length, arrow scale: the chain panel's (app/panel_rows.py)
        self._segment_t0 = 0.0  # the time of the last change: the energy error is measured from there
        self._plots_due = False  # a plot was chosen: redraw it with the next frame, paused or not
        self._plot_kind = "energy"
        self.player = Player(
            simulate=lambda *args, **kwargs: None,  # every run carries its own (MechanismSpec.simulate)
            make_settings=lambda settings, horizon, samples: settings.model_copy(
                update={"t_end": horizon, "samples": samples}),
            on_frame=self._on_frame, on_failure=self._on_failure, prepare=cast(Any, self._prepare),
            name="mechanism-player",
            ready_for_frame=None if shared else (lambda: delivery.caught_up(target)),
        )
        try:
            self.notices = Notices(self._clients, self._refresh_status, self._connection_open)
            self.scene = MechanismScene(target)
            self.camera = CameraDirector(target, shared)
            self.trace = TraceLine(target.scene, "/linkage/trace")
            self.arrows = ReactionArrows(target.scene, "/linkage/reactions")
            self.compare_view = MechanismCompare(target)
            self.free_body = FreeBodyView(target.scene, lambda: 1.0, redraw=self.player.touch)
            self._build_panel()
            self.analysis = MechanismAnalysis(self)  # the Analysis folder (app/mechanism_analysis.py)
            # the seed report's figures replayed with their verdicts (app/report_view.py): the course's own runs,
            # the same whatever is shown; after Analysis, as the chain panel's tabs are ordered
            with self.tabs.add_tab("Report"):
                self.seed_report = SeedReportPanel(
                    target.gui, panel_rows.guarded_bind(self.guard, self._muting.muted))
            self.design_view = DesignView(self)  # the Design tab and its points in the scene (app/design_view.py)
            check_gui_updates(target.gui, self._refuse_update, self.may_change, ViewerRefusals(target, shared),
                              open_to_all=self._reading_only)
            viser_compat.guard_messages()  # malformed messages dropped before viser reads them (one log line)
            self._new_mechanism(mechanism, play=autoplay)
            self.drag = DragStart(self)  # drag a bar in the paused scene to set the start (app/drag_start.py)
            target.gui.add_html(READY_HTML)
        except BaseException:
            self.player.stop()
            POOL.release(self.worker)
            raise

    @classmethod
    def for_chain(cls, target, params: SessionParameters, *, shared: bool = False,
                  autoplay: bool = True) -> "Session":
        """A chain preset hosted here (app/chain_knobs.py): ``params`` (``SessionParameters.from_preset``, edited
        or not) run as ``chain_mechanism(params.chain, theta = 0, damping)`` from the chain's own start, with the
        chain's knobs and names; LinkageError for a method the mechanism session does not run."""
        chain_knobs.hosted_settings(params)  # a method it cannot run: refused before anything is built
        return cls(target, chain_knobs.hosted_mechanism(params), label=params.preset, shared=shared,
                   autoplay=autoplay, chain=params)

    def _start_of(self, mechanism: Mechanism) -> tuple[np.ndarray, np.ndarray, int, tuple[FreeCoordinate, ...]]:
        """``(q0, qdot0, mobility, free)``: a mechanism's assembled sketch at rest and the coordinates its start is
        set by (LinkageError naming the joint that stays open); a hosted chain's own start (its loop closure's,
        never the sketch's) and its driving angles."""
        if self.chain is not None:
            q0, qdot0 = chain_knobs.hosted_start(self.chain)
            return q0, qdot0, chain_knobs.mobility(self.chain), chain_knobs.free_coordinates(self.chain)
        q0, qdot0, mobility = start_state(mechanism)
        return q0, qdot0, mobility, free_coordinates(mechanism, q0, mobility)

    # ------------------------------------------------------------------ the panel
    def _build_panel(self) -> None:
        gui = self.target.gui
        self._gui: list = []
        self._knob_handles: dict[str, Any] = {}
        self._typed_boxes: dict[str, Any] = {}
        self._typing: dict[str, threading.Timer] = {}
        self._typing_lock = threading.Lock()
        self.typed_commits = 0  # typed values applied or refused so far (tests wait for the next one)
        self._syncing = False

        def keep(handle):
            self._gui.append(handle)
            return handle

        self.status = keep(gui.add_markdown(""))
        self.lecture_style = keep(gui.add_html(""))  # lecture mode's stylesheet while it is on (app/lecture.py)
        # as the chain panel's: the page's keys (Space, S, R) press these buttons (static/page.html)
        self.transport = keep(gui.add_button_group("Playback", TRANSPORT,
                                                   hint="Reset: start again from the start in force (t = 0)"))
        self.transport.on_click(lambda event: self.guard(lambda: self.press(self.transport.value)))
        # the run so far, as the chain panel's: drag back to look again (pauses there); Play goes on from it
        self.timeline = keep(gui.add_slider("Timeline (s)", min=0.0, max=panel_rows.TIMELINE_MIN_SPAN, step=panel_rows.TIMELINE_STEP,
                                            initial_value=0.0, hint="Drag to go back through the run so far (pauses)"))
        self.timeline.on_update(lambda event: None if self._timeline_writer == threading.get_ident() else self.guard(
            lambda: self.scrub(self.timeline.value)))
        self._timeline_end = 0.0
        self._timeline_writer: int | None = None  # the thread moving the thumb to the time shown (not a scrub)
        # the rows every panel has, made by the chain panel's code (app/panel_rows.py)
        self._muting = panel_rows.Muting()
        bind = panel_rows.guarded_bind(self.guard, self._muting.muted)
        self.numbers = NumberInputs(gui, self, bind, self._muting.quiet, self._muting.muted,
                                    value_of=lambda name: float(getattr(self.display, name)))
        self.camera_view = keep(panel_rows.add_view_row(gui, bind, self))
        self.plot_choice = keep(panel_rows.add_plot_menu(
            gui, bind, panel_rows.MECHANISM_PLOT_CHOICES, self.choose_plot,
            "Energy and its error, the start's coordinates over time, or the phase portrait of the first"))
        self.coordinate_plot: Plot | None = None  # made per mechanism (one series per coordinate), in _build_knobs
        self._plotted: tuple[FreeCoordinate, ...] = ()
        self.phase_image = keep(panel_rows.add_phase_image(gui))
        self.energy_plot = Plot(gui, "Energy", ["kinetic", "potential", "total"],
                                list(ENERGY_COLORS), y_label="J")
        self._gui.append(self.energy_plot.handle)
        self.drift_plot = panel_rows.add_drift_plot(gui)
        self._gui.append(self.drift_plot.handle)
        self.residual_plot = panel_rows.add_residual_plot(gui, RESIDUAL_TITLE, "|Φ|", "")
        self._gui.append(self.residual_plot.handle)
        # the tabs: what applies to the linkage shown in each; drawn above the Plot menu and its charts, so that at
        # 1280x720 the open tab's first controls show without scrolling past two charts (issue 26)
        self.tabs = keep(gui.add_tab_group(order=self.plot_choice.order - 0.5))
        with self.tabs.add_tab("Mechanism"):
            self.menu = gui.add_dropdown("Mechanism", self._menu_entries(), initial_value=self.label,
                                         hint="A chain preset or a planar mechanism")
            self.menu.on_update(lambda event: self.guard(lambda: self.choose(str(self.menu.value))))
            self.description = gui.add_markdown("")
            self.facts = gui.add_markdown("")
            self.defaults_button = gui.add_button("Reset to the preset's values")
            self.defaults_button.on_click(lambda event: self.guard(self.reset_to_reference))
            self.upload = gui.add_upload_button("Load a mechanism file (TOML or JSON)",
                                                hint="The format of docs/mechanisms.md; at most 1 MB")
            self.upload.on_upload(lambda event: self.guard(lambda: self.load_file(
                getattr(event, "client_id", None), self.upload.value.name, self.upload.value.content)))
            self.knob_folder = gui.add_folder("Bodies and motors")
            self.start_folder = gui.add_folder("Start (t = 0)")
            self.start_note = gui.add_markdown("")
        with self.tabs.add_tab("Simulation"):
            # labelled as the chain panel's (app.parameters.method_label); links and snapshots keep the keys
            self.method = gui.add_dropdown("Method", [method_label(m, self.chain is not None) for m in METHODS],
                                           initial_value=method_label("dae"),
                                           hint="Formulation integrated; its reactions are shown")
            self.method.on_update(lambda event: self.guard(
                lambda: self.set_method(str(method_from_label(self.method.value)))))
            self.compare_box = gui.add_checkbox(
                "Compare formulations", False,
                hint="Newton-Euler, Lagrange and the DAE side by side from the same start, and how far they part")
            self.compare_box.on_update(lambda event: self.guard(lambda: self.set_compare(bool(self.compare_box.value))))
            self.integrator = gui.add_dropdown("Integrator", list(INTEGRATOR_NAMES), initial_value="DOP853",
                                               hint="Any the method allows (variational: Lagrange only; the "
                                               "reduced model: DOP853)")
            self.integrator.on_update(lambda event: self.guard(lambda: self.set_integrator(str(self.integrator.value))))
            for knob in settings_knobs(self.settings):
                self._add_knob(knob)
            self.stabilization = gui.add_dropdown("Stabilisation", list(STABILIZATIONS), initial_value="projection",
                                                  hint="How the loops are held closed")
            self.stabilization.on_update(
                lambda event: self.guard(lambda: self.set_stabilization(str(self.stabilization.value))))
        with self.tabs.add_tab("Display"):
            self.lecture_box = gui.add_checkbox("Lecture mode", False, hint="Text, charts and figures readable from "
                                                "the back row: larger text, a wider panel (also ?lecture=1, --lecture)")
            self.lecture_box.on_update(lambda event: self.guard(lambda: self.set_lecture(bool(self.lecture_box.value))))
            panel_rows.add_motion_numbers(self.numbers.add, self.display)
            self.trace_menu = gui.add_dropdown("Traced point", ["(none)"], initial_value="(none)",
                                               hint="Any named point of any body")
            self.trace_menu.on_update(lambda event: self.guard(lambda: self.set_trace(str(self.trace_menu.value))))
            self.arrow_box = gui.add_checkbox("Reaction arrows", False, hint="Pin forces of the chosen method")
            self.arrow_box.on_update(lambda event: self.guard(lambda: self.set_reactions(bool(self.arrow_box.value))))
            panel_rows.add_arrow_number(self.numbers.add, self.display)
            self.free_body_box = gui.add_checkbox("Free-body diagram", False,
                                                  hint="Every load on the chosen body at the displayed time")
            self.free_body_box.on_update(
                lambda event: self.guard(lambda: self.set_free_body(bool(self.free_body_box.value))))
            self.body_menu = gui.add_dropdown("Body", ["(none)"], initial_value="(none)",
                                              hint="The body whose free-body diagram is drawn")
            self.body_menu.on_update(
                lambda event: self.guard(lambda: self.set_free_body_body(str(self.body_menu.value))))
            self.couples = gui.add_markdown("")
            self.free_body_help = gui.add_markdown("")  # the command for its SVG, naming this preset and body
            self.rests = RestPositionsPanel(None, gui, self._bind, source=MechanismRests(self))
        with self.tabs.add_tab("Equations"):
            self.equations_button = gui.add_button("Show the equations of the method")
            self.equations_button.on_click(lambda event: self._equations_asked(getattr(event, "client", None)))
            self.equations_tex = gui.add_button("Download as LaTeX")
            self.equations_tex.on_click(lambda event: self.download_equations(getattr(event, "client", None)))
            self.equations = gui.add_html("<p>The linear system <i>A x = b</i> the chosen method integrates, derived "
                                          "for this mechanism (press the button).</p>")
        with self.tabs.add_tab("Export"):
            self.share_button = gui.add_button("Link to this setup")
            self.share_button.on_click(lambda event: self.guard(self.show_link))
            self.share_link = gui.add_markdown((VIEWERS_LINK + "\n\n" if self.shared else "")
                                               + "A link that opens this mechanism with these values and settings "
                                               "in a new session (press the button for the current ones).")
            self.download_buttons = gui.add_button_group("Download the run", DOWNLOADS,
                                                         hint="The run up to the displayed time, as the mechanism "
                                                         "command writes it")
            self.download_buttons.on_click(lambda event: self.guard(lambda: self.download(
                str(self.download_buttons.value).lower(), getattr(event, "client", None))))
            # the Save HTML replay button, and called, the chain session's export_html() (see CallableButton)
            self.export_html = CallableButton(panel_rows.add_export_button(gui, bind, self, "html"),
                                              self._export_html)
            # the setup as a file, and one read back
            self.save_setup = gui.add_button("Save this setup (JSON)")
            self.save_setup.on_click(lambda event: self.guard(lambda: self.download(
                "setup", getattr(event, "client", None))))
            self.setup_upload = gui.add_upload_button("Load a setup (JSON)", mime_type="application/json")
            self.setup_upload.on_upload(lambda event: self.guard(lambda: self.upload_setup(
                getattr(event, "client_id", None), self.setup_upload.value.name, self.setup_upload.value.content)))
        with self.tabs.add_tab("Help"):
            self.help = gui.add_markdown(self._help_text())  # the chain panel's for a hosted chain (_show_facts)
        self.torque_plot: Plot | None = None

    def set_lecture(self, on: bool) -> None:
        """Lecture mode on or off for this session's panel: its stylesheet, and every chart's canvas text and size
        (app/lecture.py). Only how things are drawn changes; nothing of the run."""
        self.lecture_style.content = lecture.LECTURE_CSS if on else ""
        lecture.switch(self.target.gui, on)
        if bool(self.lecture_box.value) != on:
            self.lecture_box.value = on

    @property
    def lecture(self) -> bool:
        return bool(self.lecture_box.value)

    def _menu_entries(self) -> list[str]:
        entries = list(preset_names()) + mechanism_names()
        return entries if self.label in entries else entries + [self.label]

    def _add_knob(self, knob: Knob) -> None:
        """A generated control's slider and the box its value is typed in, in the current container."""
        gui = self.target.gui
        low, high = knob.slider_bounds()  # widened to show a typed value beyond the slider's useful range
        # a log slider is labelled as the chain's (Tolerance log10(rtol)); its box takes the value itself
        handle = gui.add_slider(knob.label if not knob.log else f"log10({knob.name})", min=low, max=high,
                                step=knob.step, initial_value=knob.slider_value(), hint=knob.hint)
        handle.on_update(lambda event, knob=knob, handle=handle: self._knob_moved(knob, handle))
        self._knob_handles[knob.name] = handle
        if knob.follows:  # the model sets it (a closed chain's assembled angle): shown greyed, nothing to type
            handle.disabled = True
            return
        # the box a value is typed in, read by the server as written (the slider's own box is the browser's,
        # which reads 2.5e1 as 2.51): as the chain panel's (app/number_inputs.py)
        box = gui.add_text(f"type {knob.label}", initial_value=shown_value(knob.value),
                           hint=f"Type a value for {knob.label} (e.g. 1.5 or 1e-3); applied when you stop typing")
        box.on_update(lambda event, name=knob.name: None if self._syncing else self._typed(name))
        self._typed_boxes[knob.name] = box

    def _build_knobs(self) -> None:
        """The controls generated from the mechanism (bodies, motors, gears, gravity) and from its start (the
        free coordinates); the run's settings (built once with the panel) stay."""
        for timer in self._typing.values():
            timer.cancel()
        self._typing = {}
        keep = {knob.name for knob in settings_knobs(self.settings)}
        for name in [name for name in self._knob_handles if name not in keep]:
            quietly(self._knob_handles.pop(name).remove, "removing a control")
        for name in [name for name in self._typed_boxes if name not in keep]:
            quietly(self._typed_boxes.pop(name).remove, "removing a control")
        with self.knob_folder:
            for knob in self._mechanism_knobs():
                self._add_knob(knob)
        with self.start_folder:
            for knob in self._start_knobs():
                self._add_knob(knob)
        self._start_names = tuple(coordinate.body + "." + coordinate.axis for coordinate in self.free)
        self.start_folder.visible = bool(self.free)
        self.start_note.content = "" if self.free else (
            "*Start: its motors fix every body (mobility 0 free): it starts from the assembled sketch.*")
        if self.torque_plot is not None:
            self.torque_plot.remove()
            self.torque_plot = None
        motors = [self._row_names[k].split(":")[0] for k in torque_rows(self._row_names)]
        if motors:
            colors = [METHOD_COLORS["dae"], METHOD_COLORS["lagrange"], METHOD_COLORS["reduced"]]
            self.torque_plot = Plot(self.target.gui, "Driving torque (inverse dynamics)",
                                    [f"motor {m}" for m in motors], colors[: len(motors)], y_label="N·m",
                                    height=220)  # taller: a torque of ±0.4 N·m gets ticks besides 0
        self._build_coordinate_plot()

    def _build_coordinate_plot(self) -> None:
        """The Plot menu's coordinates over time, one series per coordinate of :func:`plotted_coordinates`,
        named as the Start folder names them (in its units: ° or m), beside the energy plot."""
        if self.chain is not None:  # the chain panel's Angles plot: every bar's angle, θ1..θn in degrees
            n = self.chain.n
            self._plotted = tuple(FreeCoordinate(f"bar{k}", "angle", 3 * k - 1) for k in range(1, n + 1))
            labels = [f"θ{k}" for k in range(1, n + 1)]
        else:
            self._plotted = plotted_coordinates(self.mechanism, self.free)
            labels = [coordinate_label(c) for c in self._plotted]
        if self.coordinate_plot is not None and self.coordinate_plot.labels == labels:
            return
        if self.coordinate_plot is not None:
            self.coordinate_plot.remove()
        units = {coordinate_unit(c) for c in self._plotted}
        self.coordinate_plot = Plot(self.target.gui, "Angles" if self.chain is not None else "Coordinates", labels,
                                    [chart_color(BAR_COLORS[k % len(BAR_COLORS)]) for k in range(len(labels))],
                                    y_label=units.pop() if len(units) == 1 else "",
                                    order=self.energy_plot.handle.order - 0.5)
        self._show_chosen_plot()

    @property
    def plot_kind(self) -> str:
        """``energy``, ``angles`` (the coordinates over time) or ``phase``: the Plot menu's last accepted choice."""
        return self._plot_kind

    def choose_plot(self, label: object) -> None:
        """The Plot menu (app/panel_rows.py): show the plot chosen, drawn now from the run."""
        self._plot_kind = panel_rows.plot_kind(self._plot_choices(), label)
        self._show_chosen_plot()
        self.refresh_plots()

    def _show_chosen_plot(self) -> None:
        """The chosen plot shown, the others hidden; the energy error only without a motor (a motor's work
        changes the energy), the constraint residual only for a mechanism with a loop (an open one has none
        to close)."""
        driven = bool(self.mechanism.drivers)
        panel_rows.show_plot(self._plot_kind, [self.energy_plot] if driven else [self.energy_plot, self.drift_plot],
                             self.coordinate_plot, self.phase_image)
        if driven:
            self.drift_plot.set_visible(False)
        self.residual_plot.set_visible(bool(analyse(self.mechanism).loops))

    def refresh_plots(self) -> None:
        """Redraw the chosen plot with the next frame (a paused player draws one when touched)."""
        self._plots_due = True
        self.player.touch()

    def _start_knobs(self) -> list[Knob]:
        if self.chain is not None:
            return chain_knobs.start_knobs(self.chain)
        return start_knobs(self.mechanism, self.free, self.sketch_q, self.q0, self.qdot0)

    def _mechanism_knobs(self) -> list[Knob]:
        """The Bodies and motors folder's controls: a mechanism's (app/mechanism_edits.py), or a hosted chain's
        by the chain's names (app/chain_knobs.py)."""
        if self.chain is not None:
            return chain_knobs.chain_knobs(self.chain)
        return knobs(self.mechanism, self.reference)

    def mechanism_tab_knobs(self) -> list[Knob]:
        """The generated controls of the Mechanism tab: the mechanism's, then its start's."""
        return [*self._mechanism_knobs(), *self._start_knobs()]

    def panel_knobs(self) -> list[Knob]:
        """Every generated control of the panel, in the order a share link sets them (a size before the start,
        which a size change puts back on the sketch)."""
        return [*self._mechanism_knobs(), *settings_knobs(self.settings), *self._start_knobs()]

    def _knob_moved(self, knob: Knob, handle) -> None:
        if self._syncing:
            return
        self.guard(lambda: self._set(knob.name, knob.from_slider(handle.value), CONTROL))
        quietly(lambda: self.sync_all(moved=knob.name), "showing the values in force")  # a loop's followers

    def _typed(self, name: str) -> None:
        """A keystroke in a typed box: the value is applied once typing has paused (TYPING_PAUSE_S); then the
        box shows the value in force, applied or refused (one notice naming the field and its range)."""
        box = self._typed_boxes.get(name)
        if box is None:
            return
        text = box.value

        def commit() -> None:
            if self.closed or self._typed_boxes.get(name) is not box:
                return
            self.guard(lambda: self.set_typed(name, text))
            quietly(self.sync_all, "showing the value in force")
            with self._typing_lock:
                self.typed_commits += 1

        with self._typing_lock:
            if name in self._typing:
                self._typing[name].cancel()
            timer = threading.Timer(TYPING_PAUSE_S, commit)
            timer.daemon = True
            self._typing[name] = timer
            timer.start()

    def typing(self) -> bool:
        """True while a typed value waits for its pause (tests wait for this to end)."""
        with self._typing_lock:
            return any(timer.is_alive() for timer in self._typing.values()) or self.numbers.typing()

    def typed_box(self, name: str):
        """The typed box of a generated control (``mass:crank``, ``speed:O``, ``g``) or of a display setting
        (``speed``, ``trace_seconds``, ``arrow_scale``)."""
        return self._typed_boxes[name] if name in self._typed_boxes else self.numbers.controls[name].box

    def set_typed(self, name: str, text: object) -> None:
        """A value typed (or in a share link) for a generated control, in the panel's units (°/s for a motor's
        speed, ms for the fixed step): read as written by the chain panel's reader
        (:func:`app.commands.read_number`), then set as by its slider."""
        if name in DISPLAY_NAMES:  # read by the chain panel's reader, in the panel's units
            self._set_display(name, text, CONTROL)
            return
        if self.chain is not None:  # read by the chain's command layer, its refusals the chain panel's
            self._set_chain(name, text, CONTROL)
            quietly(self.sync_all, "showing the value in force")
            return
        knob = next((k for k in self.panel_knobs() if k.name == name), None)
        if knob is None:
            self.set(name, text)  # names the controls there are
            return
        self.set(name, read_number(knob.label, knob.unit, text))

    def _sync_boxes(self) -> None:
        """Write the value in force into every typed box that shows another (the sliders are left alone: one
        may be under the mouse)."""
        self._syncing = True
        try:
            for knob in self.panel_knobs():
                box = self._typed_boxes.get(knob.name)
                if box is not None and box.value != shown_value(knob.value):
                    box.value = shown_value(knob.value)
        finally:
            self._syncing = False

    def sync_all(self, moved: str | None = None) -> None:
        """Put every control on the value in force (after a refusal, or a viewer's attempt); ``moved``: the
        slider the mouse just moved, left where it is (it may still be under the mouse)."""
        self._syncing = True
        try:
            for knob in self.panel_knobs():
                handle = self._knob_handles.get(knob.name) if knob.name != moved else None
                if handle is not None and handle.value != knob.slider_value():
                    low, high = knob.slider_bounds()  # a typed value beyond the slider's range: widen it
                    handle.min, handle.max = min(handle.min, low), max(handle.max, high)
                    handle.value = knob.slider_value()
                box = self._typed_boxes.get(knob.name)
                if box is not None and box.value != shown_value(knob.value):
                    box.value = shown_value(knob.value)
            for handle, value in ((self.method, method_label(self.settings.method, self.chain is not None)),
                                  (self.stabilization, self.settings.stabilization),
                                  (self.integrator, self.settings.integrator),
                                  (self.menu, self.label), (self.compare_box, self.compare),
                                  (self.plot_choice, self._plot_choices()[panel_rows.PLOT_KINDS.index(self._plot_kind)]),
                                  (self.free_body_box, self.free_body.on), (self.body_menu, self._body_shown())):
                if handle.value != value:
                    handle.value = value
            self.numbers.sync_all()
            fixed = self.settings.integrator in FIXED_STEP_INTEGRATORS
            baumgarte = self.settings.stabilization == "baumgarte" and not is_reduced(self.settings.method)
            for name, visible in (("rtol", not fixed), ("step", fixed), ("baumgarte_alpha", baumgarte),
                                  ("baumgarte_beta", baumgarte)):
                for control in (self._knob_handles.get(name), self._typed_boxes.get(name)):
                    if control is not None and control.visible != visible:
                        control.visible = visible
        finally:
            self._syncing = False

    # ------------------------------------------------------------------ boundary and notices
    def guard(self, action: Callable[[], object]) -> object:
        """Run one GUI action; a refused value is a notice and the controls go back to the values in force. An
        action that applies a value and says nothing takes down the refusal still shown ("Not applied"): it was
        about a value that is no longer the one in question."""
        if self._syncing:
            return None
        serial = self.notices.serial
        refused_state = self._state_words() if self.notices.showing == REFUSED else None
        try:
            result = action()
            # taken down only when a value was applied: a slider's echo of the value put back changes nothing
            if (refused_state is not None and self.notices.serial == serial
                    and self._state_words() != refused_state):
                self.notices.withdraw(REFUSED)
            return result
        except LinkageError as error:  # a hosted chain's in its menu's words (``method = Lagrange``)
            self.show_notice(REFUSED, in_menu_words(str(error)) if self.chain is not None else str(error),
                             color="yellow")
            quietly(self.sync_all, "putting the controls back")
        except Exception as error:  # the boundary: nothing escapes into viser's callback thread
            traceback.print_exc()
            quietly(self.player.pause, "pausing after an error")
            self.show_notice("Session paused", f"{type(error).__name__}: {error}. Press Reset to start again.",
                             color="red", seconds=None)
        return None

    def _state_words(self) -> object:
        """What the session has in force, as a share link or a setup file words it (compared, never shown)."""
        try:
            return share.link_query(self.chain) if self.chain is not None else tuple(self.setup_pairs())
        except LinkageError:
            return None

    def _refuse_update(self, handle, problem: str) -> None:
        self.show_notice(REFUSED, f"{handle.label}: {problem}", color="yellow")
        quietly(self.sync_all, "putting the controls back after a refused value")

    # ------------------------------------------------------------------ edits
    def set(self, name: str, value: object, units: str = SI) -> None:
        """A hosted chain's value by the chain session's names and units (``L2``, ``m3``, ``theta1``, ``g``,
        ``pin_x``, ``damping``, ``rtol``, ``method``, ``trace``, ``links``, a display setting; ``units`` SI:
        radians, seconds, as ``python -m physics --set``; CONTROL: the panel's degrees and milliseconds),
        through :func:`app.commands.apply`. For a mechanism: set a generated control (``mass:crank``, ``size:coupler``, ``speed:O2`` in °/s, ``ratio:mesh``, ``g``;
        the run's ``rtol`` and ``step`` in ms; a start's ``angle0:crank`` in °, ``omega0:crank`` in °/s):
        geometry starts again from the re-assembled sketch, a start from the new start at t = 0; masses, inertias,
        motors, gravity and the run's settings go on from the displayed state (the constraints do not depend
        on them); its controls are in the panel's units whatever ``units``, which a display setting takes. Every
        control then shows the value in force (a slider moved by the mouse is not written back: :meth:`_set`)."""
        self._set(name, value, units)
        quietly(self.sync_all, "showing the value in force")

    def _set(self, name: str, value: object, units: str = SI) -> None:
        """:meth:`set` without writing the sliders back (a slider's own move: it may still be under the mouse)."""
        if name in DISPLAY_NAMES:  # playback speed, trace length, arrow scale
            self._set_display(name, value, units)
            return
        if self.chain is not None:  # a hosted chain's value, by the chain's name
            self._set_chain(name, value, units)
            return
        with self._lock:
            if name in SETTING_KNOBS:
                self._set_settings(apply_setting(self.settings, name, value))
            elif name.partition(":")[0] in START_KINDS:
                self.set_start_value(name, value)
            else:
                edited = apply_edit(self.mechanism, name, value, self.reference, SAMPLE_DT)
                geometry = name.startswith(("size:", "ratio:", "offset:"))
                if geometry:
                    self._new_mechanism(edited, play=None, same_kind=True)
                else:
                    self.mechanism = edited
                    self._continue()
            self._sync_boxes()  # a slider moved: its box shows the value in force (a resize: the inertia's too)

    # ------------------------------------------------------------------ a hosted chain (app/chain_knobs.py)
    def _set_chain(self, name: str, value: object, units: str) -> None:
        """One edit of the hosted chain by the chain's name (``L1``, ``m2``, ``g``, ``damping``, ``theta1``,
        ``omega1``, ``pin_x``, ``links``, ``rtol``, ...), in ``units`` (CONTROL: the panel's degrees and
        milliseconds; SI: ``python -m physics --set``'s), through the chain's command layer
        (:func:`app.commands.apply`: its refusals, word for word). As the chain session: a physical number goes on
        from the displayed state (mapped to the chain's angles and back through ``chain_state`` with the new
        numbers), a start value starts again at t = 0 from it, the number of bars loads that chain preset."""
        chain = self.chain
        assert chain is not None, "a hosted chain's edit"
        if name in DISPLAY_NAMES:
            self._set_display(name, value, units)
            return
        if name in ("method", "integrator", "stabilization", "trace"):
            self.set_link_value(name, str(value))
            return
        if name == "links":
            self.set_links(value)
            return
        with self._lock:
            edit = commands.apply(chain, name, value, units)
            if name in SETTING_KNOBS:
                shown = getattr(edit.params.settings, name) * (1e3 if name == "step" else 1.0)
                self._set_settings(apply_setting(self.settings, name, shown))
                self.chain = chain_knobs.with_settings(edit.params, self.settings)
            elif edit.restart:
                if not self._same_start(edit.params, chain):  # a slider's echo of the start in force is no edit:
                    self._chain_start(edit.params)  # starting again would take down a refusal's notice meanwhile
                else:
                    self.chain = edit.params  # the same start as written (a typed -0 for 0): nothing starts again
            else:
                key = commands.split_name(name)[0]
                try:
                    self._chain_continue(edit.params, geometry=key in ("L", "d", "pin_x", "pin_y"))
                except LinkageError as error:  # the refusal names the field typed, as every refusal does
                    raise LinkageError(f"{name} = {value!s:.40}: {error}") from None
            self._sync_boxes()

    @staticmethod
    def _same_start(new: SessionParameters, old: SessionParameters) -> bool:
        """The same start angles and speeds (to 1e-12 rad, rad/s): a browser that puts a slider back on the
        value in force (after a refused value was written back to it) sends that value again."""
        return bool(np.allclose(new.theta0, old.theta0, rtol=0.0, atol=1e-12)
                    and np.allclose(new.omega0, old.omega0, rtol=0.0, atol=1e-12))

    def _chain_start(self, params: SessionParameters) -> None:
        """A new start of the hosted chain (its angles or speeds): again at t = 0 from it. The start it replaces
        is remembered if it ran (Reset's way back from a start that cannot move, as the chain session's)."""
        with self.player.lock:
            ran = bool(self.player.runs) and len(self.player.runs[0].ring) > 1
        if ran and self.chain is not None:
            self._ran_from = self.chain
        self.chain = params
        self.q0, self.qdot0 = chain_knobs.hosted_start(params)
        self._build_scene(self.q0)
        self.energy_ref = None
        self._clear_plots()
        self._restart(0.0, self.q0, self.qdot0, keep_history=False)

    def _chain_continue(self, params: SessionParameters, geometry: bool) -> None:
        """New numbers of the hosted chain (lengths, masses, inertias, g, damping, pin), going on from the
        displayed state: its angles and rates are the chain's (a pinned chain's put back on the loop the new
        numbers close: LinkageError before anything changed), re-mapped to the new mechanism's ``q, qdot``. The
        mechanism's structure (what is compiled) is the same: only numbers change. Compare mode starts every
        formulation again from the start, as a mechanism's edit does."""
        mechanism = chain_knobs.hosted_mechanism(params)
        state = None if self.compare else self.player.current_start()
        if state is not None and chain_knobs.same_shape(cast(MechanismSpec, state[0]).chain, params):
            _, t, q, qdot = state
            theta, omega = chain_knobs.close_loop(params, *chain_knobs.chain_angles(params, q, qdot))
            q, qdot = chain_state(params.chain, chain_knobs.sketch(params), theta, omega)
        else:
            state = None
        self.chain, self.mechanism = params, mechanism
        self.q0, self.qdot0 = chain_knobs.hosted_start(params)
        self.sketch_q = self.q0
        self.spec = self._spec()
        self._row_names = self.spec.row_names
        if geometry:
            self._build_scene(self.q0 if state is None else q)
            self._frame_camera(points_at(self.spec.draw, self.q0), force=False)
            self.facts.content = chain_knobs.facts_line(params)  # a four-bar's reach moves with its lengths
            self._syncing, syncing = True, self._syncing
            try:
                self._sync_trace_menu()  # a traced point the new lengths moved (a custom one's label)
            finally:
                self._syncing = syncing
            self._follow_ranges()
        self.energy_ref = None
        if state is None:
            self._restart(0.0, self.q0, self.qdot0, keep_history=False)
        else:
            self._restart(t, q, qdot, keep_history=True)

    def _follow_ranges(self) -> None:
        """A centre of mass d's slider ends at its bar's length, as the chain panel's (the slider itself stays:
        one may be under the mouse)."""
        self._syncing = True
        try:
            for knob in self._mechanism_knobs():
                handle = self._knob_handles.get(knob.name)
                if handle is not None and commands.split_name(knob.name)[0] == "d":
                    low, high = knob.slider_bounds()
                    if (handle.min, handle.max) != (low, high):
                        handle.min, handle.max = low, high
        finally:
            self._syncing = False

    def set_links(self, value: object) -> None:
        """The chain panel's Bars: load the ``chain`` preset of that many bars (its integration choices kept)."""
        number = commands.parse_links(value)
        if self.chain is None or self.chain.preset != "chain":
            raise LinkageError("links: only the 'chain' mechanism has a variable number of bars")
        self.open_chain(SessionParameters.from_preset("chain", links=number))

    def open_chain(self, params: SessionParameters, play: bool | None = None) -> None:
        """Host the chain ``params`` here (a chain preset chosen in the menu, another number of bars, the preset's
        values again): the integration choices in force kept where the chain's methods take them, as the chain
        session's ``set_mechanism``; the panel's controls built again for it. ``play``: None keeps playing or
        paused as it was (the chain session's), True plays."""
        with self._lock:
            old = self.chain
            if old is not None:
                offered = chain_knobs.methods(params, chain_knobs.mobility(params))
                method = old.method if old.method in offered else params.method
                kept = {**settings_data(old.settings), "method": method, "trace": params.trace}
                params = params.replaced(settings=validated(Settings, **kept))
            settings = chain_knobs.hosted_settings(params)
            mechanism = chain_knobs.hosted_mechanism(params)
            self.chain, self.settings = params, settings
            self.label, self.reference = params.preset, mechanism
            self._show_in_menu()
            self._new_mechanism(mechanism, play=play)

    def _show_in_menu(self) -> None:
        """The Mechanism menu on the entries and the linkage in force, its callback muted: this is no choice, and
        viser puts a menu whose value left its options on the first entry and calls the callback (a second file
        would switch this browser to a chain)."""
        self._syncing = True
        try:
            self.menu.options = self._menu_entries()
            self.menu.value = self.label
        finally:
            self._syncing = False

    def _set_display(self, name: str, value: object, units: str) -> None:
        """A display setting (the chain's :func:`app.commands.apply_display`: its bounds and its notices): the
        player's speed, the trace's length or the arrows' scale, shown at once; the controls show it."""
        self.display = apply_display(self.display, name, value, units)
        self.player.set_speed(self.display.speed)
        self.player.touch()
        self.numbers.sync(name)

    def set_start_value(self, name: str, value: object) -> None:
        """One start control (a free coordinate's value or speed, in the panel's units): the mechanism is
        re-assembled with it held and the others kept (LinkageError naming the joint that cannot close), its
        velocities follow from the free coordinates' speeds, and the run starts again at t = 0 from there, as a
        chain's does after its angle sliders."""
        with self._lock:
            number = start_value(self._start_knobs(), name, value)
            position, is_value = next((k, name == f"{START_NAMES[c.axis][0]}:{c.body}")
                                      for k, c in enumerate(self.free)
                                      if name in (f"{START_NAMES[c.axis][0]}:{c.body}", f"{START_NAMES[c.axis][2]}:{c.body}"))
            indices = [c.index for c in self.free]
            values, rates = self.q0[indices].copy(), self.qdot0[indices].copy()
            if is_value:
                values[position] = number
                try:
                    q0 = pose_with(self.mechanism, self.q0, self.free, values)
                except LinkageError as error:
                    knob = next(k for k in self._start_knobs() if k.name == name)
                    typed = value.strip() if isinstance(value, str) else shown_value(math.degrees(number)
                                                                                      if knob.unit == "°" else number)
                    raise LinkageError(f"{knob.label} = {typed}: {error}; kept {shown_value(knob.value)}") from None
            else:
                rates[position] = number
                q0 = self.q0
            self.q0, self.qdot0 = q0, velocities_with(self.mechanism, q0, self.free, rates)
            self._build_scene(self.q0)
            self.energy_ref = None
            self._clear_plots()
            self._restart(0.0, self.q0, self.qdot0, keep_history=False)

    def _clear_plots(self) -> None:
        """Empty every plot of the run (a new start at t = 0)."""
        for plot in (self.energy_plot, self.drift_plot, self.residual_plot, self.coordinate_plot):
            if plot is not None:
                plot.clear()

    def _set_settings(self, settings: MechanismSettings) -> None:
        """New run settings from the displayed state on (compare mode: every formulation must take them)."""
        if self.compare:
            for method in COMPARE_METHODS:
                try:
                    check_integrator(method, settings.integrator)
                except LinkageError as error:
                    raise LinkageError(f"compare mode: {error}") from None
        if self.chain is not None:  # the chain's models take them too (a share link carries them)
            self.chain = chain_knobs.with_settings(self.chain, settings)
        self.settings = settings
        self.sync_all()  # the tolerance or the fixed step shows, as the integrator needs
        self._continue()

    def set_integrator(self, integrator: str) -> None:
        """The integrator menu: any of the registry's the method allows; one notice naming them otherwise."""
        with self._lock:
            _choice("integrator", integrator, list(INTEGRATOR_NAMES))
            check_integrator(self.settings.method, integrator)
            self._set_settings(self.settings.model_copy(update={"integrator": integrator}))

    def set_method(self, method: str) -> None:
        """The method by its key (``dae``, as share links and snapshots give it; the menu sends its label,
        turned into the key by :func:`app.parameters.method_from_label`)."""
        with self._lock:
            _choice("method", method, self._methods() if self.chain is not None else list(METHODS))
            if self.chain is not None:  # the chain's models first: their refusal names the fix as the chain's
                commands.apply(self.chain, "method", method)
            check_method(method, self.mobility)
            update: dict[str, object] = {"method": method}
            if is_reduced(method):  # it closes its loops by position analysis and integrates with its own DOP853
                update["stabilization"] = "projection"
                update["integrator"] = allowed_integrators(method)[0]
            else:
                if self.settings.integrator not in allowed_integrators(method):
                    raise LinkageError(f"method = {method}: the integrator {self.settings.integrator} does not "
                                       f"apply to it; choose one of {', '.join(allowed_integrators(method))} first")
            settings = self.settings.model_copy(update=update)
            if self.chain is not None:  # the chain's models take it too (LinkageError before anything changed)
                self.chain = chain_knobs.with_settings(self.chain, settings)
            self.settings = settings
            self.sync_all()  # the Stabilisation menu shows projection with the reduced model
            self._continue()
        if self._equations_shown:  # the Equations tab shows the method in force
            self.show_equations()

    def set_stabilization(self, stabilization: str) -> None:
        with self._lock:
            _choice("stabilization", stabilization, list(STABILIZATIONS))
            if is_reduced(self.settings.method) and stabilization != "projection":
                raise LinkageError("stabilisation: the reduced model closes its loops by position analysis; "
                                   "choose another method first")
            settings = self.settings.model_copy(update={"stabilization": stabilization})
            if self.chain is not None:
                self.chain = chain_knobs.with_settings(self.chain, settings)
            self.settings = settings
            self.sync_all()  # the Baumgarte gains show with baumgarte
            self._continue()

    def set_trace(self, label: str) -> None:
        """The traced point by the menu's entry (a share link's ``trace``); a hosted chain's by the chain panel's
        labels, through the chain's command layer: the path is the chain's TracePoint on the run's q (no new
        structure), going on from the displayed state."""
        if self.chain is not None:
            with self._lock:
                edit = commands.apply(self.chain, "trace", label, CONTROL)
                self.chain = edit.params
                self.settings = self.settings.model_copy(update={"trace": chain_knobs.trace_label(edit.params)})
                self._continue()
                self._syncing, syncing = True, self._syncing
                try:
                    self._sync_trace_menu()
                finally:
                    self._syncing = syncing
            return
        with self._lock:
            _choice("traced point", label, ["(none)", *self.spec.draw.labels])
            self.settings = self.settings.model_copy(update={"trace": None if label == "(none)" else label})
            self._continue()

    def set_reactions(self, on: bool) -> None:
        self.reactions_on = bool(on)
        if not on:
            self.arrows.hide()
        self.player.touch()

    def _bind(self, handle, action: Callable) -> None:
        """``action(value, event)`` on a control of a shared view (app/rest_view.py), inside :meth:`guard`."""
        def callback(event) -> None:
            value = handle.value
            self.guard(lambda: action(value, event))

        if hasattr(handle, "on_click") and not hasattr(handle, "on_update"):
            handle.on_click(callback)
        else:
            handle.on_update(callback)

    def set_start_pose(self, q0: np.ndarray, qdot0: np.ndarray, play: bool = False) -> None:
        """Start again at t = 0 from the pose ``q0`` with speeds ``qdot0`` (a rest pose, app/rest_view.py),
        paused or playing; the start controls show it. A hosted chain's start becomes the pose's angles and rates
        (its share link carries them; LinkageError when they do not close its loop, nothing changed)."""
        with self._lock:
            if self.chain is not None:
                theta, omega = chain_knobs.chain_angles(self.chain, q0, qdot0)
                self.chain = self.chain.replaced(theta0=theta, omega0=omega)
            self.q0, self.qdot0 = np.array(q0, dtype=float), np.array(qdot0, dtype=float)
            self._build_scene(self.q0)
            self.energy_ref = None
            self.energy_plot.clear()
            self._restart(0.0, self.q0, self.qdot0, keep_history=False, play=play)
        self.sync_all()

    def _show_free_body_help(self) -> None:
        """The command that writes this body's SVG, naming the preset shown (a file's body names are its
        author's text: shown literally, never as markup)."""
        if self.chain is not None:  # a chain preset's bar k is body barK: the chain's own fbd command
            body = self._body_shown()
            bar = int(body[3:]) if body.startswith("bar") and body[3:].isdigit() else 1
            command = fbd_command(self.chain.preset, links=self.chain.n, bar=bar)
            self.free_body_help.content = f"The SVG of this body's diagram: `{command}`"
            return
        preset = self.mechanism.name if self.mechanism.name in mechanism_names() else None
        command = fbd_command(preset, body=self._body_shown())
        shown = f"`{command}`" if preset is not None else markdown_literal(command)
        self.free_body_help.content = f"The SVG of this body's diagram: {shown}"

    def set_free_body(self, on: bool) -> None:
        """The free-body diagram of the chosen body on or off (app/free_body_view.py)."""
        self.free_body.set_on(on)
        if not on:
            self.couples.content = ""

    def set_free_body_body(self, name: str) -> None:
        """The body whose diagram is drawn, by its name."""
        names = [body.name for body in self.mechanism.bodies]
        _choice("body", name, names)
        self.free_body.set_bar(names.index(name) + 1)
        self._show_free_body_help()
        self.player.touch()

    def _body_shown(self) -> str:
        bodies = self.mechanism.bodies
        return bodies[self.free_body.bar - 1].name if 1 <= self.free_body.bar <= len(bodies) else "(none)"

    def set_compare(self, on: bool) -> None:
        """Run Newton-Euler, Lagrange and the DAE from the same start (and a converged reference for the
        divergence plots), drawn as three mechanisms in their colours; starts again at t = 0, as the chain's.
        Every formulation runs with the integrator in force: one that only Lagrange takes is refused."""
        with self._lock:
            if on:
                for method in COMPARE_METHODS:
                    try:
                        check_integrator(method, self.settings.integrator)
                    except LinkageError as error:
                        raise LinkageError(f"compare mode: {error}") from None
            self.compare = bool(on)
            self.method.disabled = self.compare  # every formulation runs: the menu does not apply
            self._build_scene(self.q0)
            self.energy_ref = None
            self._clear_plots()
            self._restart(0.0, self.q0, self.qdot0, keep_history=False)
            self.sync_all()

    def choose(self, name: str) -> None:
        """The mechanism menu: another preset here, in this same session: a mechanism preset as loaded, a chain
        preset hosted with its own knobs (the browser keeps its seat and its panel)."""
        _choice("mechanism", name, self._menu_entries())
        if name == self.label:
            return
        if is_mechanism(name):
            with self._lock:
                mechanism = MECHANISM_PRESETS[name]()
                self.chain = None  # a hosted chain's knobs give way to the mechanism's
                self.label, self.reference = name, mechanism
                self.settings = MechanismSettings(trace=mechanism.trace)
                self._new_mechanism(mechanism, play=True)
            return
        self.open_chain(SessionParameters.from_preset(name))

    def load_file(self, client_id: int | None, name: object, content: object) -> None:
        """A mechanism file chosen in the browser: validated and assembled, or one notice naming the element."""
        if not self.may_change(client_id):
            raise LinkageError("mechanism file: the presenter controls this session")
        label = Path(str(name)).name[:60] or "mechanism file"
        if not isinstance(content, bytes):
            raise LinkageError(f"{label}: expected the file's content")
        mechanism = mechanism_from_bytes(content, label)
        self._start_anew(mechanism, label)

    def _start_anew(self, mechanism: Mechanism, label: str) -> None:
        """Show ``mechanism`` (a file's, or a preset's) as loaded, with the run settings' defaults, from its
        assembled sketch; LinkageError naming the joint that stays open, and nothing changed."""
        with self._lock:
            start_state(mechanism)  # LinkageError naming the joint that stays open; nothing changed yet
            self.chain = None
            self.label, self.reference = label, mechanism
            self.settings = MechanismSettings(trace=mechanism.trace)
            self._show_in_menu()
            self._new_mechanism(mechanism, play=True)

    def reset(self) -> None:
        """Start again at t = 0 from the start in force (the chain's Reset: its initial angles and speeds). The
        mechanism is the same, so are its controls: they stay (a box being typed into is not replaced)."""
        with self._lock:
            stuck = self.player.runs and all(len(run.ring) <= 1 and run.failed for run in self.player.runs)
            good = self._ran_from
            if self.chain is not None and stuck and good is not None and good is not self.chain:
                # a start that cannot move (a singular pose): back to the last start that ran, as the chain's
                self._chain_start(good)
                self.sync_all()
                return
            self._new_mechanism(self.mechanism, play=True, start=(self.q0, self.qdot0), same_kind=True)

    # ------------------------------------------------------------------ share links (app/share.py)
    def link_query(self) -> str:
        """The share link's query for this setup: the preset, then the method, integrator, stabilisation and
        traced point where not the preset's, then every control whose value is not the preset's, in the panel's
        units and in the panel's order (a body's size before its inertia, which the size scales; the run's
        tolerance and step; last the start, where not the assembled sketch at rest, as a chain's link carries its
        angles and speeds). LinkageError for a mechanism from a file: a link names a preset; the file itself is
        what to share. A hosted chain's is the chain session's, name for name (app/share.py ``link_query``)."""
        if self.chain is not None:
            return share.link_query(self.chain)
        if not is_mechanism(self.label):
            raise LinkageError(f"link: {self.label!r} was loaded from a file; a link can name a preset only "
                               "(share the file, and load it with 'Load a mechanism file', or save this setup)")
        return "?" + urllib.parse.urlencode(self.setup_pairs())

    def setup_pairs(self) -> list[tuple[str, str]]:
        """The setup's ``(name, value)`` pairs, as a share link carries them (see :meth:`link_query`); for a
        mechanism from a file no preset, and the values that differ from the file's as loaded."""
        if self.chain is not None:
            return urllib.parse.parse_qsl(share.link_query(self.chain)[1:], keep_blank_values=True)
        base = MECHANISM_PRESETS[self.label]() if is_mechanism(self.label) else self.reference
        pairs: list[tuple[str, str]] = [("preset", self.label)] if is_mechanism(self.label) else []
        defaults = MechanismSettings(trace=base.trace)
        for name in ("method", "integrator", "stabilization", "trace"):
            value = getattr(self.settings, name)
            if value != getattr(defaults, name):
                pairs.append((name, value or "(none)"))
        preset_values = {knob.name: knob.value for knob in [*knobs(base, base), *settings_knobs(defaults)]}
        for knob in [*knobs(self.mechanism, self.reference), *settings_knobs(self.settings)]:
            if knob.value != preset_values.get(knob.name):
                pairs.append((knob.name, f"{knob.value:.12g}"))
        at_sketch = {knob.name: knob.value for knob in start_knobs(self.mechanism, self.free, self.sketch_q,
                                                                   self.sketch_q, np.zeros_like(self.sketch_q))}
        for knob in self._start_knobs():
            if not math.isclose(knob.value, at_sketch[knob.name], rel_tol=1e-12, abs_tol=1e-9):
                pairs.append((knob.name, f"{knob.value:.12g}"))
        return pairs

    def setup_document(self) -> bytes:
        """The setup as a file (docs/app.md, "Setup files"): a preset's pairs, or a file's description and
        pairs; LinkageError when the description makes it too large to be read back."""
        description = None if is_mechanism(self.label) or self.chain is not None else self.reference
        return share.setup_document(self.setup_pairs(), description)

    def upload_setup(self, client_id: int | None, name: object, content: object) -> None:
        """A setup file chosen in the Export tab (a viewer of a presenter's session may not load one): read
        whole, then opened (:meth:`open_setup`); a file that cannot be read is one notice, nothing changed."""
        if not self.may_change(client_id):
            raise LinkageError("setup file: the presenter controls this session")
        where = f"setup file {Path(str(name)).name[:60]!r}"
        if not isinstance(content, bytes):
            raise LinkageError(f"{where}: expected the file's content")
        self.open_setup(share.setup_from_state(content, where))

    def open_setup(self, saved: share.SavedSetup) -> None:
        """A saved setup: a chain preset's is hosted here, a mechanism preset's or a description's starts here as
        loaded, then every value is applied (refusals in one notice); a setup naming no mechanism sets this
        one's values."""
        preset = saved.preset
        if saved.mechanism is not None:
            self._start_anew(saved.mechanism, saved.label or saved.mechanism.name)
        elif preset is not None and is_mechanism(preset):
            self._start_anew(MECHANISM_PRESETS[preset](), preset)
        elif preset is not None:
            allowed = [*preset_names(), *mechanism_names()]
            if preset not in allowed:
                raise LinkageError(f"{saved.where}: preset = {preset!r}: allowed {', '.join(allowed)}")
            if self.chain is None:  # a chain's setup: hosted here, then its values (and preset) applied
                self.open_chain(SessionParameters.from_preset(preset))
            self.load_setup(saved.pairs, saved.where)
            return
        self.load_setup(saved.pairs, saved.where)

    def show_link(self) -> None:
        """The link for the current setup in the Export folder, on the server's root address; in a --shared
        lecture also the viewers' link. Neither carries the presenter's secret address: both are written from
        the server's root (``/``), whatever page the presenter opened."""
        if not self.shared:
            query = self.link_query()
            self.share_link.content = (f"[Open this setup](/{query}) (right-click to copy the link), or add this "
                                       f"to the server's address:\n\n`/{query}`")
            return
        try:
            query = self.link_query()
        except LinkageError as error:  # a mechanism from a file: no link names it; the viewers' link still holds
            setup = f"No link for this setup: {markdown_literal(str(error))}"
        else:
            setup = (f"[This setup](/{query}) (right-click to copy): on a server of one's own (`python -m app`) "
                     f"it opens this setup; added to the presenter's address it sets up this lecture:\n\n`/{query}`")
        self.share_link.content = (f"{VIEWERS_LINK}\n\n{setup}")

    def _reading_only(self, handle) -> bool:
        """The controls any browser of a presenter's session may press: they read, for the sender's page alone
        (the equations, their LaTeX, the design saved to the sender's machine), and change nothing shared."""
        design_view = getattr(self, "design_view", None)
        return (handle is self.equations_button or handle is self.equations_tex
                or (design_view is not None and handle is design_view.save_buttons))

    def _equations_asked(self, client) -> None:
        """The Equations button: the presenter's (or a lone browser's) press shows them in the panel everyone
        sees (an action of the session's, through :meth:`guard`); a viewer's opens them in a window of its own
        page only, and nothing of the session, its notices included, changes."""
        if client is None or self.may_change(getattr(client, "client_id", None)):
            self.guard(self.show_equations)
        else:
            quietly(lambda: self.show_equations_to(client), "opening a viewer's equations")

    def _equations_content(self) -> Callable[[], str]:
        """``derive()``: the equations' HTML for the mechanism and method in force now (sympy: call it in a
        thread), or the reason they could not be derived."""
        mechanism = self.chain.chain if self.chain is not None else self.mechanism
        method = self.settings.method

        def derive() -> str:
            from .equations import equations_html  # noqa: PLC0415 - sympy: only when asked for

            try:
                return equations_html(mechanism, method)
            except Exception as error:  # shown where the equations would be; the session goes on
                return f"<p>Could not derive the equations: {html.escape(f'{type(error).__name__}: {error}')}</p>"

        return derive

    def show_equations_to(self, client, wait: bool = False) -> None:
        """The equations of the method in force in a window on ``client``'s page alone (a viewer of a lecture
        reads them without changing what the presenter shows); ``wait``: return once shown (tests)."""
        derive, title = self._equations_content(), f"Equations: {self.label}, {METHODS[self.settings.method]}"

        def show() -> None:
            content = derive()
            if self.closed:
                return

            def build() -> None:
                with client.gui.add_modal(title) as modal:
                    client.gui.add_html(content)
                    client.gui.add_button("Close").on_click(lambda event: modal.close())
            quietly(build, "showing a viewer the equations")

        worker = threading.Thread(target=show, daemon=True, name="mechanism-equations-viewer")
        worker.start()
        if wait:
            worker.join()

    def show_equations(self, wait: bool = False) -> None:
        """Derive (sympy, in a thread: a second or so) and show the equations of the method in force for this
        mechanism in the Equations folder (a hosted chain's: the chain's, in its angles theta, as its LaTeX
        download gives them); shown once, they follow a change of method; ``wait``: return once shown (tests)."""
        self._equations_shown = True
        self._equations_generation += 1
        asked = self._equations_generation
        method, label = self.settings.method, self.label
        self.equations.content = (f"<p><i>Deriving the {html.escape(METHODS[method])} equations (the first time "
                                  f"for this mechanism and method: a few seconds)...</i></p>")
        content_now = self._equations_content()

        def derive() -> None:
            content = content_now()
            # not shown when asked again meanwhile (another method or mechanism): a slower, older derivation
            # (a method's sympy derivation the first time) must not replace the newer one's content
            if not self.closed and asked == self._equations_generation and self.label == label:
                self.equations.content = content

        worker = threading.Thread(target=derive, daemon=True, name="mechanism-equations")
        worker.start()
        if wait:
            worker.join()

    def download_equations(self, client=None, wait: bool = False) -> None:
        """Send the equations of the method in force as LaTeX (``download_file("tex")``), derived in a thread
        (seconds the first time: never on the server's event loop); a refusal (the reduced model) is a notice."""
        def send() -> None:
            try:
                name, content = self.download_file("tex")
            except LinkageError as error:
                if client is None or self.may_change(getattr(client, "client_id", None)):
                    self.show_notice("No equations to download", str(error))
                else:  # a viewer's press: told on its own page
                    reason = str(error)
                    quietly(lambda: client.add_notification("No equations to download", reason, color="yellow",
                                                            auto_close_seconds=NOTICE_SECONDS),
                            "telling a viewer")
                return
            if not self.closed:
                (client or self.target).send_file_download(name, content)

        worker = threading.Thread(target=send, daemon=True, name="mechanism-equations-tex")
        worker.start()
        if wait:
            worker.join()

    def download(self, kind: str, client=None) -> None:
        """Send the run up to the displayed time (``csv`` or ``json``, the columns of ``python -m physics
        mechanism``; in compare mode the first formulation's) to ``client`` (or this session's browser(s))."""
        name, content = self.download_file(kind)
        (client or self.target).send_file_download(name, content)

    def download_file(self, kind: str) -> tuple[str, bytes]:
        """``(file name, content)`` of a download (see :meth:`download`); a hosted chain's are the chain
        session's files (``linkage-{preset}-{method}.csv``, its columns: app/chain_contract.py)."""
        if self.chain is not None:
            params = self.chain
            return chain_contract.download_file(self.player, "main", params, chain_knobs.sketch(params),
                                                self.spec.row_names, kind)
        if kind == "setup":
            stem = "".join(c if c.isalnum() or c in "-_" else "-" for c in self.label)
            return f"linkage-{stem}-setup.json", self.setup_document()
        if kind == "tex":  # the equations of the method in force, as the Equations folder shows them
            from .equations import equations_tex  # noqa: PLC0415 - sympy: only when asked for

            stem = "".join(c if c.isalnum() or c in "-_" else "-" for c in self.label)
            try:
                text = equations_tex(self.mechanism, self.settings.method)
            except ValueError as error:
                raise LinkageError(str(error)) from None
            return f"equations-{stem}-{self.settings.method}.tex", text.encode("utf-8")
        if kind not in ("csv", "json", "html"):
            raise LinkageError(f"download = {kind!r}: allowed csv, json, html, setup, tex")
        spec = self.player.runs[0].spec if self.player.runs else self.spec
        samples = readout.history(self.player, spec.label)
        stem = "".join(c if c.isalnum() or c in "-_" else "-" for c in self.label)
        if kind == "html":  # the chain's "Save HTML replay", drawn as this view draws the mechanism
            from .mechanism_replay import mechanism_replay_html  # noqa: PLC0415 - the recorder: on export only

            title = f"Linkage Lab replay: {self.label}, {METHODS.get(spec.settings.method, spec.settings.method)}"
            try:
                page = mechanism_replay_html(cast(MechanismSpec, spec).draw, samples, title=title)
            except ValueError as error:  # fewer than two samples: a refusal, not a fault
                raise LinkageError(str(error)) from None
            return f"mechanism-{stem}-{spec.settings.method}-replay.html", page.encode("utf-8")
        return f"mechanism-{stem}-{spec.settings.method}.{kind}", run_file(cast(Any, spec), samples, kind)

    def set_value(self, name: str, text: str) -> None:
        """One ``snapshot --set NAME=VALUE``: the names and units of the panel and its share links; for a hosted
        chain the SI units of ``python -m physics --set`` (radians, seconds), as the chain session's."""
        if self.chain is not None and name not in ("method", "integrator", "stabilization", "trace"):
            self._set_chain(name, text, SI)
            return
        self.set_link_value(name, text)

    def load_setup(self, pairs: list[tuple[str, str]], where: str = "the setup") -> None:
        """A saved setup's values by the names of this panel (the mechanism itself is the session's start);
        what is refused is listed in one notice, the rest applied. A hosted chain's setup that names its preset
        (or another chain preset, or a number of bars) starts from that preset's values, as the chain session's."""
        refused: list[str] = []
        if self.chain is not None:
            preset, links, refused = share.start_of(pairs, self.chain.preset, None)
            if any(name == "preset" for name, _ in pairs) or preset != self.chain.preset or links is not None:
                self.open_chain(SessionParameters.from_preset(preset, links=links if preset == "chain" else None))
        refused += share.apply_setup(pairs, self.set_link_value)
        if refused:
            self.show_notice(f"Not applied from {where}", "; ".join(refused))

    def set_link_value(self, name: str, text: str) -> None:
        """One value of a share link (or of ``snapshot --set``): a setting by its name, a control by its name,
        in the panel's units; LinkageError naming it otherwise."""
        if name == "method":
            self.set_method(text)
        elif name == "integrator":
            self.set_integrator(text)
        elif name == "stabilization":
            self.set_stabilization(text)
        elif name == "trace":
            self.set_trace(text)
        else:
            self.set_typed(name, text)

    # ------------------------------------------------------------------ pictures and tests
    def set_camera_view(self, view: str) -> None:
        """``"front"`` (the plane of the motion as a drawing) or ``"3d"``: every camera of this session reframed."""
        self.camera.set_view(view)

    def goto_time(self, t: float, timeout: float = 120.0) -> bool:
        """Pause at simulated time ``t`` from the start (pictures, tests); True when shown."""
        if not (math.isfinite(t) and 0.0 <= t <= MAX_GOTO_TIME):
            raise LinkageError(f"time = {t}: allowed range 0 <= time <= {MAX_GOTO_TIME:g}")
        with self._lock:
            self._restart(0.0, self.q0, self.qdot0, keep_history=False, play=False)
        self.player.wait_idle(timeout)
        return self.player.seek(t, timeout)

    def snapshot(self) -> dict:
        """JSON-able state for tests and ``python -m app snapshot --json`` (docs/app.md lists the keys); a hosted
        chain's is the chain session's, key for key (app/chain_contract.py), so that scripts read one document
        whichever session shows the chain."""
        with self._lock:  # a preset being switched to is read once its runs are installed, not half way
            chain = self.chain
        if chain is not None:
            return self._chain_snapshot(chain)
        player = self.player
        with player.lock:
            run = player.runs[0] if player.runs else None
            sample = None
            if run is not None and len(run.ring):
                i = run.ring.index_at(player.display_time)
                sample = {name: run.ring.get(name, i) for name in ("t", "q", "qdot", "joints", "trace_xy",
                                                                   "kinetic", "potential", "residual")}
            spec = self.spec
            nodes = self.compare_view.poses() if self.compare else self.scene.poses()
            return {
                "session": self.id, "shared": self.shared, "kind": "mechanism", "mechanism": self.label,
                "bodies": [body.name for body in self.mechanism.bodies], "mobility": self.mobility,
                "method": self.settings.method, "stabilization": self.settings.stabilization,
                "compare": self.compare, "runs": [r.spec.label for r in player.runs],
                "divergence": self.compare_view.passing_times() if self.compare else None,
                "free_body": None if not self.free_body.on or self.free_body.loads is None
                else self.free_body.loads.as_dict(),
                "trace": self.settings.trace,
                "values": {knob.name: knob.value for knob in self._mechanism_knobs()},
                "chain": None if self.chain is None else self.chain.as_dict(),  # a hosted chain's parameters
                "integrator": self.settings.integrator,
                "start": {knob.name: knob.value for knob in self._start_knobs()},
                "playing": player.playing, "time": float(player.display_time),
                "q": None if sample is None else [float(v) for v in sample["q"]],
                "qdot": None if sample is None else [float(v) for v in sample["qdot"]],
                "points": list(spec.draw.labels),
                "joints": None if sample is None else [[float(x), float(y)] for x, y in sample["joints"]],
                "trace_xy": None if sample is None else [float(v) for v in sample["trace_xy"]],
                "energy": None if sample is None else {
                    "kinetic": float(sample["kinetic"]), "potential": float(sample["potential"]),
                    "total": float(sample["kinetic"] + sample["potential"])},
                "constraint_residual": None if sample is None else float(sample["residual"]),
                "failed": None if run is None else run.failed,
                "notice": self.notices.text, "frames_sent": self.frames_sent,
                "scene": {"root": self.scene.root, "nodes": nodes, "names": sorted(nodes)},
            }

    # ------------------------------------------------------------------ the chain session's API (a hosted chain)
    def _hosted(self, what: str) -> SessionParameters:
        """The hosted chain's parameters, for a call of the chain session's API; LinkageError naming the call
        for a mechanism (its own calls are named in the message)."""
        if self.chain is None:
            raise LinkageError(f"{what}: applies to a chain preset only; {self.label!r} is a mechanism (its runs: "
                               "download_file('csv'), snapshot(); its values: set(name, value))")
        return self.chain

    @property
    def params(self) -> SessionParameters:
        """The chain session's ``params``: the hosted chain's parameters in force (chain, settings, start; the
        same object as ``chain``); LinkageError for a mechanism (its numbers: ``mechanism``, ``settings``)."""
        return self._hosted("params")

    @property
    def setup(self) -> SessionParameters:
        """The chain session's ``setup`` (what its panel reads): :attr:`params`."""
        return self._hosted("setup")

    @property
    def notice(self) -> str | None:
        """The notice shown (``"Title: text"``), or None: the chain session's ``notice``."""
        return self.notices.text

    def set_start(self, theta0, omega0, play: bool = False) -> None:
        """The chain session's ``set_start``: start again at t = 0 from ``(theta0, omega0)`` (n,) in radians (a
        rest position), paused unless ``play``; LinkageError when the chain's models refuse the state (nothing
        changed), or for a mechanism (its start: :meth:`set_start_pose`)."""
        params = self._hosted("set_start")
        with self._lock:
            new = params.replaced(theta0=np.array(theta0, dtype=float), omega0=np.array(omega0, dtype=float))
            q0, qdot0 = chain_knobs.hosted_start(new)
            self.chain, self.q0, self.qdot0 = new, q0, qdot0
            self._build_scene(q0)
            self.energy_ref = None
            self._clear_plots()
            self._restart(0.0, q0, qdot0, keep_history=False, play=play)
        self.sync_all()

    def set_mechanism(self, name: str, links: int | None = None) -> None:
        """The chain session's ``set_mechanism``: a chain preset (``links`` for ``chain``) hosted here, the
        integration choices in force kept where its methods take them; a mechanism preset shown here as loaded;
        the same preset again starts from its own values. LinkageError naming the presets otherwise."""
        chains, mechanisms = list(preset_names()), mechanism_names()
        if not isinstance(name, str) or name not in (*chains, *mechanisms):
            raise LinkageError(f"mechanism = {name!r}: allowed {', '.join([*chains, *mechanisms])}")
        if name in mechanisms:
            self._start_anew(MECHANISM_PRESETS[name](), name)
            return
        number = None if name != "chain" or links is None else commands.parse_links(links)
        self.open_chain(SessionParameters.from_preset(name, links=number))

    def displayed_state(self) -> tuple[float, np.ndarray, np.ndarray] | None:
        """``(t, theta, omega)`` of the first run at the sample shown (the chain session's); for a mechanism
        ``(t, q, qdot)``, its own coordinates. None before the first sample."""
        found = self.player.current_start()
        if found is None:
            return None
        spec, t, q, qdot = found
        if self.chain is not None and chain_knobs.same_shape(cast(MechanismSpec, spec).chain, self.chain):
            theta, omega = chain_knobs.chain_angles(self.chain, q, qdot)
            return t, theta, omega
        return t, q, qdot

    def state_at(self, t: float, exact: bool = False) -> tuple[np.ndarray, np.ndarray] | None:
        """The displayed run's ``(theta, omega)`` at time ``t`` (interpolated between samples; ``exact``: only at
        a sample's time), if stored: the chain session's; for a mechanism its ``(q, qdot)``."""
        found = self.player.state_at(t, exact)
        if found is None or self.chain is None:
            return found
        return chain_knobs.chain_angles(self.chain, *found)

    def history(self, label: str = "main") -> dict:
        """The stored samples of run ``label`` (or the first) up to the displayed time, in the chain's fields
        (``t``, ``theta``, ``omega``, ``joints``, ``trace_xy``, energies, ``reactions``; pinned: ``tip_reaction``,
        ``constraint_xy``), as the chain session's ``history`` (app/chain_contract.py maps the run's q)."""
        params = self._hosted("history")
        samples = readout.history(self.player, label)
        return chain_contract.chain_history(samples, params, chain_knobs.sketch(params), self.spec.row_names)

    def run_label(self) -> str:
        """The JSON download's description of the run: ``preset (n bars), method, integrator``."""
        return chain_contract.run_label(self._hosted("run_label"))

    def export_csv(self) -> bytes:
        """The run up to the displayed time as the chain session's CSV (app/export.py ``columns``)."""
        self._hosted("export_csv")
        return self.download_file("csv")[1]

    def export_json(self) -> bytes:
        """The run up to the displayed time as the chain session's JSON (its description :meth:`run_label`)."""
        self._hosted("export_json")
        return self.download_file("json")[1]

    def _export_html(self) -> str:
        """The chain session's HTML replay of the run up to the displayed time (``session.export_html()``)."""
        self._hosted("export_html")
        return self.download_file("html")[1].decode("utf-8")

    def part_addresses(self) -> dict[str, tuple[str, int | None]]:
        """Where each part the snapshot names (its ``scene.nodes``) is drawn in the browser: ``(node, instance)``
        (app/snapshot.py waits for the browser to show those positions). Compare mode's translucent copies are
        named by their own scenes (``/compare/<method>/bar_k``)."""
        scene = self.scene
        chain = self.chain
        sources = chain_contract.chain_part_sources(scene.root, chain.n) if chain is not None else {}
        out: dict[str, tuple[str, int | None]] = {}
        for name in [*scene.poses(), *scene.parts(), *sources]:
            where = scene.instance_of(sources.get(name, name))
            if where is not None:
                out[name] = where
        if self.compare:
            for copy in self.compare_view.scenes.values():
                for name in [*copy.poses(), *copy.parts()]:
                    where = copy.instance_of(name)
                    if where is not None:
                        out[name] = where
        return out

    def _chain_snapshot(self, params: SessionParameters) -> dict:
        """The chain session's snapshot of the hosted chain ``params`` (app/chain_contract.py ``snapshot``)."""
        def scene() -> dict:
            nodes = self.compare_view.poses() if self.compare else chain_contract.chain_scene(
                {**self.scene.poses(), **self.scene.parts()}, self.scene.root, params.n, self.trace)
            return {"root": self.scene.root, "nodes": nodes}

        return chain_contract.snapshot(
            session_id=self.id, shared=self.shared, params=params, theta_sketch=chain_knobs.sketch(params),
            compare=self.compare, player=self.player, notice=self.notices.text, energy_reference=None,
            frames_sent=lambda: self.frames_sent, scene=scene, since=self._segment_t0)

    def reset_to_reference(self) -> None:
        """The preset's (or file's) values again; a hosted chain's preset values, its integration choices kept."""
        if self.chain is not None:
            preset = self.chain.preset
            self.open_chain(SessionParameters.from_preset(preset, links=self.chain.n if preset == "chain" else None))
            return
        with self._lock:
            self._new_mechanism(self.reference, play=True)

    def press(self, button: object) -> None:
        """A button of the Playback row (a client may send anything: refused in one line)."""
        actions = {"Play": self.play, "Pause": self.pause, "Step": self.step, "Reset": self.reset}
        if not isinstance(button, str) or button not in actions:
            raise LinkageError(f"playback = {button!r}: allowed {', '.join(actions)}")
        actions[button]()

    def toggle_play(self) -> None:
        if self.player.playing:
            self.pause()
        else:
            self.play()

    def play(self) -> None:
        """Play on; at the end of a run that stopped, say so (Reset or an edit goes on) rather than nothing."""
        with self.player.lock:
            runs = list(self.player.runs)
            stopped = (not self.player.restart_pending and runs and runs[0].failed is not None
                       and self.player.display_time >= runs[0].ring.t_last - 1e-9)
        if stopped:
            raise LinkageError("the simulation stopped here; press Reset (or change a value) to go on")
        self.design_view.set_designing(False)  # Play shows the run (app/design_view.py)
        self.player.play()

    def pause(self) -> None:
        self.player.pause()
        self.player.touch()  # redraw the pose shown (a paused player draws no new frame)
        with self.player.lock:
            self._refresh_status()  # the status line says "paused" at once, not at the next status frame

    def wait_at_start(self) -> None:
        """Back to t = 0 from the start in force, paused: a --shared lecture waits for the presenter's Play (a
        link or setup just applied may have set it playing); the charts show the start sample meanwhile."""
        with self._lock:
            self._restart(0.0, self.q0, self.qdot0, keep_history=False, play=False)
        self.player.touch()

    def step(self) -> None:
        """Pause and advance the display by one sample (1/60 s), simulating it first if need be."""
        self.player.step()

    def scrub(self, t: object) -> None:
        """Show time ``t`` of the run so far (the timeline), paused there; Play goes on from it."""
        number = parse_number("timeline", TIMELINE, t)
        if not 0.0 <= number <= MAX_GOTO_TIME:
            raise LinkageError(f"timeline = {number:g} s: allowed range 0 <= timeline <= {MAX_GOTO_TIME:g} s")
        self.player.seek(number, timeout=0.0)  # returns at once; the player shows it when it can

    def _show_timeline(self, t: float, t_first: float, restarted: bool) -> None:
        """The timeline's range is the run so far, its thumb the time shown (as the chain panel's)."""
        self._timeline_end = t if restarted else max(self._timeline_end, t)
        low, high, value = panel_rows.timeline_window(t, t_first, self._timeline_end)
        # viser calls on_update for a value set here too: this thread's own write is not a scrub
        self._timeline_writer = threading.get_ident()
        try:
            if (self.timeline.min, self.timeline.max) != (low, high):
                self.timeline.min, self.timeline.max = low, high
            if self.timeline.value != value:
                self.timeline.value = value
        finally:
            self._timeline_writer = None

    # ------------------------------------------------------------------ runs
    def _spec(self) -> MechanismSpec:
        if self.worker is not None and not self.worker.alive:  # it died: a new one for the next run
            POOL.release(self.worker)
            self.worker = POOL.acquire()
        # A chain's chunk is compiled code in its own coordinates (a millisecond for the seed's triple pendulum),
        # as the chain route has always run it in the server's interpreter: a worker's pipe would add two
        # process hops to every call, most of an edit's time to its first frame on a loaded machine (BENCHMARKS.md).
        # A general mechanism's numpy and Python per chunk stays in the worker, off the frames' interpreter.
        runner = self.worker.run if self.worker is not None and self.chain is None else None
        trace_of = None if self.chain is None else chain_knobs.ChainTrace(self.chain)  # the chain's traced point
        return MechanismSpec("main", self.mechanism, self.settings, runner=runner, trace_of=trace_of)

    def _restart(self, t0: float, q0: np.ndarray, qdot0: np.ndarray, *, keep_history: bool,
                 play: bool | None = None) -> None:
        # the player reaches a run's model only through RunSpec's members, which MechanismSpec implements
        self.notices.clear()  # a run goes on: a stopped run's notice is about the run it replaces
        self._segment_t0 = t0  # the energy error plot measures from here ("since last change")
        specs = [self.spec] if not self.compare else compare_specs(self.mechanism, self.settings, self.spec.runner)
        for spec in specs:  # a hosted chain's traced point, in every formulation (the divergence is measured there)
            spec.trace_of = self.spec.trace_of
        self.player.restart(cast(Any, specs), t0, [(q0, qdot0)] * len(specs), keep_history=keep_history, play=play)

    def _new_mechanism(self, mechanism: Mechanism, play: bool | None, same_kind: bool = False,
                       start: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        """Assemble ``mechanism`` (LinkageError naming the open joint), rebuild the scene and the panel's
        generated controls, and start at t = 0 from ``start`` (Reset: the start in force) or else the assembled
        sketch at rest. ``same_kind``: a size dragged on a slider: the controls stay (the one under the mouse is
        not replaced), the bars are resized in place and the camera moves only when the size changed noticeably."""
        q0, qdot0, mobility, free = self._start_of(mechanism)
        if is_reduced(self.settings.method) and mobility != 1:  # a new mechanism without a free coordinate
            self.settings = self.settings.model_copy(update={"method": "dae"})
            if self.chain is not None:
                self.chain = chain_knobs.with_settings(self.chain, self.settings)
        same_kind = same_kind and free == self.free  # other start controls: built again
        self.sketch_q, self.free = q0, free
        if start is not None:
            q0, qdot0 = start
        self.mechanism, self.q0, self.qdot0, self.mobility = mechanism, q0, qdot0, mobility
        self.spec = self._spec()
        self._row_names = self.spec.row_names
        draw = self.spec.draw
        self._build_scene(q0)
        self.trace.update(np.zeros((0, 2)))
        self.arrows.hide()
        if not same_kind:
            self._build_knobs()
            if self._equations_shown:  # shown once, they follow the mechanism as they follow the method
                self.show_equations()
        self._show_chosen_plot()
        self._show_facts()
        self._frame_camera(points_at(draw, q0), force=not same_kind)
        self.energy_ref = None
        self._clear_plots()
        self._restart(0.0, q0, qdot0, keep_history=False, play=True if play is None else play)
        self.sync_all()

    def _build_scene(self, q0: np.ndarray) -> None:
        """The mechanism at ``q0``: one in the bodies' colours, or in compare mode three in the methods'."""
        draw = self.spec.draw
        points, centres = points_at(draw, q0), centres_at(q0)
        if self.compare:
            self.scene.remove()
            self.trace.update(np.zeros((0, 2)))
            # a chain's visible gap is the chain's own (0.1 m for its bars of about a metre); a mechanism's scales
            self.compare_view.build(draw, points, centres, self._trace_name(),
                                    gap=VISIBLE_GAP if self.chain is not None else None)
        else:
            self.compare_view.remove()
            self.scene.build(draw, points, centres)

    def _trace_name(self) -> str:
        """The point compare mode measures the formulations' divergence at (the run's traced point)."""
        if self.chain is not None:
            return self.chain.trace_label()
        k = self.spec.trace_index()
        return self.spec.draw.labels[k] if k is not None else f"{self.mechanism.bodies[0].name} (centre of mass)"

    def _continue(self) -> None:
        """New physics from the displayed state on (the history up to it is kept); in compare mode every
        formulation starts again from the start, so that they part from one state."""
        state = self.player.current_start()
        self.spec = self._spec()
        if self.compare:
            self._build_scene(self.q0)  # the traced point may be another (the plots say which)
            self.energy_ref = None
            self._restart(0.0, self.q0, self.qdot0, keep_history=False)
            return
        if state is None or getattr(state[0], "structure", None) != self.spec.structure:
            # nothing shown yet, or the state shown is another mechanism's (a menu choice not drawn yet)
            self._restart(0.0, self.q0, self.qdot0, keep_history=False)
            return
        _, t, q, qdot = state
        self.energy_ref = None
        self._restart(t, q, qdot, keep_history=True)

    def _show_facts(self) -> None:
        m = self.mechanism
        if self.chain is not None:  # the chain panel's description, and a four-bar's reach (Grashof) line
            self.description.content = "*" + markdown_literal(chain_knobs.description(self.chain)) + "*"
            self.facts.content = chain_knobs.facts_line(self.chain)
        else:
            motors = ", ".join(f"{d.joint} ({'speed' if d.speed is not None else 'torque'})" for d in m.drivers)
            self.description.content = "*" + markdown_literal(m.description or m.name) + "*"
            self.facts.content = markdown_literal(
                f"{len(m.bodies)} bodies, {len(m.joints)} joints; {mobility_text_for(m, self.mobility)}"
                + (f" (motors: {motors})" if motors else ""))
        help_text = self._help_text()
        if self.help.content != help_text:
            self.help.content = help_text
        choices = self._plot_choices()
        if tuple(self.plot_choice.options) != choices:  # its callback muted below: the kind shown stays
            syncing, self._syncing = self._syncing, True
            try:
                self.plot_choice.options = choices
                self.plot_choice.value = choices[panel_rows.PLOT_KINDS.index(self._plot_kind)]
            finally:
                self._syncing = syncing
        # viser puts a menu whose value left its new options on the first and calls its callback: muted, or the
        # traced point chosen for this mechanism became "(none)" (crank-rocker, then slider-crank)
        syncing, self._syncing = self._syncing, True
        try:
            self._sync_trace_menu()
            methods = self._methods()
            self.method.options = [method_label(name, self.chain is not None) for name in methods]
            self.method.value = method_label(self.settings.method, self.chain is not None)
            names = [body.name for body in m.bodies]
            if not 1 <= self.free_body.bar <= len(names) or list(self.body_menu.options) != names:
                self.free_body.set_bar(1)  # another mechanism: its first body
            self.body_menu.options = names
            self.body_menu.value = names[self.free_body.bar - 1]
        finally:
            self._syncing = syncing
        self._show_free_body_help()
        self.rests.forget_if_stale()  # another mechanism, or other numbers: the list no longer applies

    def _plot_choices(self) -> tuple[str, ...]:
        """The Plot menu's entries: the chain panel's (``Angles θ(t)``, ...) for a hosted chain, else the
        mechanism's."""
        return panel_rows.CHAIN_PLOT_CHOICES if self.chain is not None else panel_rows.MECHANISM_PLOT_CHOICES

    def _help_text(self) -> str:
        """The Help tab: the chain's help (static/help.md) for a hosted
        chain, :data:`MECHANISM_HELP` for a mechanism."""
        return chain_help() if self.chain is not None else MECHANISM_HELP

    def _trace_choices(self) -> list[str]:
        """The Traced point menu's entries: a hosted chain's are the chain panel's (``coupler point``, ``tip H``,
        ``joint k``, ``centre of mass k``: SessionParameters.trace_choices, the share link's ``trace`` values);
        a mechanism's its named points, or none."""
        if self.chain is not None:
            choices = list(self.chain.trace_choices())
            label = self.chain.trace_label()
            return choices if label in choices else [*choices, label]  # a point of no entry's (a setup's)
        return ["(none)", *self.spec.draw.labels]

    def _sync_trace_menu(self) -> None:
        """The Traced point menu on the entries and the point in force (its callback muted by the caller)."""
        options = self._trace_choices()
        if list(self.trace_menu.options) != options:
            self.trace_menu.options = options
        if self.chain is not None:
            value = self.chain.trace_label()
        else:
            value = self.settings.trace if self.settings.trace in self.spec.draw.labels else "(none)"
        if self.trace_menu.value != value:
            self.trace_menu.value = value

    def _methods(self) -> list[str]:
        """The Method menu's keys: every formulation (the reduced model for mobility 1); for a hosted chain those
        of its own (app.parameters.methods_for) that this session runs."""
        if self.chain is not None:
            return list(chain_knobs.methods(self.chain, self.mobility))
        return [name for name in METHODS if not is_reduced(name) or self.mobility == 1]

    def frame_camera(self, force: bool = False, client=None) -> None:
        """Frame the mechanism in every browser of the session, or only ``client``'s (a newcomer)."""
        if self.camera.disc is not None:
            self.camera.frame(np.array([self.camera.disc[1]]), None, force=force, client=client)

    def _frame_camera(self, points_xy: np.ndarray, force: bool = True) -> None:
        """A chain is framed on the disc it can sweep (its bars' reach around O, the pin H inside), as the chain
        panel framed it, so that a swinging pendulum never leaves the picture; a mechanism on the disc around
        its sketch and its ground points (a motor turns it within about that)."""
        if self.chain is not None:
            self.camera.disc = None
            self.camera.frame(np.asarray(self.chain.L, dtype=float), self.chain.pin, force=force)
            return
        draw = self.spec.draw
        centre, radius = pose_disc(np.concatenate([points_xy, draw.ground]), margin=1.3)
        self.camera.disc = (centre, radius)
        self.camera.frame(np.array([radius]), None, force=force)

    # ------------------------------------------------------------------ frames
    def _on_frame(self, frame: Frame) -> None:
        if self.closed or not self._connection_open() or not frame.runs:
            return
        run = self.player.runs[0] if self.player.runs else None
        spec = self.spec  # read once: a menu choice may replace it meanwhile (another thread)
        if run is None or cast(Any, run.spec).structure != spec.structure:
            return  # a frame of the mechanism shown before: never drawn with another's parts
        rf = frame.runs[0]
        ring = run.ring
        with self.target.atomic():
            if self.compare:
                self.compare_view.show([f for f in frame.runs if len(f.joints) == len(spec.draw.labels)])
            elif len(rf.joints) == len(spec.draw.labels):
                self.scene.show(rf.joints, rf.com)
            if frame.restarted or frame.counter % 2 == 0:
                self.trace.update(self._trace_window(ring, frame.t, rf.index))
            if self.reactions_on:
                self._update_arrows(run, rf, spec)
            self.free_body.update(frame, {r.spec.label: r for r in self.player.runs})
        quietly(self.target.flush, "flushing a frame")
        if hasattr(self, "drag"):
            self.drag.follow()  # bound to the bars while paused, unbound while playing
        self.frames_sent += 1
        if frame.restarted or frame.counter % PLOT_EVERY == 0 or self._plots_due:
            self._plots_due = False
            self._update_plots(ring, rf.index)
            if self.compare:
                self.compare_view.update_plots({r.spec.label: r for r in self.player.runs}, frame.t)
        if frame.restarted or frame.counter % STATUS_EVERY == 0:
            self._show_status(frame.t, ring, rf.index, cast(MechanismSpec, run.spec))
            quietly(lambda: self._show_timeline(frame.t, ring.t_first, frame.restarted), "moving the timeline")
            couples = ("Couples on the body: " + "; ".join(self.free_body.couples)) if self.free_body.on \
                and self.free_body.couples else ""
            if self.couples.content != couples:
                self.couples.content = couples

    def _update_arrows(self, run, rf, spec: MechanismSpec) -> None:
        points, rows, signs = spec.pin_arrows
        if not len(rows):
            self.arrows.hide()
            return
        sample = run.ring.get("reactions", rf.index)
        forces = signs[:, None] * np.stack([sample[rows], sample[rows + 1]], axis=1)
        points_xy = rf.joints[points]
        largest = float(np.max(np.hypot(*forces.T))) or 1.0
        # the Display tab's arrow scale: at its default the largest force is ARROW_FRACTION of the size long
        scale = ARROW_FRACTION * self.display.arrow_scale / Display().arrow_scale * spec.draw.size / largest
        self.arrows.update(points_xy, forces, scale, 0.006 * spec.draw.size)

    def _trace_window(self, ring, t: float, index: int) -> np.ndarray:
        """The traced point's path over the trace length (Display tab) up to stored sample ``index``."""
        if self.display.trace_seconds <= 0.0:
            return np.zeros((0, 2))
        first = ring.index_at(t - self.display.trace_seconds)
        return ring.window(first, index, ["trace_xy"])["trace_xy"]

    def _update_plots(self, ring, index: int) -> None:
        first = ring.index_at(ring.get("t", index) - PLOT_SECONDS)
        stride = max(1, (index - first) // 300)
        kind = self._plot_kind
        extra = ["q", "qdot"] if kind in ("angles", "phase") and self._plotted else []
        data = ring.window(first, index, ["t", "kinetic", "potential", "energy", "reactions", "residual", *extra],
                           stride=stride)
        t = data["t"]
        self.energy_plot.update(t, data["kinetic"], data["potential"], data["energy"])
        if not self.mechanism.drivers and len(t):
            # since the last change (an edit goes on from the displayed state): measured from its first sample
            reference = float(ring.get("energy", ring.index_at(self._segment_t0)))
            in_segment = t >= self._segment_t0 - 1e-9
            self.drift_plot.update(t[in_segment], relative_drift(data["energy"][in_segment], reference,
                                                                 self._energy_scale()))
        if self.residual_plot.handle.visible:
            self.residual_plot.update(t, data["residual"])
        if extra and data["q"].shape[1] == 3 * len(self.mechanism.bodies):
            columns = [c.index for c in self._plotted]
            to_shown = np.array([180.0 / math.pi if c.angular else 1.0 for c in self._plotted])
            values, rates = data["q"][:, columns] * to_shown, data["qdot"][:, columns] * to_shown
            if kind == "angles" and self.coordinate_plot is not None:
                self.coordinate_plot.update(t, *values.T)
            elif kind == "phase" and len(t) >= 2 and self.chain is not None:  # the chain panel's: every bar
                self.phase_image.image = phase_picture(values + np.degrees(chain_knobs.sketch(self.chain)), rates)
            elif kind == "phase" and len(t) >= 2:
                first_one = self._plotted[0]
                unit = coordinate_unit(first_one)
                speed_unit = "deg/s" if first_one.angular else "m/s"
                self.phase_image.image = phase_picture(
                    values[:, :1], rates[:, :1], legend=[coordinate_label(first_one)], wrap=first_one.angular,
                    title=f"Phase portrait: speed ({speed_unit}) against {first_one.body}'s {first_one.axis}",
                    x_label=f"{first_one.axis} ({'deg' if unit == '°' else unit})")
        rows = torque_rows(self._row_names)
        if self.torque_plot is not None and rows:
            self.torque_plot.update(data["t"], *(data["reactions"][:, k] for k in rows))

    def _show_status(self, t: float, ring, index: int, spec: MechanismSpec) -> None:
        """The status line at stored sample ``index`` of ``ring``, the ring of ``spec``'s run (whose mechanism
        measures the shown pose's condition: the session's own spec may be another's already)."""
        energy = float(ring.get("energy", index))
        if self.energy_ref is None and len(ring):
            self.energy_ref = float(ring.get("energy", 0))
        scale = self._energy_scale()
        driven = bool(self.mechanism.drivers)
        drift = None if driven or self.energy_ref is None else float(
            relative_drift(np.array([energy]), self.energy_ref, scale)[0])
        residual = float(ring.get("residual", index))
        method = (", ".join(METHODS[m].split(" (")[0] for m in COMPARE_METHODS) if self.compare
                  else METHODS.get(self.settings.method, self.settings.method))
        integrator = self.settings.integrator if self.mobility > 0 else "position analysis"
        label = ("compare: " if self.compare else "") + f"{method} · {integrator}"
        if self.chain is not None:  # in the chain's words (theta, the chain's energy and loop gap)
            label = ("compare: " + ", ".join(METHOD_LABELS[m] for m in COMPARE_METHODS) if self.compare
                     else f"{METHOD_LABELS.get(self.settings.method, self.settings.method)} · {integrator}")
        text = status_markdown(t, self.player.playing, self.player.real_time_factor(), label, drift, residual,
                               self.notices.text, warning=self.notices.warning)
        condition = spec.condition_at(ring, index)  # this pose's alone (MechanismSpec.chunk leaves it)
        if condition > NEAR_SINGULAR_CONDITION:  # a change point or a dead centre is close
            text += f"\n\nnear a singular pose: Jacobian condition {condition:.2g}"
        if self.status.content != text:
            self.status.content = text

    def _energy_scale(self) -> float:
        """A characteristic energy (total weight times size): the energy error's floor denominator."""
        return sum(b.mass for b in self.mechanism.bodies) * max(self.mechanism.g, 1e-9) * self.spec.draw.size

    def _refresh_status(self) -> None:
        if self.closed or not self.player.runs or not len(self.player.runs[0].ring):
            return
        run = self.player.runs[0]
        ring = run.ring
        quietly(lambda: self._show_status(self.player.display_time, ring, ring.index_at(self.player.display_time),
                                          cast(MechanismSpec, run.spec)),
                "refreshing the status line")

    def _prepare(self, spec: MechanismSpec, q0: np.ndarray, qdot0: np.ndarray) -> None:
        """Derive the chosen formulation before the first chunk (the tree formulations take sympy about a
        second for a six-bar), with a progress notice when it takes longer than PREPARE_NOTICE_DELAY. Once per
        structure and run choices in this session's worker: an edit of a number compiles nothing (the numbers are
        the compiled code's parameters), so it does not pay a call of the worker for it (about half of an
        edit's time to its first frame)."""
        settings = spec.settings
        # a worker's compiled code is its own; a chain run here finds the derived code in the cache folder,
        # whichever session of this process had it derived (a classroom's sessions pay for it once)
        key = (structure_key(spec.chain), settings.method, settings.integrator, settings.stabilization,
               *route_options(settings), id(self.worker) if spec.runner is not None else None)
        if key in self._prepared or key in PREPARED_HERE:
            return
        if not self.compare:  # the start pose is on the page before a first derivation's notice (a cold cache)
            quietly(self.scene.resend, "showing the start pose")
        shown: list = []
        timer = threading.Timer(PREPARE_NOTICE_DELAY, lambda: shown.extend(self.notices.progress(
            "Deriving equations...", f"{METHODS.get(spec.settings.method)} for {spec.chain.name}: sympy derives "
            "them and LLVM compiles them (a second or two).")))
        timer.start()
        try:
            # a few steps compile as much as a whole run; a stiff start must not hold the player here for
            # millions (the run's own calls are bounded by the player's step cap)
            brief = spec.settings.model_copy(update={"t_end": 1e-3, "samples": 2, "max_steps": PREPARE_STEPS})
            if spec.runner is None and self.worker is not None:
                # a hosted chain's chunks run here, but a structure never derived is derived by the worker
                # (sympy holds the interpreter lock for up to seconds): it leaves the generated code in the
                # cache folder, which this interpreter then loads without sympy
                MechanismSpec.simulate(dataclasses.replace(spec, runner=self.worker.run), spec.chain, q0, qdot0,
                                       brief, t_start=0.0)
            spec.simulate(spec.chain, q0, qdot0, brief, t_start=0.0)
        except LinkageError:
            pass  # the run's own first chunk reports it
        else:
            (PREPARED_HERE if spec.runner is None else self._prepared).add(key)
        finally:
            timer.cancel()
            self.notices.dismiss(shown)

    def _on_failure(self, message: str) -> None:
        stuck = all(len(run.ring) <= 1 for run in self.player.runs)
        if self.chain is not None:  # in the chain's words: theta1, bars, methods as the menu names them
            message = in_menu_words(chain_knobs.chain_failure(message, at_start=stuck))
        hint = ("" if "press Reset" in message else
                " This start cannot move. Press Reset to go back to the last start that ran." if stuck
                and self.chain is not None else " Press Reset to start again.")
        self.show_notice("Simulation stopped", f"{message}.{hint}", color="red", seconds=None)

    # ------------------------------------------------------------------ lifetime
    def close(self, clean: bool = False) -> None:
        """Stop the player; with ``clean`` (or shared) remove every node and control (a switch to a chain)."""
        if not self._stop():
            return
        POOL.release(self.worker)
        self.drag.close()
        self.design_view.close()
        for timer in self._typing.values():
            timer.cancel()
        self.numbers.close()
        if self.shared or clean:
            for part in (self.scene, self.trace, self.arrows, self.compare_view, self.free_body, self.analysis):
                quietly(part.remove, "removing a scene part")
            # the Display tab's numbers before the tabs (in self._gui): a tab removes its children with it, and
            # removing a child again makes viser warn on stderr (a refused `snapshot` must say one line)
            self.numbers.remove(list(self.numbers.controls))
            # the Mechanism tab's folders by name too, children before their tab: a browser that lags behind the
            # switch kept "Bodies and motors" beside the chain's panel once (tests/browser/test_preset_switching.py)
            for handle in [*self._knob_handles.values(), *self._typed_boxes.values(), self.knob_folder,
                           self.start_folder, *self._gui]:
                quietly(handle.remove, "removing a control")
            for plot in (self.torque_plot, self.coordinate_plot):
                if plot is not None:
                    plot.remove()

