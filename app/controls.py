"""The control panel of one session, generated from the pydantic models where it can be.

Slider ranges come from the model fields' bounds (``Field(ge=..., le=...)``) intersected with a range that is
useful on a slider, and dropdown options from the fields' ``Literal`` types, so one declaration feeds
validation, the GUI and the command line. Every callback calls exactly one :class:`~app.session.Session`
method through ``session.guard``; values the session changes itself (a centre of mass pulled in by a
shorter bar, assembled angles of a closed loop) are written back with callbacks muted.
"""

from __future__ import annotations

import math
import threading
import typing
from dataclasses import dataclass
from pathlib import Path

import annotated_types

import physics
from physics import Bar, Chain, Settings
from physics.model import FIXED_STEP_INTEGRATORS

from .overlays import METHOD_COLORS, Plot
from .parameters import METHOD_LABELS, driving_count, method_label, methods_for
from .text import html_literal

STATIC = Path(__file__).resolve().parent.parent / "static"


@dataclass(frozen=True)
class SliderSpec:
    """A slider for one model field: the useful range on screen, clipped to the model's bounds."""

    model: type
    field: str
    label: str
    ui_min: float
    ui_max: float
    step: float

    def bounds(self) -> tuple[float, bool, float, bool]:
        """``(lo, lo_open, hi, hi_open)`` from the field's metadata (``-inf``/``inf`` when unbounded)."""
        lo, lo_open, hi, hi_open = -math.inf, False, math.inf, False
        for item in self.model.model_fields[self.field].metadata:
            if isinstance(item, annotated_types.Ge):
                lo, lo_open = float(item.ge), False
            elif isinstance(item, annotated_types.Gt):
                lo, lo_open = float(item.gt), True
            elif isinstance(item, annotated_types.Le):
                hi, hi_open = float(item.le), False
            elif isinstance(item, annotated_types.Lt):
                hi, hi_open = float(item.lt), True
        return lo, lo_open, hi, hi_open

    def range(self, value: float | None = None) -> tuple[float, float]:
        """Slider min and max: inside the model's bounds by construction, widened to show ``value``."""
        lo, lo_open, hi, hi_open = self.bounds()
        low = max(self.ui_min, lo + (self.step if lo_open else 0.0))
        high = min(self.ui_max, hi - (self.step if hi_open else 0.0))
        if value is not None and math.isfinite(value):
            high = max(high, min(value, hi))
            low = min(low, max(value, lo))
        return low, high

    @property
    def hint(self) -> str | None:
        return self.model.model_fields[self.field].description


BAR_SLIDERS = {
    "L": SliderSpec(Bar, "L", "length L", 0.05, 3.0, 0.01),
    "d": SliderSpec(Bar, "d", "centre of mass d", 0.0, 3.0, 0.01),  # max follows L
    "m": SliderSpec(Bar, "m", "mass m", 0.0, 5.0, 0.05),
    "I": SliderSpec(Bar, "I", "inertia I", 0.0, 1.0, 0.005),
}
GRAVITY_SLIDER = SliderSpec(Chain, "g", "gravity g", 0.0, 20.0, 0.05)
DAMPING_SLIDER = SliderSpec(Settings, "damping", "joint damping", 0.0, 2.0, 0.01)
ALPHA_SLIDER = SliderSpec(Settings, "baumgarte_alpha", "Baumgarte alpha", 0.0, 50.0, 0.5)
BETA_SLIDER = SliderSpec(Settings, "baumgarte_beta", "Baumgarte beta", 0.0, 50.0, 0.5)
# tolerance and step are set on log / millisecond scales; their model bounds are checked in the tests
TOLERANCE_LOG10 = (-12.0, -3.0, 0.5)  # rtol = atol = 10 ** slider
STEP_MS = (0.1, 20.0, 0.1)  # midpoint / variational step in milliseconds
ANGLE_DEG = (-180.0, 180.0, 0.5)
PIN_RANGE = (-5.0, 5.0, 0.01)
SPEED = (0.1, 4.0, 0.05)
TRACE_SECONDS = (0.0, 20.0, 0.5)
ARROW_SCALE = (0.05, 3.0, 0.05)
LINKS_MAX_ON_SLIDER = physics.model.MAX_LINKS


