"""The Analysis section of the one session's panel (issue 24): the studies the command line runs for a
mechanism, computed for the one shown: a work-precision chart, an ensemble of copies a hair apart drawn over
it, a chaos map over two body angles, and the list of its rest poses.

A hosted chain (``session.chain`` not None) keeps what the chain's own Analysis tab gave (issue 7), because its
studies are better than the general ones for a chain: the work-precision chart sweeps the chain's integrators
(RK45, DOP853, the fixed-step midpoint and variational ones: :func:`physics.studies.work_precision.
work_precision_chain`), the ensemble is the chain's batched RK4 :class:`~physics.ensemble.Ensemble` (100 or 1000
copies 1e-9 rad apart, cheap enough to follow the display as it plays, for as long as it plays, with copy 0 put
back on the displayed run at every sample the two share), and the chaos map is the double pendulum's 64 x 64
map. Everything else (the buttons, the workers and their notices, the refusals, discarding a stale study, the
rest poses) is one code path; the chain's studies differ only inside :meth:`MechanismAnalysis.
work_precision_chart`, :meth:`~MechanismAnalysis.chaos_map`, the ensemble's build and :meth:`~MechanismAnalysis.
follow` (the watcher's step of the chain's copies).

For every linkage, chains included (a chain is hosted as a mechanism): a button only starts a
worker thread and returns; one notice says the study is being computed, one that it is done, refused or
discarded. Which studies apply depends on the mobility the motors leave free: every mechanism is integrated
(work-precision), an ensemble needs a free coordinate, a chaos map two, and a rest pose a free motion that no
turning motor drives; a study that does not apply is refused at once in one line.

A study belongs to the run it was started for (the session's ``spec``: a mechanism from the menu or a file,
Reset, an edited value or setting each make a new one): a study whose run was replaced meanwhile is stopped at
its next step and never drawn. What is shown is cleared once the mechanism it was computed for is no longer
the one shown, and an ensemble's copies follow the displayed time only while their run is the one shown (a
watcher thread, so that the session's own code only constructs and removes this section).
"""

from __future__ import annotations

import colorsys
import re
import threading
import time
from typing import Any, Callable

import numpy as np

from physics import FORMULATION_NAMES, LinkageError
from physics.chain_presets import get_preset
from physics.ensemble import Ensemble, MechanismEnsemble
from physics.mechanism.statics import refuse_without_rest, rest_poses
from physics.status import Status
from physics.studies.chaos_map import framed_picture
from physics.studies.report import Progress
from physics.studies.work_precision_chart import chart

from .buffers import ThinnedSeries
from .logs import quietly
from .mechanism_runs import points_at
from .overlays import Plot
from .page import FIGURE_CLASS
from .scene import BAR_WIDTH_FRACTION, to_world
from .text import markdown_literal

# a short sweep (the chain tab's is as short): every method the mechanism has, DOP853 with projection
WORK_PRECISION: dict[str, Any] = dict(horizon=1.0, tolerances=(1e-4, 1e-6, 1e-8), stabilizations=("projection",),
                      integrators=("DOP853",), repeats=1, budget=0.3)
ENSEMBLE_COUNTS = ("20", "100")  # each copy is a whole run of the general engine (no batched kernel)
ENSEMBLE_SPREAD = 1e-5  # rad every body turns between neighbouring copies: a fan that opens within ENSEMBLE_SECONDS
ENSEMBLE_SECONDS = 20.0  # s of copies computed from the displayed state (20 double pendulums: about a second)
ENSEMBLE_RATE = 30  # samples per second of the copies (the scene shows the nearest one)
ENSEMBLE_NODE = "/ensemble/mechanism"
CHAOS_RESOLUTION = 16  # pixels per side: every pixel is a run of the general engine
CHAOS_T_MAX = 10.0
CHAOS_STEP = 0.05  # s between samples: a flip is dated to this (the command's default is 0.01)
CHAOS_METHOD = "dae"  # the fastest of the general engine's formulations for a map's short runs
CHAOS_DISPLAY_SCALE = 16  # each pixel drawn as 16 x 16 screen pixels: 256 px, as the chain's map
WATCH_SECONDS = 1.0 / 30.0  # how often the watcher moves the copies drawn (and looks for a change of mechanism)
IDLE_WATCH_SECONDS = 0.2  # how often it looks for a change of mechanism while no copies are drawn
# a hosted chain's studies: the chain's Analysis tab's (main's app/analysis.py, issue 7)
CHAIN_ENSEMBLE_COUNTS = ("100", "1000")  # the batched RK4 kernel: 1000 copies still follow the display
CHAIN_ENSEMBLE_SPREAD = 1e-9  # rad between the initial angles of neighbouring copies
CHAIN_ENSEMBLE_NODE = "/ensemble/links"
MAX_FRAME_DT = 4.0  # s of simulated time the copies follow in one look at most (a jump back or far ahead restarts
# them instead); 4 s covers the fastest playback (8x) on a server that looks only twice a second: a slow or loaded
# machine must not restart the ensemble on every look (it would never fan out); the catch-up costs at most 960
# RK4 steps of the batch
SPREAD_EVERY = 3  # looks of the watcher between updates of a chain's spread figure (10 Hz)
SPREAD_POINTS = 512  # points of that figure at most, over the ensemble's whole life (ThinnedSeries)
CHAIN_CHAOS_PRESET = "double"  # the chain's map is the double pendulum's, whatever chain is shown
CHAIN_CHAOS_METHOD = "lagrange"
CHAIN_CHAOS_RESOLUTION = 64
CHAIN_CHAOS_STEP = 0.01
CHAIN_CHAOS_DISPLAY_SCALE = 4  # each pixel drawn as 4 x 4 screen pixels: with its axes and colour bar, 384 px wide
CHAIN_INTEGRATORS = ("RK45", "DOP853", "midpoint", "variational")  # work_precision_chain's: the chain tab's chart
STUDIES = {"chart": "work-precision chart", "ensemble": "ensemble", "chaos": "chaos map",
           "equilibrium": "rest poses"}


