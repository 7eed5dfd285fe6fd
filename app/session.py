"""One browser's (or, with ``--shared``, one lecture's) simulation: parameters, player, scene, overlays.

A :class:`Session` is built on a target, a ``viser.ClientHandle`` (its own GUI and scene) or the
``viser.ViserServer`` itself (shared by every browser). GUI callbacks call exactly one public method of
the session, through :meth:`Session.guard`, which turns any exception into a notice in that browser (and
pauses the session when the error is not a plain invalid value), so one session's trouble never reaches
the server or the other sessions. Tests call the same methods.

Changing a physical parameter continues the motion from the displayed state with the new parameters;
changing the start (initial angles, mechanism, reset, compare mode) starts again at t = 0.
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
from physics import LinkageError, TracePoint, assembly

from . import delivery, export, warm
from .analysis import Analysis
from .controls import Controls
from .overlays import (
    METHOD_COLORS,
    ReactionArrows,
    TraceLine,
    energy_scale,
    relative_drift,
    status_markdown,
)
from .parameters import METHOD_LABELS, SessionParameters, driving_count, methods_for
from .player import SAMPLE_RATE, Frame, Player, RunSpec
from .scene import LinkageScene, camera_pose, mechanism_reach

TRACE_EVERY = 2  # frames between trace updates (30 Hz)
PLOT_EVERY = 12  # frames between plot updates (5 Hz)
STATUS_EVERY = 15  # frames between status-line updates (4 Hz)
PLOT_SECONDS = 30.0  # simulated seconds shown by the plots
MAX_TRACE_SECONDS = 30.0
COMPARE_METHODS = tuple(physics.FORMULATION_NAMES)
NOTICE_SECONDS = 8.0
# Show the "deriving equations" notice only when loading takes longer than this: a warm cache loads in well
# under a second; a new mechanism derives and compiles in a few seconds (the very first run of an installation
# also compiles the integrators, about half a minute).
PREPARE_NOTICE_DELAY = 1.0

# Between a browser closing and its session being closed, a frame or two may still be queued to the departed
# connection; viser warns about each. The session stops right after, so these writes are expected.
warnings.filterwarnings("ignore", message=r"Queued a \w+ on a closed connection")

_ids = itertools.count(1)


def _settings_for_chunk(settings, horizon: float, samples: int):
    return settings.model_copy(update={"t_end": horizon, "samples": samples})


class Session:
    """State and behaviour of one simulation shown in one browser (or in all, when shared)."""

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
        self.params = SessionParameters.from_preset(preset, links=links, method=method)
        self.compare = False
        self.trace_seconds = 4.0
        self.reactions_on = False
        self.reaction_scale = 0.5
        self.notice: str | None = None
        self._notifications: list = []
        self._segment_t0 = 0.0
        self._energy_ref = 0.0
        self._user_paused = not autoplay
        self._framed_reach: float | None = None
        self._frame_lock = threading.Lock()
        self.last_frame: Frame | None = None
        self.frames_sent = 0
        self._start_params: SessionParameters | None = None  # parameters of the latest start (t = 0)
        self._last_good_params: SessionParameters | None = None  # of the latest start that could move

        scene_api = target.scene
        self.floor = scene_api.add_grid(
            "/floor", width=20.0, height=20.0, plane="xy", cell_size=0.25, section_size=1.0,
            position=(0.0, 0.0, -1.0),
        )
        self.scene = LinkageScene(target, "/linkage")
        self.trace = TraceLine(scene_api, "/linkage/trace")
        self.arrows = ReactionArrows(scene_api, "/linkage/reactions")
        self.compare_scenes: dict[str, LinkageScene] = {}
        self.compare_traces: dict[str, TraceLine] = {}

        self.controls = Controls(self)
        self.analysis = Analysis(self)
        self._canvas_watched: set[int] = set()
        self._framed_aspect: dict[int, float] = {}
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
            self._build_scene()
            self._show_start_pose()
            self.frame_camera(force=True)
            self._restart_fresh(play=autoplay)
        except BaseException:
            self.player.stop()  # no thread left behind by a session that could not start
            raise

    # ================================================================== error boundary
    def guard(self, action: Callable[[], object]) -> object:
        """Run one GUI action; show any error as a notice in this browser instead of raising.

        An invalid value (LinkageError) leaves the session as it was; anything else pauses it and offers
        Reset. Returns the action's result, or None after an error.
        """
        try:
            return action()
        except LinkageError as error:
            self.show_notice("Not applied", str(error), color="yellow")
            self._resync_controls()
        except Exception as error:  # the boundary: nothing escapes into viser's callback thread
            traceback.print_exc()
            try:
                self.player.pause()
            except Exception:
                pass
            self.show_notice(
                "Session paused",
                f"{type(error).__name__}: {error}. Press Reset to start again.",
                color="red",
            )
        return None

    def _resync_controls(self) -> None:
        """Put the controls back on the values in force (a refused value must not stay on its widget)."""
        try:
            self.controls.sync_all()
            self.controls.sync_compare()
        except Exception:  # a half-built panel: the next successful change syncs it
            pass

    # ================================================================== notices
    def _clients(self) -> list:
        if self.shared:
            return list(self.target.get_clients().values())
        return [self.target]

    def show_notice(self, title: str, body: str, color: str = "yellow", seconds: float | None = NOTICE_SECONDS) -> None:
        """A notification in this session's browser(s), and the same text on the status line."""
        self.notice = f"{title}: {body}"
        if self.closed or not self._connection_open():
            return
        for old in self._notifications:
            try:
                old.remove()
            except Exception:
                pass
        self._notifications = []
        for client in self._clients():
            try:
                self._notifications.append(
                    client.add_notification(title, body, color=color, auto_close_seconds=seconds)
                )
            except Exception:
                pass
        self.controls.show_status(self._status_text())

    def clear_notice(self) -> None:
        self.notice = None

    # ================================================================== scene and camera
    def _build_scene(self) -> None:
        p = self.params
        with self.player.lock:
            if self.compare:
                self.scene.set_visible(False)
                self.trace.update(np.zeros((0, 2)))
                for method in COMPARE_METHODS:
                    if method not in self.compare_scenes:
                        color = METHOD_COLORS[method]
                        self.compare_scenes[method] = LinkageScene(
                            self.target, f"/compare/{method}", opacity=0.45, palette=[color]
                        )
                        self.compare_traces[method] = TraceLine(
                            self.target.scene, f"/compare/{method}/trace", color=color
                        )
                    self.compare_scenes[method].build(np.array(p.L), p.pin)
            else:
                for method in list(self.compare_scenes):
                    self.compare_scenes.pop(method).remove()
                    self.compare_traces.pop(method).remove()
                self.scene.build(np.array(p.L), p.pin)
                self.scene.set_visible(True)
            reach = mechanism_reach(np.array(p.L), p.pin)
            self.floor.position = (0.0, 0.0, -1.08 * reach)
            width = 0.012 * reach
            self.trace.set_thickness(width)
            for trace in self.compare_traces.values():
                trace.set_thickness(width)
            if not self.reactions_available():
                self.arrows.hide()

    def _show_start_pose(self) -> None:
        """Put the new nodes at the start pose before the first frame (a cold start derives for a while)."""
        p = self.params
        L = np.array(p.L, dtype=float)
        joints = physics.joint_positions(L, p.theta0)
        ratio = np.divide(np.array(p.d), L, out=np.zeros_like(L), where=L > 0)
        com = joints[:-1] + ratio[:, None] * (joints[1:] - joints[:-1])
        with self.player.lock, self.target.atomic():
            for scene in [self.scene, *self.compare_scenes.values()]:
                if scene.layout is not None:
                    scene.show(joints, com)

    def frame_camera(self, force: bool = False, client=None) -> None:
        """Point the camera(s) at the mechanism; only when its size changed noticeably unless ``force``.
        ``client``: only that browser's camera (a browser joining a shared session)."""
        p = self.params
        reach = mechanism_reach(np.array(p.L), p.pin)
        unchanged = self._framed_reach is not None and abs(reach / self._framed_reach - 1.0) < 0.15
        if client is None and not force and unchanged:
            return
        position, look_at = camera_pose(np.array(p.L), p.pin)
        cameras = []
        if client is not None:
            cameras = [client.camera]
        elif self.shared:
            self._framed_reach = reach
            try:
                self.target.initial_camera.position = tuple(position)
                self.target.initial_camera.look_at = tuple(look_at)
                self.target.initial_camera.up = (0.0, 0.0, 1.0)
            except Exception:
                pass
            cameras = [c.camera for c in self.target.get_clients().values()]
        else:
            self._framed_reach = reach
            cameras = [self.target.camera]
        for camera in cameras:
            self._watch_canvas(camera)
            try:
                aspect = float(camera.aspect)
            except Exception:  # the browser has not reported its canvas yet: framed when it does
                continue
            self._frame_one(camera, aspect)

    def _frame_one(self, camera, aspect: float) -> None:
        p = self.params
        self._framed_aspect[id(camera)] = aspect
        try:
            position, look_at = camera_pose(np.array(p.L), p.pin, aspect=aspect)
            with self.target.atomic():
                camera.up_direction = (0.0, 0.0, 1.0)
                camera.position = tuple(position)
                camera.look_at = tuple(look_at)
        except Exception:  # the browser went away meanwhile
            pass

    def _watch_canvas(self, camera) -> None:
        """Frame a browser's camera again when its canvas is first reported or changes shape by more than 5 %
        (the layout settling beside the control panel, a window resized): a canvas narrower than it is tall
        must still show the whole mechanism. Orbiting alone (same canvas) never re-frames."""
        key = id(camera)
        if key in self._canvas_watched:
            return
        self._canvas_watched.add(key)

        def on_camera(reported) -> None:
            if self.closed:
                return
            try:
                aspect = float(reported.aspect)
            except Exception:
                return
            framed = self._framed_aspect.get(key)
            if framed is None or abs(aspect / framed - 1.0) > 0.05:
                self._frame_one(reported, aspect)

        camera.on_update(on_camera)

    # ================================================================== runs
    @staticmethod
    def _check_compare(params: SessionParameters) -> None:
        """Compare mode runs every formulation with the same settings: all of them must accept those settings
        (the variational integrator, for one, exists for Lagrange only). LinkageError names the one that does not."""
        for method in COMPARE_METHODS:
            try:
                params.settings(method=method)
            except LinkageError as error:
                raise LinkageError(f"compare mode: {error}") from None

    def _specs(self) -> list[RunSpec]:
        p = self.params
        chain = p.chain()
        if self.compare:
            return [RunSpec(method, chain, p.settings(method=method)) for method in COMPARE_METHODS]
        return [RunSpec("main", chain, p.settings())]

    def _restart_fresh(self, play: bool | None = None) -> None:
        """Start again at t = 0 from the initial state (reset, new start, new mechanism, compare mode)."""
        p = self.params
        specs = self._specs()
        starts = [(p.theta0.copy(), p.omega0.copy()) for _ in specs]
        self._start_params = p
        self._segment_t0 = 0.0
        self.clear_notice()
        if play is None:
            play = not self._user_paused
        self.player.restart(specs, 0.0, starts, keep_history=False, play=play)

    def _commit(self, new: SessionParameters, keep_state: bool) -> None:
        """Adopt ``new`` parameters and restart the runs.

        ``keep_state``: go on from the displayed state (a physical parameter changed); a closed loop's state
        is first put back exactly on its loop, and if it cannot close with the new values, LinkageError is
        raised before anything is changed. Otherwise start again at t = 0.
        """
        state = self.player.current_state() if keep_state and not self.compare else None
        if state is not None and len(state[1]) != new.n:
            state = None  # the displayed run is of another mechanism: start afresh
        if state is not None and new.pinned:
            t, theta, omega = state
            theta, omega = self._close_loop(new, theta, omega)
            state = (t, theta, omega)
        self.params = new
        if state is None:
            self._restart_fresh()
            return
        t, theta, omega = state
        self._segment_t0 = t
        self.clear_notice()
        self.player.restart(self._specs(), t, [(theta, omega)], keep_history=True)

    @staticmethod
    def _close_loop(p: SessionParameters, theta: np.ndarray, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Put a pinned chain's state exactly on its loop (drift, or a change of lengths or pin)."""
        k = driving_count(p.n, True)
        try:
            theta = p.assembled(theta[:k], theta_prev=theta)
        except LinkageError as error:
            raise LinkageError(f"the moving linkage cannot close with these values: {error}") from None
        try:
            omega = assembly.project_velocity(p.L, theta, omega)
        except LinkageError:
            omega = np.zeros_like(omega)
        return theta, omega

    def _prepare(self, spec: RunSpec, theta0: np.ndarray, omega0: np.ndarray) -> None:
        """Have the run's code loaded and its integrator compiled before its first chunk (app/warm.py), with a
        notice in the page when this takes a while (a cold cache: deriving and compiling)."""
        if warm.is_ready(spec.chain, spec.settings):
            return
        method = spec.settings.method
        notice: list = []

        def show() -> None:
            label = METHOD_LABELS.get(method, method)
            closure = "closed loop" if spec.pinned else "open chain"
            for client in self._clients():
                try:
                    notice.append(
                        client.add_notification(
                            "Deriving equations...",
                            f"{label}, {spec.n} bars, {closure}: preparing the equations of motion. The first "
                            "time, sympy derives them and LLVM compiles them (a few seconds; the first run of an "
                            "installation also compiles the integrators, about half a minute); afterwards "
                            "they load from the cache.",
                            loading=True,
                            with_close_button=False,
                        )
                    )
                except Exception:
                    pass
            self.controls.show_status(f"**Deriving equations...** ({label}, {spec.n} bars, {closure})")

        timer = threading.Timer(PREPARE_NOTICE_DELAY, show)
        timer.daemon = True
        timer.start()
        try:
            warm.ensure_ready(spec.chain, spec.settings, theta0, omega0, cancelled=self.player.superseded)
        finally:
            timer.cancel()
            for handle in notice:
                try:
                    handle.remove()
                except Exception:
                    pass

    # ================================================================== the frame callback (player thread)
    def _connection_open(self) -> bool:
        """False once this session's browser has gone (viser closes its buffer before telling the server)."""
        if self.shared:
            return True
        try:
            return not self.target._websock_connection.get_message_buffer().done
        except AttributeError:  # a viser without this internal: rely on close() alone
            return True

    def _on_frame(self, frame: Frame) -> None:
        if self.closed or not self._connection_open():
            return
        runs = {run.spec.label: run for run in self.player.runs}
        with self.target.atomic():
            for rf in frame.runs:
                scene = self.scene if rf.label == "main" else self.compare_scenes.get(rf.label)
                if scene is None or scene.layout is None or scene.layout.n + 1 != len(rf.joints):
                    continue
                scene.show(rf.joints, rf.com)
            if frame.restarted or frame.counter % TRACE_EVERY == 0:
                self._update_traces(frame, runs)
            if self.reactions_on and not self.compare:
                self._update_arrows(frame, runs)
        if frame.restarted:
            self._energy_ref = self._energy_at(runs, frame, self._segment_t0)
            try:
                self.target.flush()
            except Exception:
                pass
        self.analysis.on_frame(frame.t, frame.restarted)
        if frame.restarted or frame.counter % PLOT_EVERY == 0:
            self._update_plots(frame, runs)
        if frame.restarted or frame.counter % STATUS_EVERY == 0:
            self.controls.show_status(self._status_text(frame, runs))
        if self._start_params is not self._last_good_params and any(len(run.ring) > 1 for run in runs.values()):
            self._last_good_params = self._start_params
        with self._frame_lock:
            self.last_frame = frame
            self.frames_sent += 1

    def _trace_window(self, ring, index: int) -> np.ndarray:
        count = int(round(self.trace_seconds * SAMPLE_RATE))
        if count < 2:
            return np.zeros((0, 2))
        return ring.window(index - count, index, names=["trace_xy"])["trace_xy"]

    def _update_traces(self, frame: Frame, runs) -> None:
        for rf in frame.runs:
            run = runs.get(rf.label)
            if run is None:
                continue
            trace = self.trace if rf.label == "main" else self.compare_traces.get(rf.label)
            if trace is not None:
                trace.update(self._trace_window(run.ring, rf.index))

    def reactions_available(self) -> bool:
        return self.params.method == "dae" or self.params.pinned

    def _update_arrows(self, frame: Frame, runs) -> None:
        run = runs.get("main")
        if run is None or not frame.runs or frame.runs[0].label != "main":
            self.arrows.hide()
            return
        spec = run.spec  # the run's own description: the session's parameters may already be newer
        if not (spec.settings.method == "dae" or spec.pinned):
            self.arrows.hide()
            return
        rf = frame.runs[0]
        ring = run.ring
        points, forces = [], []
        if spec.settings.method == "dae":
            points.append(rf.joints[:-1])
            forces.append(ring.get("reactions", rf.index))
        if spec.pinned:
            points.append(rf.joints[-1:])
            forces.append(ring.get("tip_reaction", rf.index)[None, :])
        points_xy = np.concatenate(points)
        forces_xy = np.concatenate(forces)
        chain = spec.chain
        weight = max(float(np.sum(chain.array("m"))) * chain.g, 1e-9)
        reach = mechanism_reach(chain.array("L"), chain.pin)
        # scale 1 draws the total weight as an arrow as long as the mechanism's reach
        scale = self.reaction_scale * reach / weight
        self.arrows.update(points_xy, forces_xy, scale, radius=0.008 * reach)

    def _energy_at(self, runs, frame: Frame, t: float) -> float:
        run = runs.get(frame.runs[0].label) if frame.runs else None
        if run is None or len(run.ring) == 0:
            return 0.0
        return float(run.ring.get("energy", run.ring.index_at(t)))

    def _update_plots(self, frame: Frame, runs) -> None:
        if not frame.runs:
            return
        first = runs.get(frame.runs[0].label)
        if first is None:
            return
        i = frame.runs[0].index
        span = int(PLOT_SECONDS * SAMPLE_RATE)
        chain = first.spec.chain  # the run's own chain: the session's parameters may already be newer
        data = first.ring.window(i - span, i, names=["t", "kinetic", "potential", "energy"] + (
            ["constraint_xy"] if chain.pinned else []))
        t = data["t"]
        c = self.controls
        c.energy_plot.update(t, data["energy"], data["kinetic"], data["potential"])
        scale = energy_scale(chain.array("m"), chain.array("L"), chain.g)
        in_segment = t >= self._segment_t0 - 1e-9
        c.drift_plot.update(t[in_segment], relative_drift(data["energy"][in_segment], self._energy_ref, scale))
        if chain.pinned:
            c.constraint_plot.update(t, np.hypot(data["constraint_xy"][:, 0], data["constraint_xy"][:, 1]))
        if self.compare and len(frame.runs) == len(COMPARE_METHODS):
            reference = runs.get(COMPARE_METHODS[0])
            others = [runs.get(m) for m in COMPARE_METHODS[1:]]
            if reference is None or any(o is None for o in others):
                return
            j = min(rf.index for rf in frame.runs)
            ref = reference.ring.window(j - span, j, names=["t", "joints"])
            diffs = []
            for other in others:
                o = other.ring.window(j - span, j, names=["joints"])["joints"]
                m = min(len(o), len(ref["joints"]))
                diffs.append(np.linalg.norm(ref["joints"][-m:, -1] - o[-m:, -1], axis=1))
            m = min(len(d) for d in diffs)
            c.divergence_plot.update(ref["t"][-m:], *[d[-m:] for d in diffs])

    def _current_values(self, frame: Frame | None = None, runs=None) -> dict:
        """Energy error and constraint error at the displayed sample of the first run."""
        frame = frame or self.last_frame
        if frame is None or not frame.runs:
            return {}
        runs = runs or {run.spec.label: run for run in self.player.runs}
        run = runs.get(frame.runs[0].label)
        if run is None or len(run.ring) == 0:
            return {}
        i = min(frame.runs[0].index, len(run.ring) - 1)
        chain = run.spec.chain
        energy = float(run.ring.get("energy", i))
        scale = energy_scale(chain.array("m"), chain.array("L"), chain.g)
        out = {
            "kinetic": float(run.ring.get("kinetic", i)),
            "potential": float(run.ring.get("potential", i)),
            "total": energy,
            "reference": self._energy_ref,
            "relative_drift": float(relative_drift(np.array([energy]), self._energy_ref, scale)[0]),
        }
        if chain.pinned and "constraint_xy" in run.ring.field_names():
            cxy = run.ring.get("constraint_xy", i)
            out["constraint_error"] = float(math.hypot(cxy[0], cxy[1]))
        return out

    def _status_text(self, frame: Frame | None = None, runs=None) -> str:
        values = self._current_values(frame, runs)
        t = frame.t if frame is not None else (self.last_frame.t if self.last_frame else 0.0)
        if self.compare:
            label = "compare: " + ", ".join(METHOD_LABELS[m] for m in COMPARE_METHODS)
        else:
            label = f"{METHOD_LABELS.get(self.params.method, self.params.method)} · {self.params.integrator}"
        return status_markdown(
            t,
            self.player.playing,
            self.player.real_time_factor(),
            label,
            values.get("relative_drift"),
            values.get("constraint_error"),
            self.notice,
        )

    def _on_failure(self, message: str) -> None:
        stuck = all(len(run.ring) <= 1 for run in self.player.runs)
        hint = ("This start cannot move. Press Reset to go back to the last start that ran."
                if stuck else "Press Reset to start again.")
        self.show_notice("Simulation stopped", f"{message}. {hint}", color="red", seconds=None)

    # ================================================================== public actions (GUI callbacks)
    def play(self) -> None:
        self._user_paused = False
        if self.last_frame is not None and any(run.failed for run in self.player.runs):
            t_last = min(run.ring.t_last for run in self.player.runs)
            if self.player.display_time >= t_last - 1e-9:
                raise LinkageError("the simulation stopped here; press Reset (or change a parameter) to go on")
        self.player.play()

    def work_precision_chart(self) -> None:
        """Compute the work-precision chart for the current parameters in a worker; shown in the Analysis tab."""
        self.analysis.work_precision_chart()

    def chaos_map(self) -> None:
        """Compute a small chaos map of the double pendulum in a worker; shown in the Analysis tab."""
        self.analysis.chaos_map()

    def set_ensemble(self, on: bool, count: int | None = None) -> None:
        """Draw (or stop drawing) ``count`` copies whose initial angles differ by 1e-9 rad."""
        self.analysis.set_ensemble(on, count)

    def pause(self) -> None:
        self._user_paused = True
        self.player.pause()

    def step(self) -> None:
        self._user_paused = True
        self.player.step()

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
                if layout:
                    self._build_scene()
                    self.controls.rebuild()
                else:
                    with self.player.lock:
                        self.scene.resize(np.array(good.L), good.pin)
                self.controls.sync_all()
                self.frame_camera()
            self._restart_fresh()

    def goto_time(self, t: float, timeout: float = 120.0) -> bool:
        """Pause at simulated time ``t`` from the start (for pictures and tests); True when shown."""
        if not (math.isfinite(t) and 0.0 <= t <= 1e5):
            raise LinkageError(f"time = {t}: allowed range 0 <= time <= 1e5")
        with self._lock:
            self._user_paused = True
            self._restart_fresh(play=False)
        self.player.wait_idle(timeout)
        return self.player.seek(t, timeout)

    def set_speed(self, speed: float) -> None:
        if not (math.isfinite(speed) and 0.01 <= speed <= 8.0):
            raise LinkageError(f"speed = {speed}: allowed range 0.01 <= speed <= 8")
        self.player.set_speed(speed)

    def set_trace_seconds(self, seconds: float) -> None:
        if not (math.isfinite(seconds) and 0.0 <= seconds <= MAX_TRACE_SECONDS):
            raise LinkageError(f"trace length = {seconds}: allowed range 0 <= trace length <= {MAX_TRACE_SECONDS:g} s")
        self.trace_seconds = float(seconds)
        self.player.touch()

    def set_trace_point(self, label: str) -> None:
        choices = self.params.trace_choices()
        if label not in choices:
            raise LinkageError(f"traced point = {label!r}: allowed {', '.join(choices)}")
        with self._lock:
            self.params = self.params.changed(trace=choices[label])
            self._restart_fresh()

    def set_reactions(self, on: bool, scale: float | None = None) -> None:
        if scale is not None:
            if not (math.isfinite(scale) and 0.0 < scale <= 10.0):
                raise LinkageError(f"arrow scale = {scale}: allowed range 0 < scale <= 10")
            self.reaction_scale = float(scale)
        self.reactions_on = bool(on)
        if not on:
            with self.player.lock:
                self.arrows.hide()
        self.player.touch()

    # ---------------------------------------------------------------- mechanism
    def set_mechanism(self, name: str, links: int | None = None) -> None:
        """Load a preset (``links`` for ``chain``), keeping the integration choices where they apply."""
        if name not in physics.preset_names():
            raise LinkageError(f"mechanism = {name!r}: allowed {', '.join(physics.preset_names())}")
        with self._lock:
            old = self.params
            new = SessionParameters.from_preset(name, links=links if name == "chain" else None)
            keep = {
                "integrator": old.integrator,
                "tolerance": old.tolerance,
                "step": old.step,
                "stabilization": old.stabilization,
                "baumgarte_alpha": old.baumgarte_alpha,
                "baumgarte_beta": old.baumgarte_beta,
                "damping": old.damping,
            }
            if old.method in methods_for(new.chain()):
                keep["method"] = old.method
            self.params = new.changed(**keep)
            self._layout_changed()

    def set_links(self, links: int) -> None:
        if not (1 <= int(links) <= physics.model.MAX_LINKS):
            raise LinkageError(f"links = {links}: allowed range 1 <= links <= {physics.model.MAX_LINKS}")
        if self.params.preset != "chain":
            raise LinkageError("links: only the 'chain' mechanism has a variable number of bars")
        self.set_mechanism("chain", links=int(links))

    def _layout_changed(self) -> None:
        self._build_scene()
        self._show_start_pose()
        self.controls.rebuild()
        self.frame_camera(force=True)
        self._restart_fresh()

    def set_bar(self, k: int, field: str, value: float) -> None:
        """Set ``field`` (L, d, m or I) of bar ``k`` (1-based); the motion goes on from the displayed state."""
        p = self.params
        if field not in ("L", "d", "m", "I"):
            raise LinkageError(f"field = {field!r}: allowed L, d, m, I")
        if not 1 <= k <= p.n:
            raise LinkageError(f"bar = {k}: allowed range 1 <= bar <= {p.n}")
        value = float(value)
        with self._lock:
            values = list(getattr(p, field))
            old_value = values[k - 1]
            values[k - 1] = value
            updates: dict = {field: values}
            trace = p.trace
            if field == "L":
                d = list(p.d)
                d[k - 1] = min(d[k - 1], value)  # the centre of mass stays on the bar
                updates["d"] = d
                if p.pinned:
                    updates["theta0"] = self._reassembled_start(values, p.pin)
            if trace.bar == k and field in ("L", "d") and trace.along == old_value:
                # the end of a bar (tip, joint) or its centre of mass stays what is traced
                updates["trace"] = TracePoint(bar=k, along=value, across=trace.across)
            elif trace.bar == k and field == "L" and trace.along > value:
                updates["trace"] = TracePoint(bar=k, along=value, across=trace.across)
            new = p.changed(**updates)
            self._commit(new, keep_state=True)
            if field == "L":
                with self.player.lock:
                    self.scene.resize(np.array(new.L), new.pin)
                    for scene in self.compare_scenes.values():
                        scene.resize(np.array(new.L), new.pin)
                self.frame_camera()
            if field in ("L", "d"):
                self.controls.sync_bar(k)

    def _reassembled_start(self, L, pin) -> np.ndarray:
        p = self.params
        k = driving_count(p.n, True)
        return assembly.assemble(L, pin, p.theta0[:k], theta_prev=p.theta0)

    def set_gravity(self, g: float) -> None:
        with self._lock:
            self._commit(self.params.changed(g=float(g)), keep_state=True)

    def set_pin(self, x: float, y: float) -> None:
        p = self.params
        if not p.pinned:
            raise LinkageError("pin: this mechanism is an open chain (no pinned tip)")
        with self._lock:
            pin = (float(x), float(y))
            theta0 = self._reassembled_start(p.L, pin)
            self._commit(p.changed(pin=pin, theta0=theta0), keep_state=True)
            with self.player.lock:
                self.scene.resize(np.array(self.params.L), pin)
                for scene in self.compare_scenes.values():
                    scene.resize(np.array(self.params.L), pin)
            self.frame_camera()

    def set_initial_angle(self, k: int, theta: float) -> None:
        """Initial angle of bar ``k`` (radians). A closed loop takes only its driving angles and assembles
        the rest; an angle at which it cannot close raises LinkageError and keeps the last valid start."""
        p = self.params
        count = driving_count(p.n, p.pinned)
        if not 1 <= k <= count:
            if p.pinned:
                what = f"the driving angle{'s' if count > 1 else ''} theta1..theta{count}"
            else:
                what = f"theta1..theta{p.n}"
            raise LinkageError(f"initial angle {k}: this mechanism takes {what}")
        theta = float(theta)
        if not math.isfinite(theta):
            raise LinkageError(f"theta{k} = {theta}: must be a finite number")
        with self._lock:
            theta0 = p.theta0.copy()
            theta0[k - 1] = theta
            omega0 = p.omega0.copy()
            if p.pinned:
                try:
                    theta0 = p.assembled(theta0[:count], theta_prev=p.theta0)
                except LinkageError as error:
                    raise LinkageError(
                        f"theta{k} = {math.degrees(theta):.1f}°: the loop cannot close there ({error}); "
                        f"kept theta{k} = {math.degrees(p.theta0[k - 1]):.1f}°"
                    ) from None
                try:
                    omega0 = assembly.project_velocity(p.L, theta0, omega0)
                except LinkageError:
                    omega0 = np.zeros_like(omega0)
            self.params = p.changed(theta0=theta0, omega0=omega0)
            if p.pinned:
                self.controls.sync_angles()
            self._restart_fresh()

    def set_initial_velocity(self, k: int, omega: float) -> None:
        p = self.params
        count = driving_count(p.n, p.pinned)
        if not 1 <= k <= count:
            raise LinkageError(f"initial angular velocity {k}: allowed 1..{count}")
        with self._lock:
            omega0 = p.omega0.copy()
            omega0[k - 1] = float(omega)
            if p.pinned:
                omega0 = assembly.project_velocity(p.L, p.theta0, omega0[:count])
            self.params = p.changed(omega0=omega0)
            self._restart_fresh()

    # ---------------------------------------------------------------- integration
    def set_method(self, method: str) -> None:
        with self._lock:
            self._commit(self.params.changed(method=method), keep_state=True)
            with self.player.lock:
                if not self.reactions_available():
                    self.arrows.hide()
            self.controls.sync_method()

    def set_integrator(self, integrator: str) -> None:
        with self._lock:
            new = self.params.changed(integrator=integrator)
            if self.compare:
                self._check_compare(new)
            self._commit(new, keep_state=True)
            self.controls.sync_integrator()

    def set_tolerance(self, tolerance: float) -> None:
        with self._lock:
            self._commit(self.params.changed(tolerance=float(tolerance)), keep_state=True)

    def set_step(self, step: float) -> None:
        with self._lock:
            self._commit(self.params.changed(step=float(step)), keep_state=True)

    def set_stabilization(self, name: str, alpha: float | None = None, beta: float | None = None) -> None:
        updates: dict = {"stabilization": name}
        if alpha is not None:
            updates["baumgarte_alpha"] = float(alpha)
        if beta is not None:
            updates["baumgarte_beta"] = float(beta)
        with self._lock:
            self._commit(self.params.changed(**updates), keep_state=True)
            self.controls.sync_integrator()

    def set_damping(self, damping: float) -> None:
        with self._lock:
            self._commit(self.params.changed(damping=float(damping)), keep_state=True)

    def set_compare(self, on: bool) -> None:
        """Run all three formulations from the same start, drawn as three translucent mechanisms."""
        with self._lock:
            if on:
                self._check_compare(self.params)
            self.compare = bool(on)
            self._build_scene()
            self.controls.sync_compare()
            self._restart_fresh()

    # ---------------------------------------------------------------- by name (tests, --set)
    def set_value(self, name: str, value) -> None:
        """Set one value by the names of ``python -m physics --set`` (L1, d2, m3, I1, g, theta1, omega1) or
        ``pin_x, pin_y, method, integrator, rtol, step, stabilization, damping, speed, trace_seconds``."""
        p = self.params
        import re

        match = re.fullmatch(r"(L|d|m|I|theta|omega)(\d+)", name)
        if match:
            field, k = match.group(1), int(match.group(2))
            if field == "theta":
                return self.set_initial_angle(k, float(value))
            if field == "omega":
                return self.set_initial_velocity(k, float(value))
            return self.set_bar(k, field, float(value))
        simple = {
            "g": lambda v: self.set_gravity(float(v)),
            "pin_x": lambda v: self.set_pin(float(v), p.pin[1] if p.pin else 0.0),
            "pin_y": lambda v: self.set_pin(p.pin[0] if p.pin else 0.0, float(v)),
            "method": lambda v: self.set_method(str(v)),
            "integrator": lambda v: self.set_integrator(str(v)),
            "rtol": lambda v: self.set_tolerance(float(v)),
            "step": lambda v: self.set_step(float(v)),
            "stabilization": lambda v: self.set_stabilization(str(v)),
            "damping": lambda v: self.set_damping(float(v)),
            "speed": lambda v: self.set_speed(float(v)),
            "trace_seconds": lambda v: self.set_trace_seconds(float(v)),
        }
        if name not in simple:
            allowed = f"L1..L{p.n}, d1.., m1.., I1.., g, theta1.., omega1.., " + ", ".join(list(simple)[1:])
            raise LinkageError(f"unknown parameter {name!r}; allowed: {allowed}")
        try:
            simple[name](value)
        except (TypeError, ValueError) as error:
            if isinstance(error, LinkageError):
                raise
            raise LinkageError(f"{name} = {value!r}: {error}") from None
        finally:
            self.controls.sync_all()

    # ---------------------------------------------------------------- export
    def history(self, label: str = "main") -> dict:
        """The stored samples of one run up to the displayed time (for export), as arrays."""
        with self.player.lock:
            runs = {run.spec.label: run for run in self.player.runs}
            run = runs.get(label) or (self.player.runs[0] if self.player.runs else None)
            if run is None or len(run.ring) == 0:
                raise LinkageError("nothing to export yet: the simulation has not produced samples")
            i = run.ring.index_at(self.player.display_time)
            return run.ring.window(0, i)

    def export_csv(self) -> bytes:
        return export.to_csv(self.history(), self.params)

    def export_json(self) -> bytes:
        return export.to_json(self.history(), self.params, self.run_label())

    def export_html(self) -> str:
        from .replay import replay_html

        return replay_html(self.history(), self.params, title=f"Linkage Lab replay: {self.run_label()}")

    def run_label(self) -> str:
        p = self.params
        return f"{p.preset} ({p.n} bars), {METHOD_LABELS.get(p.method, p.method)}, {p.integrator}"

    # ---------------------------------------------------------------- snapshot
    def snapshot(self) -> dict:
        """JSON-able state for tests and ``python -m app snapshot --json``."""
        with self.player.lock:
            frame = self.last_frame
            runs = {run.spec.label: run for run in self.player.runs}
            out_runs = []
            for run in self.player.runs:
                ring = run.ring
                if len(ring) == 0:
                    continue
                i = ring.index_at(self.player.display_time)
                out_runs.append(
                    {
                        "label": run.spec.label,
                        "method": run.spec.settings.method,
                        "t": float(ring.t_first + i * ring.dt),
                        "theta": [float(v) for v in ring.get("theta", i)],
                        "omega": [float(v) for v in ring.get("omega", i)],
                        "joints": [[float(x), float(y)] for x, y in ring.get("joints", i)],
                        "trace_xy": [float(v) for v in ring.get("trace_xy", i)],
                        "samples_stored": len(ring),
                        "simulated_until": ring.t_last,
                        "failed": run.failed,
                    }
                )
            nodes = {}
            scenes = [self.scene] if not self.compare else list(self.compare_scenes.values())
            for scene in scenes:
                nodes.update(scene.poses())
            traces = [self.trace] if not self.compare else list(self.compare_traces.values())
            for trace in traces:
                nodes[trace.name] = {"visible": bool(trace.handle.visible), "points": trace.points_shown}
            if self.arrows.handle is not None:
                nodes[self.arrows.name] = {"visible": bool(self.arrows.handle.visible), "arrows": self.arrows.count}
            main = out_runs[0] if out_runs else None
            values = self._current_values(frame, runs)
            snapshot = {
                "session": self.id,
                "shared": self.shared,
                "parameters": self.params.as_dict(),
                "method": self.params.method,
                "compare": self.compare,
                "playing": self.player.playing,
                "speed": self.player.speed,
                "time": float(self.player.display_time),
                "theta": main["theta"] if main else None,
                "omega": main["omega"] if main else None,
                "joints": main["joints"] if main else None,
                "energy": values,
                "runs": out_runs,
                "notice": self.notice,
                "frames_sent": self.frames_sent,
                "scene": {"root": self.scene.root, "nodes": nodes, "names": sorted(nodes)},
            }
        return snapshot

    # ---------------------------------------------------------------- lifetime
    def close(self) -> None:
        """Stop the player and drop the scene (the server calls this when the browser goes away)."""
        if self.closed:
            return
        self.closed = True
        self.player.stop()
        self.analysis.remove()
        if self.shared:  # the server's scene outlives this session: clean it
            with self.player.lock:
                for scene in [self.scene, *self.compare_scenes.values()]:
                    scene.remove()
                for trace in [self.trace, *self.compare_traces.values()]:
                    trace.remove()
                self.arrows.remove()
                try:
                    self.floor.remove()
                except Exception:
                    pass
            self.controls.remove()
