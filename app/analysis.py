"""The "Analysis" tab of one session: a work-precision chart and a chaos map for the current parameters, and an
ensemble of perturbed copies drawn over the mechanism (issue 7).

Why background threads: both computations take seconds (and an ensemble's first use may compile its batched
code), so GUI callbacks only start a worker and return; results and errors reach the panel as the worker ends.
The ensemble is advanced by the session's frame callback (player thread) by the displayed time's increment.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

import numpy as np

import physics
from physics import LinkageError
from physics.chain_presets import get_preset
from physics.ensemble import Ensemble

from .buffers import ThinnedSeries
from .logs import quietly
from .mechanism_analysis import copy_colors, fit_width
from .overlays import Plot
from .ports import SessionPort
from .scene import to_world
from .text import markdown_literal

ENSEMBLE_COUNTS = ("100", "1000")
SPREAD_EVERY = 6  # frames between updates of the spread figure (10 Hz)
SPREAD_POINTS = 512  # points of the spread figure at most, over the ensemble's whole life (ThinnedSeries)
ENSEMBLE_SPREAD = 1e-9  # rad between the initial angles of neighbouring copies
ENSEMBLE_NODE = "/ensemble/links"
MAX_FRAME_DT = 4.0  # s of simulated time advanced per frame at most (a jump back or far ahead restarts instead);
# 4 s covers the fastest playback (8x) on a server that renders only 2 frames per second: a slow or loaded
# machine must not restart the ensemble on every frame (it would never fan out); the catch-up costs at most
# 960 RK4 steps of the batch on that frame
CHAOS_RESOLUTION = 64
CHAOS_T_MAX = 10.0  # s: a small map, a few seconds to compute
CHAOS_STEP = 0.01
CHAOS_DISPLAY_SCALE = 4  # each map pixel drawn as 4 x 4 screen pixels: with its axes and colour bar, 384 px wide


def segments(joints: np.ndarray) -> np.ndarray:
    """Joint positions (N, n + 1, 2) -> line segments (N * n, 2, 3) in the world (the mechanism's x-z plane)."""
    ends = np.stack([joints[:, :-1], joints[:, 1:]], axis=2)  # (N, n, 2, 2)
    return to_world(ends.reshape(-1, 2, 2)).astype(np.float32)


def follows_on(dt: float) -> bool:
    """Whether the ensemble follows a frame that moved the display by ``dt`` s of simulated time (advancing its
    copies by ``dt``), rather than starting again from the displayed state: it does for every step forward a
    playing server makes, however few frames it draws, and not for a jump back or far ahead (the timeline)."""
    return 0.0 <= dt <= MAX_FRAME_DT


def catch_up(ensemble: Ensemble, t: float, displayed_state: Callable[[], tuple | None],
             rounds: int = 8) -> float:
    """Advance copies built from the state at ``t`` to where the display is now; returns the display time they
    stand for. Why: a playing display moves on while the copies are built (in a worker: the first build
    compiles, a loaded machine is slow), and a frame that finds them more than ``MAX_FRAME_DT`` behind takes it
    for a jump and builds them again, which on a loaded machine never ended (CI saw the ensemble rebuilt
    through 6 s of play). Each round closes the gap the last one left; a display that went back is left to
    the next frame (a jump back restarts)."""
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


class Analysis:
    """The Analysis tab's widgets and jobs, and the ensemble drawn in the session's scene.

    It sees its session through :class:`~app.ports.SessionPort` (``port``), adds its tab to ``panel``'s tab
    group and draws the ensemble with ``scene_api`` (the session's ``target.scene``)."""

    def __init__(self, port: SessionPort, panel, scene_api) -> None:
        self.session = port
        self._panel = panel
        self._scene_api = scene_api
        self.chart_handle = None
        self.image_handle = None
        self.ensemble: Ensemble | None = None  # once built
        self.ensemble_node = None
        self.ensemble_on = False
        self.ensemble_count = int(ENSEMBLE_COUNTS[0])
        self._ensemble_t: float | None = None
        self._ensemble_generation = 0
        self._spread = ThinnedSeries(SPREAD_POINTS)  # the spread over the ensemble's life (its figure)
        self._frames_advanced = 0
        self._lock = threading.Lock()
        self._jobs: dict[str, threading.Thread] = {}
        self._build()

    # ------------------------------------------------------------------ widgets
    def _build(self) -> None:
        s = self.session
        controls = self._panel
        gui = controls.gui
        self.tab = controls.tabs.add_tab("Analysis")
        with self.tab:
            self.chart_button = gui.add_button("Work-precision chart (current parameters)")
            controls.bind(self.chart_button, lambda value, event: s.work_precision_chart())
            self.chart_status = gui.add_markdown("Error against wall time for a few integrators and tolerances "
                                                 "(a few seconds).")
            self.chaos_button = gui.add_button(f"Chaos map (double pendulum, {CHAOS_RESOLUTION} x {CHAOS_RESOLUTION})")
            controls.bind(self.chaos_button, lambda value, event: s.chaos_map())
            self.chaos_status = gui.add_markdown(f"Initial-angle plane (theta1 across, theta2 up) coloured by the "
                                                 f"time until a link first flips (log scale, up to {CHAOS_T_MAX:g} s).")
            self.ensemble_box = gui.add_checkbox("Ensemble", initial_value=False,
                                                 hint="Copies of the mechanism whose initial angles differ by 1e-9 rad")
            controls.bind(self.ensemble_box, lambda value, event: s.set_ensemble(value))
            self.count_dropdown = gui.add_dropdown("Ensemble copies", ENSEMBLE_COUNTS,
                                                   initial_value=str(self.ensemble_count))
            controls.bind(self.count_dropdown, lambda value, event: s.set_ensemble(self.ensemble_on, value))
            self.ensemble_status = gui.add_markdown("")
            self.spread_plot = Plot(gui, "Ensemble spread: largest tip distance from copy 0", ["spread"],
                                    [(148, 103, 189)], log=True, height=140, y_label="m")
            self.spread_plot.set_visible(False)

    def _start(self, name: str, work) -> bool:
        job = self._jobs.get(name)
        if job is not None and job.is_alive():
            return False
        job = threading.Thread(target=work, name=f"analysis-{name}-{self.session.id}", daemon=True)
        self._jobs[name] = job
        job.start()
        return True

    def wait(self, name: str, timeout: float = 120.0) -> None:
        """Wait for a job (tests)."""
        job = self._jobs.get(name)
        if job is not None:
            job.join(timeout)

    # ------------------------------------------------------------------ work-precision chart
    def work_precision_chart(self) -> None:
        from physics.studies import work_precision as bench  # noqa: PLC0415 - the studies import scipy: on demand
        p = self.session.setup
        chain = p.chain
        theta0, omega0, trace = p.theta0.copy(), p.omega0.copy(), p.trace
        formulations = (p.method,) if p.method in physics.FORMULATION_NAMES else ("lagrange",)

        def work() -> None:
            try:
                _, svg = bench.work_precision_chain(chain, theta0, omega0, trace=trace, formulations=formulations,
                                                    narrow=True)
            except Exception as error:
                self.chart_status.content = "Work-precision chart failed."
                self.session.show_notice("Work-precision chart failed", f"{type(error).__name__}: {error}",
                                         color="red")
                return
            html = f'<div style="width:100%">{fit_width(svg)}</div>'
            if self.chart_handle is None:
                with self.tab:
                    self.chart_handle = self._panel.gui.add_html(html, order=self.chart_status.order + 0.1)
            else:
                self.chart_handle.content = html
            self.chart_status.content = f"Work-precision chart: {p.n} bars, {formulations[0]}, horizon 5 s."

        if self._start("chart", work):
            self.chart_status.content = "**Computing** the work-precision chart..."
            self.session.show_notice("Computing", "work-precision chart for the current parameters (a few seconds)",
                                     color="blue")

    # ------------------------------------------------------------------ chaos map
    def chaos_map(self) -> None:
        from physics.studies import chaos_map as chaos  # noqa: PLC0415 - a study: imported on demand
        chain = get_preset("double").chain

        def work() -> None:
            try:
                times = chaos.compute_map(chain, "lagrange", CHAOS_RESOLUTION, CHAOS_T_MAX, CHAOS_STEP)
                rgb = chaos.to_rgb(times, CHAOS_T_MAX, CHAOS_STEP)
                rgb = np.repeat(np.repeat(rgb, CHAOS_DISPLAY_SCALE, axis=0), CHAOS_DISPLAY_SCALE, axis=1)
                rgb = chaos.framed_picture(rgb, CHAOS_T_MAX, CHAOS_STEP)  # axes, ticks, colour bar, key
            except Exception as error:
                self.chaos_status.content = "Chaos map failed."
                self.session.show_notice("Chaos map failed", f"{type(error).__name__}: {error}", color="red")
                return
            if self.image_handle is None:
                with self.tab:
                    self.image_handle = self._panel.gui.add_image(
                        rgb, label="Chaos map (double pendulum)", format="png", order=self.chaos_status.order + 0.1)
            else:
                self.image_handle.image = rgb
            self.chaos_status.content = (f"Chaos map: {CHAOS_RESOLUTION} x {CHAOS_RESOLUTION}, "
                                         f"theta1, theta2 in [-pi, pi], flip time up to {CHAOS_T_MAX:g} s.")

        if self._start("chaos", work):
            self.chaos_status.content = "**Computing** the chaos map..."
            self.session.show_notice("Computing", "chaos map of the double pendulum (a few seconds)", color="blue")

    # ------------------------------------------------------------------ ensemble
    def set_ensemble(self, on: bool, count: int | None = None) -> None:
        if count is not None:
            text = str(count).strip() if isinstance(count, (str, int)) and not isinstance(count, bool) else None
            if text not in ENSEMBLE_COUNTS:
                raise LinkageError(f"ensemble count = {count!r}: allowed {', '.join(ENSEMBLE_COUNTS)}")
            self.ensemble_count = int(text)
        self.ensemble_on = bool(on)
        if not self.ensemble_on:
            self._drop_ensemble()
            self.ensemble_status.content = ""
            return
        self.restart_ensemble()

    def restart_ensemble(self) -> None:
        """Build a new ensemble from the displayed state (in a worker: the first build may compile)."""
        s = self.session
        p = s.setup
        state = s.displayed_state()
        if state is None or len(state[1]) != p.n:
            t, theta, omega = 0.0, p.theta0.copy(), p.omega0.copy()
        else:
            t, theta, omega = state
        chain = p.chain
        method = p.method if p.method in physics.FORMULATION_NAMES else "lagrange"
        count, damping = self.ensemble_count, p.damping
        with self._lock:
            self._ensemble_generation += 1
            generation = self._ensemble_generation
        self.ensemble_status.content = f"**Preparing** {count} copies..."

        def work() -> None:
            try:
                ensemble = Ensemble(chain, theta, omega, method, count, ENSEMBLE_SPREAD, damping=damping)
                ensemble.prepare()  # its first compilation here, not in a frame (catch_up may take no step)
                t_copies = catch_up(ensemble, t, s.displayed_state)
                points = segments(ensemble.joints())
            except Exception as error:
                self.ensemble_status.content = f"Ensemble failed: {markdown_literal(f'{type(error).__name__}: {error}')}"
                self.session.show_notice("Ensemble failed", f"{type(error).__name__}: {error}", color="red")
                return
            with self._lock:
                if generation != self._ensemble_generation or not self.ensemble_on or self.session.closed:
                    return
                self._remove_node()
                self.ensemble_node = self._scene_api.add_line_segments(
                    ENSEMBLE_NODE, points, copy_colors(count, chain.n), thickness=0.004 * max(1.0, sum(p.L)))
                self.ensemble = ensemble
                self._ensemble_t = t_copies
                self._spread.clear()
                self._spread.append(t_copies, ensemble.tip_spread())
                self.spread_plot.set_visible(True)
            self.ensemble_status.content = f"{count} copies, {method}, RK4 step {ensemble.step * 1e3:.3g} ms."

        threading.Thread(target=work, name=f"ensemble-{s.id}", daemon=True).start()

    def on_frame(self, t: float, restarted: bool) -> None:
        """Advance and redraw the ensemble to the displayed time ``t`` (player thread); an error switches the
        ensemble off with a notice, the session goes on."""
        if not self.ensemble_on:
            return
        try:
            self._advance(t, restarted)
        except Exception as error:
            self.ensemble_on = False
            self._drop_ensemble()
            self.ensemble_status.content = f"Ensemble stopped: {markdown_literal(f'{type(error).__name__}: {error}')}"
            self.session.show_notice("Ensemble stopped", f"{type(error).__name__}: {error}", color="red")

    def _advance(self, t: float, restarted: bool) -> None:
        if restarted:
            self.restart_ensemble()
            return
        with self._lock:
            ensemble, node, last = self.ensemble, self.ensemble_node, self._ensemble_t
            if ensemble is None or node is None or last is None:
                return
            dt = t - last
            follows = follows_on(dt)
            self._ensemble_t = t if follows else None
        if not follows:  # a jump back or far ahead: go on from the displayed state
            self.restart_ensemble()
            return
        if dt == 0.0:
            return
        ensemble.advance(dt)
        # where the displayed run is at the copies' time, when that is one of its samples (every 4th RK4 step)
        shown = self.session.state_at(t - ensemble.pending, exact=True)
        if shown is not None and len(shown[0]) == ensemble.theta.shape[1]:
            ensemble.anchor(*shown)  # copy 0 stays on the displayed pendulum (Ensemble.anchor)
        node.points = segments(ensemble.joints())
        with self._lock:  # a restart (another thread) clears the series
            self._spread.append(t, ensemble.tip_spread())
            self._frames_advanced += 1
            spread = self._spread.arrays() if self._frames_advanced % SPREAD_EVERY == 0 else None
        if spread is not None:
            self.spread_plot.update(*spread)
        if not ensemble.alive.all():
            self.ensemble_status.content = f"{int(ensemble.alive.sum())} of {ensemble.count} copies alive: " \
                                           f"{ensemble.message}"

    def _remove_node(self) -> None:
        if self.ensemble_node is not None:
            quietly(self.ensemble_node.remove, "removing the ensemble")
        self.ensemble_node = None

    def _drop_ensemble(self) -> None:
        quietly(lambda: self.spread_plot.set_visible(False), "hiding the spread plot")
        with self._lock:
            self._ensemble_generation += 1
            self._remove_node()
            self.ensemble = None
            self._ensemble_t = None

    def remove(self) -> None:
        self.ensemble_on = False
        self._drop_ensemble()