def literal_options(model: type, field: str) -> tuple[str, ...]:
    """Options of a ``Literal[...]`` field (the dropdowns' choices)."""
    return tuple(typing.get_args(model.model_fields[field].annotation))


INTEGRATOR_OPTIONS = literal_options(Settings, "integrator")
STABILIZATION_OPTIONS = literal_options(Settings, "stabilization")


def _round_to(value: float, step: float) -> float:
    return round(value / step) * step


class Controls:
    """GUI of one session. ``rebuild()`` after the mechanism changed; ``sync_*`` after the session changed
    a value itself."""

    def __init__(self, session) -> None:
        self.session = session
        self.gui = session.target.gui
        self._muted = threading.local()
        self._bar_handles: list[dict] = []
        self._bar_folders: list = []
        self._angle_handles: list = []
        self._pin_handles: dict = {}
        self._dynamic: list = []  # handles removed on rebuild
        self._status_text = ""
        self._equations_job: threading.Thread | None = None
        self._build()

    # ------------------------------------------------------------------ helpers
    @property
    def muted(self) -> bool:
        return getattr(self._muted, "on", False)

    def _set(self, handle, value) -> None:
        """Write a value into a control without running its callback."""
        self._muted.on = True
        try:
            handle.value = value
        finally:
            self._muted.on = False

    def _set_options(self, handle, options) -> None:
        """Replace a dropdown's options without running its callback (viser picks options[0] if needed)."""
        self._muted.on = True
        try:
            handle.options = tuple(options)
        finally:
            self._muted.on = False

    def _on(self, handle, action) -> None:
        """Attach ``action(value, event)`` to a control, inside the session's error boundary."""

        def callback(event) -> None:
            if self.muted:
                return
            self.session.guard(lambda: action(handle.value, event))

        if hasattr(handle, "on_click") and not hasattr(handle, "on_update"):
            handle.on_click(callback)
        else:
            handle.on_update(callback)

    def _slider(self, spec: SliderSpec, value: float, *, label: str | None = None, max_value: float | None = None):
        low, high = spec.range(value)
        if max_value is not None:
            high = max(min(high, max_value), low + spec.step)
        value = min(max(value, low), high)
        return self.gui.add_slider(
            label or spec.label, min=low, max=high, step=spec.step, initial_value=value, hint=spec.hint
        )

    # ------------------------------------------------------------------ layout
    def _build(self) -> None:
        s = self.session
        p = s.params
        gui = self.gui
        self.status = gui.add_markdown("**Starting...**")
        self.transport = gui.add_button_group("Playback", ("Play", "Pause", "Step", "Reset"))
        self._on(self.transport, lambda value, event: {
            "Play": s.play, "Pause": s.pause, "Step": s.step, "Reset": s.reset,
        }[value]())
        self.energy_plot = Plot(gui, "Energy", ["total E", "kinetic T", "potential V"],
                                [(20, 20, 20), (214, 39, 40), (31, 119, 180)], y_label="J")
        self.drift_plot = Plot(gui, "Relative energy error since last change", ["|E - E0| / E0"],
                               [(148, 103, 189)], log=True, height=130)
        self.constraint_plot = Plot(gui, "Tip distance from pin |H - pin|", ["|H - pin|"],
                                    [(140, 86, 75)], log=True, height=130, y_label="m")
        self.divergence_plot = Plot(
            gui, "Tip divergence from Newton-Euler", ["Lagrange", "DAE"],
            [METHOD_COLORS["lagrange"], METHOD_COLORS["dae"]], log=True, height=150, y_label="m",
        )
        self.tabs = gui.add_tab_group()
        with self.tabs.add_tab("Mechanism"):
            self.mechanism = gui.add_dropdown("Mechanism", physics.preset_names(), initial_value=p.preset)
            self._on(self.mechanism, lambda value, event: s.set_mechanism(value))
            self.links = gui.add_slider("Bars (chain)", min=1, max=LINKS_MAX_ON_SLIDER, step=1, initial_value=p.n)
            self._on(self.links, lambda value, event: s.set_links(int(value)))
            self.gravity = self._slider(GRAVITY_SLIDER, p.g)
            self._on(self.gravity, lambda value, event: s.set_gravity(value))
            self.angles_folder = gui.add_folder("Initial angles (degrees)")
            self.pin_folder = gui.add_folder("Ground pin H")
            self.bars_folder = gui.add_folder("Bars")
        with self.tabs.add_tab("Simulation"):
            self.method = gui.add_dropdown("Method", self._method_labels(), initial_value=method_label(p.method))
            self._on(self.method, lambda value, event: s.set_method(self._method_from_label(value)))
            self.compare = gui.add_checkbox("Compare all three methods", initial_value=False,
                                            hint="Run Newton-Euler, Lagrange and DAE from the same start")
            self._on(self.compare, lambda value, event: s.set_compare(value))
            self.integrator = gui.add_dropdown("Integrator", INTEGRATOR_OPTIONS, initial_value=p.integrator)
            self._on(self.integrator, lambda value, event: s.set_integrator(value))
            lo, hi, step = TOLERANCE_LOG10
            self.tolerance = gui.add_slider("Tolerance log10(rtol)", min=lo, max=hi, step=step,
                                            initial_value=_round_to(math.log10(p.tolerance), step),
                                            hint="rtol = atol = 10^value (adaptive integrators)")
            self._on(self.tolerance, lambda value, event: s.set_tolerance(10.0 ** value))
            lo, hi, step = STEP_MS
            self.step = gui.add_slider("Step (ms, fixed-step)", min=lo, max=hi, step=step,
                                       initial_value=min(max(p.step * 1e3, lo), hi))
            self._on(self.step, lambda value, event: s.set_step(value * 1e-3))
            self.stabilization = gui.add_dropdown("Stabilisation (loops)", STABILIZATION_OPTIONS,
                                                  initial_value=p.stabilization)
            self._on(self.stabilization, lambda value, event: s.set_stabilization(value))
            self.alpha = self._slider(ALPHA_SLIDER, p.baumgarte_alpha)
            self._on(self.alpha, lambda value, event: s.set_stabilization(s.params.stabilization, alpha=value))
            self.beta = self._slider(BETA_SLIDER, p.baumgarte_beta)
            self._on(self.beta, lambda value, event: s.set_stabilization(s.params.stabilization, beta=value))
            self.damping = self._slider(DAMPING_SLIDER, p.damping)
            self._on(self.damping, lambda value, event: s.set_damping(value))
        with self.tabs.add_tab("Display"):
            lo, hi, step = SPEED
            self.speed = gui.add_slider("Playback speed", min=lo, max=hi, step=step, initial_value=1.0)
            self._on(self.speed, lambda value, event: s.set_speed(value))
            lo, hi, step = TRACE_SECONDS
            self.trace_seconds = gui.add_slider("Trace length (s)", min=lo, max=hi, step=step,
                                                initial_value=s.trace_seconds)
            self._on(self.trace_seconds, lambda value, event: s.set_trace_seconds(value))
            self.trace_point = gui.add_dropdown("Traced point", tuple(p.trace_choices()), initial_value=p.trace_label())
            self._on(self.trace_point, lambda value, event: s.set_trace_point(value))
            self.reactions = gui.add_checkbox("Reaction arrows", initial_value=False,
                                              hint="Joint reactions (DAE) and the pin's reaction (closed loops)")
            self._on(self.reactions, lambda value, event: s.set_reactions(value))
            lo, hi, step = ARROW_SCALE
            self.arrow_scale = gui.add_slider("Arrow scale", min=lo, max=hi, step=step, initial_value=s.reaction_scale,
                                              hint="1 draws the total weight as long as the mechanism's reach")
            self._on(self.arrow_scale, lambda value, event: s.set_reactions(s.reactions_on, scale=value))
        with self.tabs.add_tab("Equations"):
            self.equations_button = gui.add_button("Show the equations of motion")
            self._on(self.equations_button, lambda value, event: self.show_equations())
            self.equations_tex = gui.add_button("Download as LaTeX")
            self._on(self.equations_tex, lambda value, event: self._download(event, "tex"))
            self.equations = gui.add_html("<p>The equations being integrated, as derived by sympy, for the "
                                          "current mechanism and method. Press the button (the first time per "
                                          "mechanism this derives them, a few seconds).</p>")
        with self.tabs.add_tab("Export"):
            self.export_csv = gui.add_button("Download CSV")
            self._on(self.export_csv, lambda value, event: self._download(event, "csv"))
            self.export_json = gui.add_button("Download JSON")
            self._on(self.export_json, lambda value, event: self._download(event, "json"))
            self.export_html = gui.add_button("Save HTML replay")
            self._on(self.export_html, lambda value, event: self._download(event, "html"))
            gui.add_markdown("Exports hold the run up to the displayed time (at most the last "
                             "two minutes, 60 samples per second). The replay plays without the server.")
        with self.tabs.add_tab("Help"):
            help_file = STATIC / "help.md"
            gui.add_markdown(help_file.read_text() if help_file.exists() else "See docs/app.md.")
        self.rebuild()

    def _method_labels(self) -> tuple[str, ...]:
        return tuple(method_label(m) for m in methods_for(self.session.params.chain()))

    @staticmethod
    def _method_from_label(label: str) -> str:
        for name, text in METHOD_LABELS.items():
            if text == label:
                return name
        return label

    # ------------------------------------------------------------------ per-mechanism parts
    def rebuild(self) -> None:
        """(Re)create the per-bar folders, angle sliders and pin sliders; refresh every value."""
        s = self.session
        p = s.params
        for handle in self._dynamic:
            try:
                handle.remove()
            except Exception:
                pass
        self._dynamic, self._bar_handles, self._angle_handles, self._pin_handles = [], [], [], {}
        gui = self.gui
        with self.bars_folder:
            for k in range(1, p.n + 1):
                folder = gui.add_folder(f"Bar {k}", expand_by_default=(p.n <= 3 and k == 1))
                self._dynamic.append(folder)
                with folder:
                    handles = {}
                    for field, spec in BAR_SLIDERS.items():
                        value = getattr(p, field)[k - 1]
                        max_value = p.L[k - 1] if field == "d" else None
                        handles[field] = self._slider(spec, value, label=spec.label, max_value=max_value)
                        self._on(handles[field], lambda value, event, k=k, field=field: s.set_bar(k, field, value))
                    self._bar_handles.append(handles)
        with self.angles_folder:
            count = driving_count(p.n, p.pinned)
            lo, hi, step = ANGLE_DEG
            for k in range(1, p.n + 1):
                label = f"theta{k}" if k <= count else f"theta{k} (assembled)"
                handle = gui.add_slider(label, min=lo, max=hi, step=step, initial_value=self._degrees(p.theta0[k - 1]),
                                        disabled=k > count)
                self._on(handle, lambda value, event, k=k: s.set_initial_angle(k, math.radians(value)))
                self._angle_handles.append(handle)
                self._dynamic.append(handle)
        self.pin_folder.visible = p.pinned
        if p.pinned:
            with self.pin_folder:
                lo, hi, step = PIN_RANGE
                for axis, value in zip(("x", "y"), p.pin):
                    handle = gui.add_slider(f"pin {axis}", min=min(lo, value), max=max(hi, value), step=step,
                                            initial_value=value)
                    self._pin_handles[axis] = handle
                    self._dynamic.append(handle)
                self._on(self._pin_handles["x"], lambda value, event: s.set_pin(value, s.params.pin[1]))
                self._on(self._pin_handles["y"], lambda value, event: s.set_pin(s.params.pin[0], value))
        self._set(self.mechanism, p.preset)
        self.links.visible = p.preset == "chain"
        self._set(self.links, p.n)
        self.constraint_plot.set_visible(p.pinned)
        self.sync_method()
        self.sync_integrator()
        self.sync_compare()
        self._set_options(self.trace_point, p.trace_choices())
        self._set(self.trace_point, p.trace_label())
        self.equations.content = "<p>Press the button to show the equations for this mechanism and method.</p>"

    @staticmethod
    def _degrees(theta: float) -> float:
        deg = math.degrees(theta)
        deg = (deg + 180.0) % 360.0 - 180.0 if abs(deg) > 180.0 else deg
        return round(deg / ANGLE_DEG[2]) * ANGLE_DEG[2]

    # ------------------------------------------------------------------ write-backs
    def sync_bar(self, k: int) -> None:
        """After bar k's length changed: the d slider's max follows L, and d may have been pulled in."""
        p = self.session.params
        if k - 1 >= len(self._bar_handles):
            return
        handles = self._bar_handles[k - 1]
        d_handle = handles["d"]
        d_handle.max = max(p.L[k - 1], BAR_SLIDERS["d"].step)
        self._set(d_handle, min(p.d[k - 1], d_handle.max))
        self._set(handles["L"], p.L[k - 1])
        self._set_options(self.trace_point, p.trace_choices())
        self._set(self.trace_point, p.trace_label())

    def sync_angles(self) -> None:
        p = self.session.params
        for k, handle in enumerate(self._angle_handles):
            self._set(handle, self._degrees(p.theta0[k]))

    def sync_method(self) -> None:
        p = self.session.params
        self._set_options(self.method, self._method_labels())
        self._set(self.method, method_label(p.method))

    def sync_integrator(self) -> None:
        p = self.session.params
        self._set(self.integrator, p.integrator)
        self.step.visible = p.integrator in FIXED_STEP_INTEGRATORS
        self.tolerance.visible = p.integrator not in FIXED_STEP_INTEGRATORS
        self.stabilization.visible = p.pinned
        self._set(self.stabilization, p.stabilization)
        baumgarte = p.pinned and p.stabilization == "baumgarte"
        self.alpha.visible = baumgarte
        self.beta.visible = baumgarte

    def sync_compare(self) -> None:
        s = self.session
        self._set(self.compare, s.compare)
        self.divergence_plot.set_visible(s.compare)
        self.method.disabled = s.compare

    def sync_all(self) -> None:
        """Write every value of the session back into the controls (after ``Session.set_value``)."""
        s = self.session
        p = s.params
        self._set(self.gravity, p.g)
        self._set(self.damping, p.damping)
        for k, handles in enumerate(self._bar_handles, start=1):
            self.sync_bar(k)
            for field in ("m", "I"):
                self._set(handles[field], getattr(p, field)[k - 1])
        self.sync_angles()
        self.sync_method()
        self.sync_integrator()
        self._set(self.speed, min(max(s.player.speed, SPEED[0]), SPEED[1]))
        self._set(self.trace_seconds, s.trace_seconds)
        if p.pinned and self._pin_handles:
            self._set(self._pin_handles["x"], p.pin[0])
            self._set(self._pin_handles["y"], p.pin[1])

    def show_status(self, text: str) -> None:
        if text != self._status_text:
            self._status_text = text
            try:
                self.status.content = text
            except Exception:
                pass

    # ------------------------------------------------------------------ equations and export
    def show_equations(self) -> None:
        """Render the current system's equations in a worker thread (sympy is imported there, never at start)."""
        from . import equations

        p = self.session.params
        method = p.method
        key = (method, p.n, p.pinned)
        if self._equations_job is not None and self._equations_job.is_alive():
            return
        self.equations.content = f"<p><b>Deriving</b> the {method_label(method)} equations for {p.n} bars...</p>"

        def work() -> None:
            try:
                html = equations.equations_html(*key)
            except Exception as error:  # shown in the panel; the session goes on
                html = f"<p>Could not render the equations: {html_literal(f'{type(error).__name__}: {error}')}</p>"
            if (self.session.params.method, self.session.params.n, self.session.params.pinned) == key:
                self.equations.content = html

        self._equations_job = threading.Thread(target=work, name="equations", daemon=True)
        self._equations_job.start()

    def _download(self, event, kind: str) -> None:
        s = self.session
        client = getattr(event, "client", None)
        if client is None:
            client = None if s.shared else s.target
        stem = f"linkage-{s.params.preset}-{s.params.method}"
        if kind == "csv":
            name, content = f"{stem}.csv", s.export_csv()
        elif kind == "json":
            name, content = f"{stem}.json", s.export_json()
        elif kind == "tex":
            from . import equations

            p = s.params
            try:
                text = equations.equations_tex(p.method, p.n, p.pinned)
            except ValueError as error:
                raise physics.LinkageError(str(error)) from None
            name, content = f"equations-{p.method}-{p.n}{'-pinned' if p.pinned else ''}.tex", text.encode("utf-8")
        else:
            name, content = f"{stem}-replay.html", s.export_html().encode("utf-8")
        if client is None:
            s.target.send_file_download(name, content)
        else:
            client.send_file_download(name, content)

    def remove(self) -> None:
        for handle in [self.status, self.transport, self.tabs]:
            try:
                handle.remove()
            except Exception:
                pass
        for plot in (self.energy_plot, self.drift_plot, self.constraint_plot, self.divergence_plot):
            plot.remove()