class Discarded(Exception):
    """The run a study was computed for was replaced (another mechanism, Reset, an edit): stop, draw nothing."""


class _Checkpoint(Progress):
    """A silent progress bar whose every step stops the sweep once its run has been replaced."""

    def __init__(self, stale: Callable[[], bool]) -> None:
        super().__init__(0, "work-precision", enabled=False)
        self._stale = stale

    def step(self, label: str = "") -> None:
        if self._stale():
            raise Discarded


def copy_segments(draw, q: np.ndarray) -> np.ndarray:
    """Every copy's bars at poses ``q (N, 3 B)`` -> line segments ``(N * S, 2, 3)`` in the world."""
    ends = points_at(draw, q)[:, draw.segments]  # (N, S, 2, 2)
    return to_world(ends.reshape(-1, 2, 2)).astype(np.float32)


def segments(joints: np.ndarray) -> np.ndarray:
    """A chain's joint positions (N, n + 1, 2) -> line segments (N * n, 2, 3) in the world (the x-z plane)."""
    ends = np.stack([joints[:, :-1], joints[:, 1:]], axis=2)  # (N, n, 2, 2)
    return to_world(ends.reshape(-1, 2, 2)).astype(np.float32)


def follows_on(dt: float) -> bool:
    """Whether a chain's ensemble follows a look that finds the display moved by ``dt`` s of simulated time
    (advancing its copies by ``dt``), rather than starting again from the displayed state: it does for every step
    forward a playing server makes, however seldom it looks, and not for a jump back or far ahead (the timeline)."""
    return 0.0 <= dt <= MAX_FRAME_DT


def catch_up(ensemble: Ensemble, t: float, displayed_state: Callable[[], tuple | None], rounds: int = 8) -> float:
    """Advance copies built from the state at ``t`` to where the display is now; returns the display time they
    stand for. Why: a playing display moves on while the copies are built (in a worker: the first build
    compiles, a loaded machine is slow), and a look that finds them more than ``MAX_FRAME_DT`` behind takes it
    for a jump and builds them again, which on a loaded machine never ended (CI saw the ensemble rebuilt
    through 6 s of play). Each round closes the gap the last one left; a display that went back is left to the
    next look (a jump back restarts)."""
    for _ in range(rounds):
        state = displayed_state()
        if state is None or not state[0] > t:
            break
        gap = state[0] - t
        ensemble.advance(gap)
        t = state[0]
        if gap <= MAX_FRAME_DT / 8:
            break
    return t


def rest_table(mechanism, poses) -> str:
    """Markdown table of rest poses: each body's angle from the sketch, stability and potential energy."""
    names = [body.name for body in mechanism.bodies]
    head = "| " + " | ".join(markdown_literal(name) for name in names) + " | stable | V (J) |"
    rule = "|" + "---|" * (len(names) + 2)
    rows = ["| " + " | ".join(f"{np.degrees(v):.1f}°" for v in pose.q[2::3]) + " | "
            + ("yes" if pose.stable else "flat" if pose.neutral else "no") + f" | {pose.potential:.4g} |"
            for pose in poses]
    return "\n".join([head, rule, *rows])


class MechanismAnalysis:
    """The Analysis folder of a :class:`~app.session.Session` (``session``): its widgets, its
    workers and the ensemble drawn in the session's scene. ``remove()`` ends it with the session."""

    def __init__(self, session) -> None:
        self.session = session
        self.closed = False
        self._lock = threading.Lock()
        self._jobs: dict[str, threading.Thread] = {}
        self._shown: dict[str, Any] = {}  # study -> the mechanism (object) its result shown was computed for
        self.image_handle: Any = None
        self.ensemble: MechanismEnsemble | Ensemble | None = None  # a mechanism's computed copies or a chain's
        self.ensemble_node: Any = None
        self._ensemble_spec: Any = None  # the run the copies were started from
        self._ensemble_t0 = 0.0
        self._ensemble_t: float | None = None  # a chain's copies: the display time they stand for
        self._spread = ThinnedSeries(SPREAD_POINTS)  # a chain's spread over the ensemble's life (its figure)
        self._looks = 0  # a chain's copies: looks that advanced them (the spread figure every SPREAD_EVERY)
        self._ensemble_q: np.ndarray | None = None  # (samples, N, 3 B)
        self._ensemble_index = -1
        self._ensemble_generation = 0  # bumped when the copies shown or under way are dropped
        self._chain_kind = session.chain is not None  # the kind the widgets are labelled for (_sync_kind)
        self.ensemble_count = int(self._counts()[0])
        self.notices: list[tuple[str, str]] = []  # (title, body) of every notice this section showed (tests)
        self.times: np.ndarray | None = None  # the chaos map's flip times shown
        self.poses: list = []  # the rest poses shown
        self._setting_box = False  # this section unticks the Ensemble box itself (not the user)
        self._build()
        self._watcher = threading.Thread(target=self._watch, name=f"mechanism-analysis-{session.id}", daemon=True)
        self._watcher.start()

    # ------------------------------------------------------------------ widgets
    def _build(self) -> None:
        s = self.session
        gui = s.target.gui
        tabs = getattr(s, "tabs", None)  # the panel's tabs: Analysis after Help, as in a chain's panel
        self.folder = tabs.add_tab("Analysis") if tabs is not None else gui.add_folder("Analysis",
                                                                                      expand_by_default=False)
        with self.folder:
            self.chart_button = gui.add_button("Work-precision chart", hint=self._chart_hint())
            self.chart_button.on_click(lambda event: s.guard(self.work_precision_chart))
            self.chart_status = gui.add_markdown("Error of the traced point against wall time, every method.")
            self.chart_html = gui.add_html("")
            self.ensemble_box = gui.add_checkbox("Ensemble", initial_value=False, hint=self._ensemble_hint())
            self.ensemble_box.on_update(lambda event: None if self._setting_box else s.guard(
                lambda: self.set_ensemble(self.ensemble_box.value)))
            self.count_dropdown = gui.add_dropdown("Ensemble copies", self._counts(),
                                                   initial_value=str(self.ensemble_count))
            self.count_dropdown.on_update(lambda event: None if self._setting_box else s.guard(
                lambda: self.set_ensemble(self.ensemble_box.value, self.count_dropdown.value)))
            self.ensemble_status = gui.add_markdown("")
            self.spread_plot = Plot(gui, "Ensemble spread: largest distance of the traced point (a chain's tip) "
                                    "from copy 0",
                                    ["spread"], [(148, 103, 189)], log=True, height=140, y_label="m")
            self.spread_plot.set_visible(False)
            self.chaos_button = gui.add_button(self._chaos_label(), hint=self._chaos_hint())
            self.chaos_button.on_click(lambda event: s.guard(self.chaos_map))
            self.chaos_status = gui.add_markdown("")
            self.rest_button = gui.add_button("Rest poses", hint="Every pose where the mechanism stays at rest, "
                                              "and whether it is stable (mobility >= 1, no turning motor)")
            self.rest_button.on_click(lambda event: s.guard(self.equilibria))
            self.rest_status = gui.add_markdown("")

    # ------------------------------------------------------------------ the kind shown: a chain or a mechanism
    def _for_chain(self) -> bool:
        """A hosted chain is shown: its studies are the chain tab's (see the module's docstring)."""
        return self.session.chain is not None

    def _counts(self) -> tuple[str, ...]:
        return CHAIN_ENSEMBLE_COUNTS if self._for_chain() else ENSEMBLE_COUNTS

    def _chart_hint(self) -> str:
        if self._for_chain():
            return f"Error against wall time of the chain's method with {', '.join(CHAIN_INTEGRATORS)} (a few seconds)"
        return "Error against wall time for every method of this mechanism (DOP853, projection; a few seconds)"

    def _ensemble_hint(self) -> str:
        if self._for_chain():
            return (f"Copies of the chain whose initial angles differ by {CHAIN_ENSEMBLE_SPREAD:g} rad, advanced by "
                    "RK4 with the display as it plays")
        return (f"Copies of the mechanism, every body turned {ENSEMBLE_SPREAD:g} rad further than the last, run "
                f"{ENSEMBLE_SECONDS:g} s from the displayed state (mobility >= 1)")

    def _chaos_label(self) -> str:
        if self._for_chain():
            return f"Chaos map (double pendulum, {CHAIN_CHAOS_RESOLUTION} x {CHAIN_CHAOS_RESOLUTION})"
        return f"Chaos map ({CHAOS_RESOLUTION} x {CHAOS_RESOLUTION})"

    def _chaos_hint(self) -> str:
        if self._for_chain():
            return (f"Initial-angle plane of the double pendulum (theta1 across, theta2 up) coloured by the time "
                    f"until a link first flips (log scale, up to {CHAOS_T_MAX:g} s)")
        return "The first two bodies' initial angles, coloured by the time until a body turns over (mobility >= 2)"

    def _sync_kind(self) -> None:
        """Label the widgets for the kind shown (the session went from a mechanism to a chain or back: the menu,
        a share link); the copies' count goes to that kind's default. Called by the watcher and by every study's
        entry point, so that a click right after the change already gets the kind's study."""
        chain = self._for_chain()
        if chain == self._chain_kind:
            return
        self._chain_kind = chain
        self.ensemble_count = int(self._counts()[0])
        self._setting_box = True  # the dropdown's own update is not the user's
        try:
            self.count_dropdown.options = self._counts()
            self.count_dropdown.value = str(self.ensemble_count)
        finally:
            self._setting_box = False
        self.chaos_button.label = self._chaos_label()
        for handle, hint in ((self.chart_button, self._chart_hint()), (self.ensemble_box, self._ensemble_hint()),
                             (self.chaos_button, self._chaos_hint())):
            quietly(lambda: setattr(handle, "hint", hint), "relabelling the Analysis tab")

    def _notice(self, title: str, body: str, color: str) -> None:
        self.notices.append((title, body))
        self.session.show_notice(title, body, color=color)

    # ------------------------------------------------------------------ jobs
    def _start(self, name: str, compute: Callable[[Callable[[], bool]], Any], show: Callable[[Any], str],
               status, wanted: Callable[[], bool] | None = None) -> bool:
        """Run ``compute(stale)`` in a worker, then ``show(result)`` (it returns the done notice's text): one
        notice now, one at the end. ``stale()`` is True once the run it was started for has been replaced (or
        ``wanted()`` is False: the user called it off); a stale study is stopped and nothing of it is drawn, nor
        its refusal or failure, which were about the run replaced. Without ``wanted``, a study already under
        way is not started twice; with it, the older one is called off by ``wanted`` and the new one starts."""
        s = self.session
        job = self._jobs.get(name)
        if wanted is None and job is not None and job.is_alive():
            return False
        spec, mechanism, label = s.spec, s.mechanism, s.label
        study = STUDIES[name]
        still_wanted = wanted or (lambda: True)

        def stale() -> bool:
            return self.closed or s.closed or s.spec is not spec or not still_wanted()

        def work() -> None:
            failure = None
            try:
                result = compute(stale)
            except Discarded:  # stale() holds now: said below as discarded, nothing of it drawn
                result = None
            except LinkageError as error:
                failure = ("refused", str(error), "yellow")
            except Exception as error:  # the worker's boundary: the session goes on
                failure = ("failed", f"{type(error).__name__}: {error}", "red")
            with self._lock:
                if stale():
                    text = None
                elif failure is not None:
                    status.content = f"{study.capitalize()} {failure[0]}: {markdown_literal(failure[1])}"
                    text = None
                else:
                    text = show(result)
                    self._shown[name] = mechanism
            if text is not None:
                self._notice("Done", text, "green")
            elif failure is not None and not stale():
                self._notice(f"{study.capitalize()} {failure[0]}", failure[1], failure[2])
            elif not (self.closed or s.closed or not still_wanted()):  # the run changed: say so, once
                if name == "ensemble":
                    self._untick()
                status.content = f"The {study} of {markdown_literal(label)} was discarded: the run changed."
                self._notice(f"{study.capitalize()} discarded", f"{label} changed while it was computed "
                             "(another mechanism, Reset or an edit); press again", "yellow")

        job = threading.Thread(target=work, name=f"mechanism-{name}-{s.id}", daemon=True)
        self._jobs[name] = job
        status.content = f"**Computing** the {study} of {markdown_literal(label)}..."
        self._notice("Computing", f"the {study} of {label} (a few seconds)", "blue")
        job.start()
        return True

    def _refuse(self, name: str, reason: str, status) -> None:
        study = STUDIES[name]
        status.content = f"{study.capitalize()} refused: {markdown_literal(reason)}"
        self._notice(f"{study.capitalize()} refused", reason, "yellow")

    def wait(self, name: str, timeout: float = 300.0) -> None:
        """Wait for a study's worker (tests)."""
        job = self._jobs.get(name)
        if job is not None:
            job.join(timeout)

    # ------------------------------------------------------------------ work-precision chart
    def work_precision_chart(self) -> None:
        """Every method of this mechanism swept over the tolerance (any mechanism: a driven one is integrated
        with its motor's angle held as a constraint), drawn as the chain tab's chart. A hosted chain gets the
        chain tab's own chart (:meth:`_chain_chart`): its method with every integrator the chain runs."""
        self._sync_kind()
        if self._for_chain():
            self._chain_chart()
            return
        mechanism, label = self.session.mechanism, self.session.label

        def compute(stale):
            # studies integrate in this process when asked (a worker thread), never at import: a server that
            # only animates mechanisms loads no formulation (tests/app/test_mechanism_workers.py)
            from physics.studies.mechanism_work_precision import mechanism_case  # noqa: PLC0415

            case = mechanism_case(mechanism, progress=_Checkpoint(stale), name=label, **WORK_PRECISION)
            return case, chart(label, case, narrow=True)

        def show(result) -> str:
            case, svg = result
            self.chart_html.content = f'<div style="width:100%">{fit_width(svg)}</div>'
            methods = sorted({curve["formulation"] for curve in case["curves"]})
            self.chart_status.content = markdown_literal(
                f"Work-precision of {label}: {', '.join(methods)}, horizon {case['horizon']:g} s, "
                f"{case['failures']} failed runs.")
            return f"work-precision chart of {label} ({len(case['curves'])} methods)"

        self._start("chart", compute, show, self.chart_status)

    def _chain_chart(self) -> None:
        """The chain tab's chart for the parameters in force: the chain's method (Lagrange for one the chain's
        sweep does not run) with RK45 and DOP853 over the tolerance and the fixed-step midpoint and variational
        integrators over the step, 5 s from the chain's start. Why not the mechanism's sweep: for a chain the
        question the chart answers is which integrator, and the chain's models run all of them (the general
        engine only scipy's, with projection)."""
        params, label = self.session.chain, self.session.label
        assert params is not None
        formulations = (params.method,) if params.method in FORMULATION_NAMES else ("lagrange",)
        chain, theta0, omega0, trace = params.chain, params.theta0.copy(), params.omega0.copy(), params.trace

        def compute(stale):
            from physics.studies import work_precision as bench  # noqa: PLC0415 - see work_precision_chart

            # no steps to stop at: what it computed for a run replaced meanwhile is discarded at its end (_start)
            result = bench.work_precision_chain(chain, theta0, omega0, trace=trace, formulations=formulations,
                                                integrators=CHAIN_INTEGRATORS, narrow=True)
            return result

        def show(result) -> str:
            case, svg = result
            self.chart_html.content = f'<div style="width:100%">{fit_width(svg)}</div>'
            integrators = [i for i in CHAIN_INTEGRATORS if any(c["integrator"] == i for c in case["curves"])]
            failed = sum(point["status"] != Status.OK for curve in case["curves"] for point in curve["points"])
            self.chart_status.content = markdown_literal(
                f"Work-precision of {label}: {params.n} bars, {formulations[0]} with {', '.join(integrators)}, "
                f"horizon {case['horizon']:g} s, {failed} failed runs.")
            return f"work-precision chart of {label} ({len(case['curves'])} integrators)"

        self._start("chart", compute, show, self.chart_status)

    # ------------------------------------------------------------------ chaos map
    def chaos_map(self) -> None:
        """The chaos map over the first two bodies' initial angles (mobility >= 2; refused in one line
        otherwise), row band by row band so that a change of mechanism stops it. A hosted chain gets the chain
        tab's map (:meth:`_chain_chaos_map`)."""
        self._sync_kind()
        if self._for_chain():
            self._chain_chaos_map()
            return
        s = self.session
        mechanism, label = s.mechanism, s.label
        if s.mobility < 2:
            self._refuse("chaos", f"{label} has mobility {s.mobility}; a chaos map spans two initial coordinates, "
                         "so it needs a mechanism of mobility >= 2 (two free coordinates), e.g. a double pendulum "
                         "(docs/examples/double-pendulum.toml)", self.chaos_status)
            return
        from physics.studies import mechanism_chaos  # noqa: PLC0415 - see work_precision_chart

        indices = mechanism_chaos.angle_indices(mechanism, None)
        names = [body.name for body in mechanism.bodies]
        axes = (f"{names[indices[0] // 3]}.phi", f"{names[indices[1] // 3]}.phi")

        def compute(stale):
            mechanism_chaos.check_mechanism_map(mechanism, CHAOS_METHOD, CHAOS_RESOLUTION, CHAOS_T_MAX, CHAOS_STEP)
            times = np.empty((CHAOS_RESOLUTION, CHAOS_RESOLUTION))
            for task in mechanism_chaos.mechanism_tiles(mechanism, indices, CHAOS_RESOLUTION, CHAOS_T_MAX,
                                                        CHAOS_STEP, CHAOS_METHOD):
                if stale():
                    raise Discarded
                start, band, _ = mechanism_chaos.compute_mechanism_tile(task)
                times[start : start + band.shape[0]] = band
            rgb = mechanism_chaos.mechanism_rgb(times, CHAOS_T_MAX, CHAOS_STEP)
            rgb = np.repeat(np.repeat(rgb, CHAOS_DISPLAY_SCALE, axis=0), CHAOS_DISPLAY_SCALE, axis=1)
            picture = framed_picture(rgb, CHAOS_T_MAX, CHAOS_STEP, title=f"first turn-over time of {label}"[:48],
                                     axes=axes)
            return times, picture

        def show(result) -> str:
            times, picture = result
            self.times = times
            if self.image_handle is None:
                with self.folder:
                    self.image_handle = s.target.gui.add_image(picture, label="Chaos map", format="png",
                                                               order=self.chaos_status.order + 0.1)
            else:
                self.image_handle.image = picture
                self.image_handle.visible = True
            flipped = int(np.count_nonzero(times > 0))
            self.chaos_status.content = markdown_literal(
                f"Chaos map of {label}: {axes[0]} across, {axes[1]} up, in [-180°, 180°]; {flipped} of "
                f"{times.size} starts turn a body over within {CHAOS_T_MAX:g} s.")
            return f"chaos map of {label} ({CHAOS_RESOLUTION} x {CHAOS_RESOLUTION})"

        self._start("chaos", compute, show, self.chaos_status)

    def _chain_chaos_map(self) -> None:
        """The chain tab's map: the double pendulum's initial-angle plane, 64 x 64 by the chain's compiled
        Lagrange model, whatever chain is shown (a map needs two free angles and is a picture of the double
        pendulum's chaos, the course's example; the chain tab never mapped another)."""
        s = self.session
        label = s.label
        chain = get_preset(CHAIN_CHAOS_PRESET).chain

        def compute(stale):
            from physics.studies import chaos_map as chaos  # noqa: PLC0415 - see work_precision_chart

            times = chaos.compute_map(chain, CHAIN_CHAOS_METHOD, CHAIN_CHAOS_RESOLUTION, CHAOS_T_MAX, CHAIN_CHAOS_STEP)
            rgb = chaos.to_rgb(times, CHAOS_T_MAX, CHAIN_CHAOS_STEP)
            rgb = np.repeat(np.repeat(rgb, CHAIN_CHAOS_DISPLAY_SCALE, axis=0), CHAIN_CHAOS_DISPLAY_SCALE, axis=1)
            return times, framed_picture(rgb, CHAOS_T_MAX, CHAIN_CHAOS_STEP)  # axes, ticks, colour bar, key

        def show(result) -> str:
            times, picture = result
            self.times = times
            if self.image_handle is None:
                with self.folder:
                    self.image_handle = s.target.gui.add_image(picture, label="Chaos map (double pendulum)",
                                                               format="png", order=self.chaos_status.order + 0.1)
            else:
                self.image_handle.image = picture
                self.image_handle.visible = True
            self.chaos_status.content = markdown_literal(
                f"Chaos map of the double pendulum: {CHAIN_CHAOS_RESOLUTION} x {CHAIN_CHAOS_RESOLUTION}, theta1 "
                f"across, theta2 up, in [-pi, pi], flip time up to {CHAOS_T_MAX:g} s.")
            return f"chaos map of the double pendulum ({CHAIN_CHAOS_RESOLUTION} x {CHAIN_CHAOS_RESOLUTION}, {label} shown)"

        self._start("chaos", compute, show, self.chaos_status)

    # ------------------------------------------------------------------ rest poses
    def equilibria(self) -> None:
        """Every rest pose the search finds, lowest potential first (a mechanism with a free motion and no
        turning motor; refused in one line otherwise)."""
        mechanism, label = self.session.mechanism, self.session.label
        try:
            refuse_without_rest(mechanism)
        except LinkageError as error:
            self._refuse("equilibrium", str(error), self.rest_status)
            return

        def show(poses) -> str:
            stable = sum(pose.stable for pose in poses)
            self.poses = poses
            self.rest_status.content = (markdown_literal(f"Rest poses of {label}: {len(poses)} found, {stable} "
                                                         "stable; body angles from the sketch, lowest energy first.")
                                        + "\n\n" + rest_table(mechanism, poses))
            return f"{len(poses)} rest poses of {label} ({stable} stable)"

        self._start("equilibrium", lambda stale: rest_poses(mechanism), show, self.rest_status)

    # ------------------------------------------------------------------ ensemble
    def set_ensemble(self, on: object, count: object = None) -> None:
        """The ensemble on (computed from the displayed state in a worker, then drawn over the mechanism) or off;
        ``count`` one of ENSEMBLE_COUNTS (a hosted chain's: CHAIN_ENSEMBLE_COUNTS)."""
        self._sync_kind()
        if count is not None:
            counts = self._counts()
            text = str(count).strip() if isinstance(count, (str, int)) and not isinstance(count, bool) else None
            if text not in counts:
                raise LinkageError(f"ensemble copies = {count!r}: allowed {', '.join(counts)}")
            self.ensemble_count = int(text)
        self._drop_ensemble()  # and calls off copies under way
        if not on:
            self.ensemble_status.content = ""
            return
        s = self.session
        if s.mobility < 1:
            self._untick()
            self._refuse("ensemble", f"{s.label} has mobility 0: its motors fix every body, so every copy would "
                         "follow the same path; an ensemble needs mobility >= 1", self.ensemble_status)
            return
        if self._for_chain():
            self._start_chain_ensemble()
        else:
            self._start_ensemble()

    def _start_ensemble(self) -> None:
        """A mechanism's copies: whole runs of the general engine (no batched kernel), ENSEMBLE_SECONDS of them
        computed at once from the displayed state; the watcher shows the sample nearest the displayed time."""
        s = self.session
        spec, mechanism, label, count = s.spec, s.mechanism, s.label, self.ensemble_count
        settings = s.settings
        method = "dae" if s.compare else settings.method
        found = s.player.current_start()
        if (found is not None and getattr(found[0], "structure", None) == spec.structure
                and not any(driver.speed for driver in mechanism.drivers)):
            _, t0, q0, qdot0 = found  # the displayed state (a turning motor's angle depends on the time: t = 0)
        else:
            t0, q0, qdot0 = 0.0, s.q0, s.qdot0
        samples = int(round(ENSEMBLE_SECONDS * ENSEMBLE_RATE)) + 1

        def compute(stale):
            def step(k: int) -> None:
                if stale():
                    raise Discarded

            ensemble = MechanismEnsemble(mechanism, count=count, spread=ENSEMBLE_SPREAD, t_end=ENSEMBLE_SECONDS,
                                         samples=samples, method=method, stabilization=settings.stabilization,
                                         q0=q0, qdot0=qdot0)
            ensemble.run(progress=step)
            if not ensemble.alive.any():
                raise LinkageError(f"every copy stopped: {ensemble.message}")
            q = np.full((samples, count, len(q0)), np.nan)
            for k, run in enumerate(ensemble.runs):
                if run is not None:
                    q[:, k] = run.q
            return ensemble, q

        def show(result) -> str:
            ensemble, q = result
            alive = q[:, ensemble.alive]
            self.ensemble, self._ensemble_q, self._ensemble_spec, self._ensemble_t0 = ensemble, alive, spec, t0
            self._ensemble_index = 0
            # thin lines just in front of the bars (the camera looks from -y): copies still together show on them
            width = BAR_WIDTH_FRACTION * spec.draw.size
            self.ensemble_node = s.target.scene.add_line_segments(  # replaces a node of the same name
                ENSEMBLE_NODE, copy_segments(spec.draw, alive[0]),
                copy_colors(alive.shape[1], len(spec.draw.segments)), thickness=0.3 * width,
                position=(0.0, -width, 0.0))
            spread = ensemble.tip_spread()
            self.spread_plot.update(t0 + ensemble.t, np.maximum(spread, 1e-16))
            self.spread_plot.set_visible(True)
            self.ensemble_status.content = markdown_literal(
                f"{count} copies of {label} ({int(ensemble.alive.sum())} ran to the end), {method}, from "
                f"t = {t0:.3g} s to {t0 + ENSEMBLE_SECONDS:.3g} s; the traced point's spread grows from "
                f"{spread[1]:.2g} m to {spread[-1]:.2g} m." + (f" {ensemble.note}" if ensemble.note else ""))
            return f"ensemble of {count} copies of {label}"

        generation = self._ensemble_generation
        self._start("ensemble", compute, show, self.ensemble_status,
                    wanted=lambda: generation == self._ensemble_generation)

    def _start_chain_ensemble(self) -> None:
        """A hosted chain's copies (the chain tab's ensemble): the chain's batched RK4 :class:`Ensemble` built from
        the displayed state (copy 0 exactly on it) in a worker, compiled there and caught up with a display that
        played on meanwhile (:func:`catch_up`); the watcher then advances them with the display for as long as it
        plays (:meth:`follow`). Why not the mechanism's precomputed window: a chain's kernel steps 1000 copies
        faster than real time, so the fan can be watched opening for minutes, not 20 s."""
        s = self.session
        params, spec, label, count = s.chain, s.spec, s.label, self.ensemble_count
        assert params is not None
        state = s.displayed_state()  # the hosted chain's (t, theta, omega) at the sample shown
        if state is None or len(state[1]) != params.n:
            t, theta, omega = 0.0, params.theta0.copy(), params.omega0.copy()
        else:
            t, theta, omega = state
        chain, damping = params.chain, params.damping
        method = params.method if params.method in FORMULATION_NAMES else "lagrange"

        def compute(stale):
            ensemble = Ensemble(chain, theta, omega, method, count, CHAIN_ENSEMBLE_SPREAD, damping=damping)
            ensemble.prepare()  # its first compilation here, not in the watcher (catch_up may take no step)
            if stale():
                raise Discarded
            shown = catch_up(ensemble, t, s.displayed_state)
            return ensemble, shown

        def show(result) -> str:
            ensemble, shown = result
            self.ensemble, self._ensemble_spec, self._ensemble_t0, self._ensemble_t = ensemble, spec, t, shown
            self._draw_copies(CHAIN_ENSEMBLE_NODE, segments(ensemble.joints()), copy_colors(count, params.n))
            self._spread.clear()
            self._spread.append(shown, ensemble.tip_spread())
            self._looks = 0
            self.spread_plot.set_visible(True)
            self.ensemble_status.content = markdown_literal(
                f"{count} copies of {label} from t = {t:.3g} s, {method}, RK4 step {ensemble.step * 1e3:.3g} ms; "
                "they follow the display as it plays.")
            return f"ensemble of {count} copies of {label}"

        generation = self._ensemble_generation
        self._start("ensemble", compute, show, self.ensemble_status,
                    wanted=lambda: generation == self._ensemble_generation)

    def _draw_copies(self, name: str, points: np.ndarray, colors: np.ndarray) -> None:
        """The copies' bars as thin lines just in front of the mechanism's (the camera looks from -y): copies still
        together show on them. One node for either kind (``name`` replaces a node of the same name)."""
        s = self.session
        width = BAR_WIDTH_FRACTION * s.spec.draw.size
        self.ensemble_node = s.target.scene.add_line_segments(name, points, colors, thickness=0.3 * width,
                                                              position=(0.0, -width, 0.0))

    def follow(self, t: float) -> None:
        """Advance a chain's copies to the displayed time ``t`` (the watcher, 30 times a second) and redraw them:
        by ``t`` minus the time they stand for when :func:`follows_on` that step, else (the timeline dragged back
        or far ahead) built again from the displayed state. Copy 0 is put back on the displayed run whenever the
        copies' time is one of its samples (:meth:`Ensemble.anchor`: fixed-step RK4 and the display's adaptive
        integrator part as fast as the copies do in a chaotic motion). Runs under the player's lock, as the chain
        tab's frames did, so that the copies and the display are read together (its tests hold that lock)."""
        s = self.session
        with s.player.lock:
            with self._lock:
                ensemble, node, last = self.ensemble, self.ensemble_node, self._ensemble_t
                if not isinstance(ensemble, Ensemble) or node is None or last is None:
                    return
                dt = t - last
                follows = follows_on(dt)
                self._ensemble_t = t if follows else None
            if not follows:
                self._drop_ensemble()
                self._start_chain_ensemble()
                return
            if dt == 0.0:
                return
            ensemble.advance(dt)
            shown = s.state_at(t - ensemble.pending, exact=True)
            if shown is not None and len(shown[0]) == ensemble.theta.shape[1]:
                ensemble.anchor(*shown)
            node.points = segments(ensemble.joints())
            with self._lock:
                self._spread.append(t, ensemble.tip_spread())
                self._looks += 1
                spread = self._spread.arrays() if self._looks % SPREAD_EVERY == 0 else None
        if spread is not None:
            self.spread_plot.update(*spread)
        if not ensemble.alive.all():
            self.ensemble_status.content = markdown_literal(
                f"{int(ensemble.alive.sum())} of {ensemble.count} copies alive: {ensemble.message}")

    def _drop_ensemble(self) -> None:
        """Take the copies out of the scene and forget them (the box off, another run, the session's end)."""
        with self._lock:
            self._ensemble_generation += 1
            node, self.ensemble_node = self.ensemble_node, None
            self.ensemble, self._ensemble_q, self._ensemble_spec, self._ensemble_t = None, None, None, None
        if node is not None:
            quietly(node.remove, "removing the ensemble's copies")
        quietly(lambda: self.spread_plot.set_visible(False), "hiding the spread plot")

    def _untick(self) -> None:
        self._setting_box = True
        try:
            self.ensemble_box.value = False
        finally:
            self._setting_box = False

    # ------------------------------------------------------------------ the watcher
    def _watch(self) -> None:
        # the session's player ends with it (also when its construction failed after this section's)
        while not self.closed and not self.session.closed and self.session.player.alive:
            quietly(self._look, "moving the ensemble")
            time.sleep(WATCH_SECONDS if self.ensemble_node is not None else IDLE_WATCH_SECONDS)

    def _look(self) -> None:
        """Clear what was computed for another mechanism than the one shown; move the copies to the displayed
        time (the sample nearest it; held at the ends of their window; a chain's copies: :meth:`follow`)."""
        s = self.session
        self._sync_kind()
        cleared = []
        with self._lock:
            for name, mechanism in list(self._shown.items()):
                if mechanism is not s.mechanism:
                    cleared.append(name)
                    del self._shown[name]
            ensemble_stale = self._ensemble_spec is not None and self._ensemble_spec is not s.spec
        for name in cleared:
            self._clear(name)
        if ensemble_stale:  # Reset, another mechanism, an edit or a setting: the copies are another run's
            chain_copies = isinstance(self.ensemble, Ensemble)
            self._drop_ensemble()
            if chain_copies and self._for_chain():  # the chain tab's: built again from the new run's display
                self._start_chain_ensemble()
                return
            self._untick()
            self.ensemble_status.content = "The run changed: tick Ensemble again for copies of this one."
            return
        if isinstance(self.ensemble, Ensemble):  # a chain's copies follow the display (not a computed window)
            self.follow(s.player.display_time)
            return
        with self._lock:
            q, node = self._ensemble_q, self.ensemble_node
            if q is None or node is None:
                return
            index = int(np.clip(round((s.player.display_time - self._ensemble_t0) * ENSEMBLE_RATE), 0, len(q) - 1))
            if index == self._ensemble_index:
                return
            self._ensemble_index = index
            node.points = copy_segments(self._ensemble_spec.draw, q[index])

    def _clear(self, name: str) -> None:
        if name == "chart":
            self.chart_html.content = ""
            self.chart_status.content = "Error of the traced point against wall time, every method."
        elif name == "chaos":
            if self.image_handle is not None:
                self.image_handle.visible = False
            self.chaos_status.content = ""
        elif name == "equilibrium":
            self.rest_status.content = ""

    def remove(self) -> None:
        """Stop the watcher and every study's drawing (the session ends or leaves for a chain)."""
        self.closed = True
        self._drop_ensemble()
        self.spread_plot.remove()
        quietly(self.folder.remove, "removing the Analysis folder")


def copy_colors(count: int, n: int) -> np.ndarray:
    """One hue per copy, repeated for its n segments and both ends: shape (count * n, 2, 3), uint8."""
    hues = np.arange(count) / max(count, 1)
    rgb = np.array([colorsys.hsv_to_rgb(h, 0.75, 0.85) for h in hues]) * 255.0
    return np.repeat(rgb[:, None, :], n * 2, axis=1).reshape(count * n, 2, 3).astype(np.uint8)


def fit_width(svg: str) -> str:
    """An SVG drawn at the panel's width (its viewBox keeps the proportions): never wider than the panel. It is a
    figure drawn on white (``FIGURE_CLASS``: the page shows it in dark mode with its lightness turned round)."""
    return re.sub(r'^<svg ([^>]*?)width="[\d.]+" height="[\d.]+"',
                  rf'<svg class="{FIGURE_CLASS}" \1width="100%" style="height:auto"', svg,
                  count=1)
