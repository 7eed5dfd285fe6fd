"""The control panel of one session, generated from the pydantic models where it can be.

Slider ranges come from the model fields' bounds and dropdown options from the fields' ``Literal`` types, so
one declaration feeds validation, the GUI and the command line; every number has a box for typed values
beside its slider (:mod:`app.number_inputs`). The panel sees its session only through
:class:`~app.ports.SessionPort`: it reads the values in force (``port.setup``, ``port.display``) and asks for
changes by name (``port.set("m2", 3.0)``), each callback inside ``port.guard``. Values the session changes
itself (a centre of mass pulled in by a shorter bar, assembled angles of a closed loop) are written back with
callbacks muted.
"""

from __future__ import annotations

import math
import threading

import viser

import physics
from physics import LinkageError
from physics.mechanism import MECHANISM_PRESETS
from physics.model import FIXED_STEP_INTEGRATORS

from . import share
from .chain_knobs import (  # the chain's slider ranges and texts, kept with the one session's chain knobs
    ANGLE_SLIDER,
    BAR_SLIDERS,
    DAMPING_SLIDER,
    GRAVITY_SLIDER,
    PIN_SLIDER,
    SPEED_START_SLIDER,
    preset_description,
    reach_text,
)
from .commands import check_control, options_of, split_name
from .logs import quietly
from .number_inputs import NumberInputs, SliderSpec
from .overlays import METHOD_COLORS, Plot
from .panel_rows import (
    CHAIN_PLOT_CHOICES,
    EXPORT_NOTE,
    TIMELINE_MIN_SPAN,
    TIMELINE_STEP,
    add_arrow_number,
    add_drift_plot,
    add_export_button,
    add_motion_numbers,
    add_phase_image,
    add_plot_menu,
    add_residual_plot,
    add_view_row,
    plot_kind,
    show_plot,
    timeline_window,
)
from .parameters import driving_count, method_from_label, method_label, methods_for, wrap_degrees
from .phase_view import BAR_COLORS
from .ports import SessionPort
from .resources import STATIC
from .text import html_literal, markdown_literal

ALPHA_SLIDER = SliderSpec("baumgarte_alpha", 0.0, 50.0, 0.5)
BETA_SLIDER = SliderSpec("baumgarte_beta", 0.0, 50.0, 0.5)
PLOT_CHOICES = CHAIN_PLOT_CHOICES  # the rows every panel has: app/panel_rows.py
STEP_SLIDER = SliderSpec("step", 0.1, 20.0, 0.1)  # midpoint / variational step in milliseconds
# tolerance and step are set on log / millisecond scales; their model bounds are checked in the tests
TOLERANCE_LOG10 = (-12.0, -3.0, 0.5)  # rtol = atol = 10 ** slider
STEP_MS = (STEP_SLIDER.ui_min, STEP_SLIDER.ui_max, STEP_SLIDER.step)
ANGLE_DEG = (ANGLE_SLIDER.ui_min, ANGLE_SLIDER.ui_max, ANGLE_SLIDER.step)
LINKS_MAX_ON_SLIDER = physics.model.MAX_LINKS
INTEGRATOR_OPTIONS = options_of("integrator")
STABILIZATION_OPTIONS = options_of("stabilization")


def accepted_values(handle) -> dict:
    """What a control offers, as keywords of :func:`app.commands.check_control`: a dropdown or button group its
    options, a checkbox true or false, a slider a finite number within its range (one step of slack for a
    range the server has just moved; a whole number on a slider of whole steps)."""
    if isinstance(handle, (viser.GuiDropdownHandle, viser.GuiButtonGroupHandle)):
        return {"options": tuple(handle.options)}
    if isinstance(handle, viser.GuiCheckboxHandle):
        return {"flag": True}
    if isinstance(handle, viser.GuiSliderHandle):
        step = float(handle.step or 0.0)
        whole = step == int(step) and float(handle.min) == int(handle.min) and step > 0
        return {"number": True, "whole": whole, "low": float(handle.min) - step, "high": float(handle.max) + step}
    return {}


def _round_to(value: float, step: float) -> float:
    return round(value / step) * step


def _from_log10(exponent: float) -> float:
    """The slider's log10(rtol) back to rtol; a wild exponent (a hostile client) stays a float the model refuses."""
    return 10.0 ** min(max(exponent, -400.0), 300.0) if exponent == exponent else exponent


def _degrees_per_second(omega: float) -> float:
    """An angular velocity for its slider: degrees per second on the slider's step (not wrapped: 720 °/s is two
    turns a second)."""
    return _round_to(math.degrees(omega), SPEED_START_SLIDER.step)


def _degrees(theta: float) -> float:
    """An angle for the angle sliders: degrees in [-180, 180], on the slider's step."""
    return _round_to(wrap_degrees(theta), ANGLE_DEG[2])



class Controls:
    """GUI of one session. ``rebuild()`` after the mechanism changed; ``sync_*`` after the session changed
    a value itself."""

    def __init__(self, port: SessionPort, gui) -> None:
        self.port = port
        self.gui = gui
        self._muted = threading.local()
        self._angle_names: list[str] = []
        self._speed_names: list[str] = []  # omega1.. (initial angular velocities)
        self._bar_folders: list = []
        self._dynamic: list = []  # folders removed on rebuild (their numbers are removed by name)
        self._dynamic_numbers: list[str] = []
        self._status_text = ""
        self._equations_job: threading.Thread | None = None
        self._equations_key: tuple | None = None  # the system the Equations tab shows (None: not asked for yet)
        self.numbers = NumberInputs(gui, port, self.bind, self._quiet, lambda: self.muted)
        self._build()

    # ------------------------------------------------------------------ helpers
    @property
    def muted(self) -> bool:
        return getattr(self._muted, "on", False)

    def _quiet(self, action) -> None:
        """Run ``action`` (writes into controls) without running the controls' callbacks."""
        self._muted.on = True
        try:
            action()
        finally:
            self._muted.on = False

    def _set(self, handle, value) -> None:
        """Write a value into a control without running its callback."""
        self._quiet(lambda: setattr(handle, "value", value))

    def _set_options(self, handle, options) -> None:
        """Replace a dropdown's options without running its callback (viser picks options[0] if needed)."""
        self._quiet(lambda: setattr(handle, "options", tuple(options)))

    def bind(self, handle, action, accepts: dict | None = None) -> None:
        """Attach ``action(value, event)`` to a control, inside the session's error boundary. The value is
        checked first against what the control offers (:func:`accepted_values`, or ``accepts``: keywords of
        :func:`app.commands.check_control`); a value it does not offer is refused with a notice and the control
        put back on the last value it accepted, so that nothing reads a value outside its options."""
        accepted = [handle.value]

        def checked(value, event) -> None:
            try:
                check_control(str(getattr(handle, "label", "control")), value,
                              **(accepted_values(handle) if accepts is None else accepts))
            except LinkageError:
                previous = accepted[0]
                options = getattr(handle, "options", None)
                if options is not None and previous not in options and options:
                    previous = options[0]
                self._set(handle, previous)
                raise
            accepted[0] = value
            action(value, event)

        def callback(event) -> None:
            if self.muted:
                return
            value = handle.value
            self.port.guard(lambda: checked(value, event))

        if hasattr(handle, "on_click") and not hasattr(handle, "on_update"):
            handle.on_click(callback)
        else:
            handle.on_update(callback)

    # the handles scripts and tests drive, by the names they know
    @property
    def gravity(self):
        return self.numbers.controls["g"].slider

    @property
    def damping(self):
        return self.numbers.controls["damping"].slider

    @property
    def alpha(self):
        return self.numbers.controls["baumgarte_alpha"].slider

    @property
    def beta(self):
        return self.numbers.controls["baumgarte_beta"].slider

    @property
    def step(self):
        return self.numbers.controls["step"].slider

    @property
    def tolerance(self):
        return self.numbers.controls["rtol"].slider

    @property
    def speed(self):
        return self.numbers.controls["speed"].slider

    @property
    def trace_seconds(self):
        return self.numbers.controls["trace_seconds"].slider

    @property
    def arrow_scale(self):
        return self.numbers.controls["arrow_scale"].slider

    @property
    def _bar_handles(self) -> list[dict]:
        """Per bar, its sliders by field (``[{"L": slider, "d": ..., "m": ..., "I": ...}, ...]``)."""
        n = self.port.setup.n
        return [{f: self.numbers.controls[f"{f}{k}"].slider for f in BAR_SLIDERS} for k in range(1, n + 1)]

    @property
    def _angle_handles(self) -> list:
        return [self.numbers.controls[name].slider for name in self._angle_names]

    def typed_box(self, name: str):
        """The box for typed values of ``name`` (``I1``, ``g``, ``rtol``, ...)."""
        return self.numbers.controls[name].box

    # ------------------------------------------------------------------ layout
    def _build(self) -> None:
        s = self.port
        p = s.setup
        gui = self.gui
        add = self.numbers.add
        self.status = gui.add_markdown("**Starting...**")
        self.transport = gui.add_button_group("Playback", ("Play", "Pause", "Step", "Reset"))
        self.bind(self.transport, lambda value, event: self._transport(value))
        # the run so far: drag back to look again (pauses there); Play goes on from the time shown
        self.timeline = gui.add_slider("Timeline (s)", min=0.0, max=TIMELINE_MIN_SPAN, step=TIMELINE_STEP,
                                       initial_value=0.0, hint="Drag to go back through the run so far (pauses)")
        self.bind(self.timeline, lambda value, event: s.scrub(value), accepts={"number": True})
        self._timeline_end = 0.0
        # beside Playback, not in a tab: a lecturer switches views often (and the F key presses it)
        self.camera_view = add_view_row(gui, self.bind, s)
        self.plot_choice = add_plot_menu(gui, self.bind, PLOT_CHOICES, self.choose_plot,
                                         "Energy and its error, the angles over time, or the phase portrait")
        self.angle_plot: Plot | None = None  # made per mechanism (one series per bar), in rebuild()
        self.phase_image = add_phase_image(gui)
        self.energy_plot = Plot(gui, "Energy", ["total E", "kinetic T", "potential V"],
                                [(20, 20, 20), (214, 39, 40), (31, 119, 180)], y_label="J")
        self.drift_plot = add_drift_plot(gui)
        self.constraint_plot = add_residual_plot(gui, "Tip distance from pin |H - pin|", "|H - pin|", "m")
        self.divergence_plot = Plot(
            gui, "Tip divergence from Newton-Euler", ["Lagrange", "DAE"],
            [METHOD_COLORS["lagrange"], METHOD_COLORS["dae"]], log=True, height=150, y_label="m",
        )
        self.tabs = gui.add_tab_group()
        with self.tabs.add_tab("Mechanism"):
            self.mechanism = gui.add_dropdown("Mechanism", [*physics.preset_names(), *MECHANISM_PRESETS],
                                              initial_value=p.preset)
            self.bind(self.mechanism, lambda value, event: s.set_mechanism(value))
            self.description = gui.add_markdown("")  # what the chosen preset is and teaches (physics.chain_presets)
            self.preset_defaults = gui.add_button("Reset to the preset's values",
                                                  hint="Lengths, masses, inertias, gravity and angles as the preset has them")
            self.bind(self.preset_defaults, lambda value, event: self.reset_to_preset())
            self.links = gui.add_slider("Bars (chain)", min=1, max=LINKS_MAX_ON_SLIDER, step=1, initial_value=p.n)
            self.bind(self.links, lambda value, event: s.set_links(value))
            add("g", GRAVITY_SLIDER, p.g)
            self.angles_folder = gui.add_folder("Initial angles (degrees)")
            self.speeds_folder = gui.add_folder("Initial angular velocities (°/s)", expand_by_default=False)
            self.pin_folder = gui.add_folder("Ground pin H")
            self.bars_folder = gui.add_folder("Bars")
        with self.tabs.add_tab("Simulation"):
            self.method = gui.add_dropdown("Method", self._method_labels(), initial_value=method_label(p.method))
            self.bind(self.method, lambda value, event: s.set("method", method_from_label(value)))
            self.compare = gui.add_checkbox("Compare all three methods", initial_value=False,
                                            hint="Run Newton-Euler, Lagrange and DAE from the same start")
            self.bind(self.compare, lambda value, event: s.set_compare(value))
            self.integrator = gui.add_dropdown("Integrator", INTEGRATOR_OPTIONS, initial_value=p.integrator)
            self.bind(self.integrator, lambda value, event: s.set("integrator", value))
            lo, hi, step = TOLERANCE_LOG10
            add("rtol", SliderSpec("rtol", lo, hi, step), p.tolerance, label="Tolerance log10(rtol)", slider_range=(lo, hi),
                to_slider=lambda v: min(max(_round_to(math.log10(v), step), lo), hi), from_slider=_from_log10,
                hint="rtol = atol = 10^value (adaptive integrators); type rtol itself in the box, e.g. 1e-9")
            add("step", STEP_SLIDER, p.step, label="Step (ms, fixed-step)")
            self.stabilization = gui.add_dropdown("Stabilisation (loops)", STABILIZATION_OPTIONS,
                                                  initial_value=p.stabilization)
            self.bind(self.stabilization, lambda value, event: s.set("stabilization", value))
            add("baumgarte_alpha", ALPHA_SLIDER, p.baumgarte_alpha)
            add("baumgarte_beta", BETA_SLIDER, p.baumgarte_beta)
            add("damping", DAMPING_SLIDER, p.damping)
        with self.tabs.add_tab("Display"):
            add_motion_numbers(add, s.display)
            self.trace_point = gui.add_dropdown("Traced point", tuple(p.trace_choices()), initial_value=p.trace_label())
            self.bind(self.trace_point, lambda value, event: s.set("trace", value))
            self.reactions = gui.add_checkbox("Reaction arrows", initial_value=False,
                                              hint="Joint reactions (every method) and the pin's reaction (closed loops); "
                                                   "in compare mode those of the Newton-Euler run")
            self.bind(self.reactions, lambda value, event: s.set_reactions(value))
            add_arrow_number(add, s.display)
        with self.tabs.add_tab("Equations"):
            self.equations_button = gui.add_button("Show the equations of motion")
            self.bind(self.equations_button, lambda value, event: self.show_equations())
            self.equations_tex = gui.add_button("Download as LaTeX")
            self.bind(self.equations_tex, lambda value, event: s.download("tex", getattr(event, "client", None)))
            self.equations = gui.add_html("<p>The equations being integrated, as derived by sympy, for the "
                                          "current mechanism and method. Press the button (the first time per "
                                          "mechanism this derives them, a few seconds).</p>")
        with self.tabs.add_tab("Export"):
            for kind in ("csv", "json", "html"):
                setattr(self, f"export_{kind}", add_export_button(gui, self.bind, s, kind))
            gui.add_markdown(EXPORT_NOTE)
            self.save_setup = gui.add_button("Save this setup (JSON)")
            self.bind(self.save_setup, lambda value, event: s.download("setup", getattr(event, "client", None)))
            self.load_setup = gui.add_upload_button("Load a setup (JSON)", mime_type="application/json")
            self.load_setup.on_upload(lambda event: None if self.muted else s.guard(
                lambda: s.upload_setup(getattr(event, "client_id", None), self.load_setup.value.name,
                                       self.load_setup.value.content)))
            self.share_button = gui.add_button("Link to this setup")
            self.bind(self.share_button, lambda value, event: self.show_link())
            self.share_link = gui.add_markdown("A link that opens this mechanism with these values and settings "
                                               "in a new session (press the button for the current ones).")
        with self.tabs.add_tab("Help"):
            help_file = STATIC / "help.md"
            gui.add_markdown(help_file.read_text() if help_file.exists() else "See docs/app.md.")
        self.rebuild()

    def show_link(self) -> None:
        """The share link for the current setup (app/share.py), as a link to open or copy."""
        query = share.link_query(self.port.setup)
        # on the server's root address, never relative to this page's: a presenter's page has a secret path
        self.share_link.content = (f"[Open this setup](/{query}) (right-click to copy the link), or add this to "
                                   f"the server's address:\n\n`/{query}`")

    def _transport(self, button) -> None:
        actions = {"Play": self.port.play, "Pause": self.port.pause, "Step": self.port.step, "Reset": self.port.reset}
        if not isinstance(button, str) or button not in actions:
            raise LinkageError(f"playback = {button!r}: allowed {', '.join(actions)}")
        actions[button]()

    def _method_labels(self) -> tuple[str, ...]:
        return tuple(method_label(m) for m in methods_for(self.port.setup.chain))


    # ------------------------------------------------------------------ per-mechanism parts
    def rebuild(self) -> None:
        """(Re)create the per-bar folders, angle sliders and pin sliders; refresh every value."""
        p = self.port.setup
        self.numbers.remove(self._dynamic_numbers)
        for handle in self._dynamic:
            quietly(handle.remove, "removing a folder")
        self._dynamic, self._dynamic_numbers, self._angle_names, self._speed_names = [], [], [], []
        gui = self.gui
        add = self.numbers.add
        with self.bars_folder:
            for k in range(1, p.n + 1):
                folder = gui.add_folder(f"Bar {k}", expand_by_default=(p.n <= 3 and k == 1))
                self._dynamic.append(folder)
                with folder:
                    for field, spec in BAR_SLIDERS.items():
                        name = f"{field}{k}"
                        max_value = p.L[k - 1] if field == "d" else None
                        add(name, spec, getattr(p.chain.bars[k - 1], field), max_value=max_value)
                        self._dynamic_numbers.append(name)
        with self.angles_folder:
            count = driving_count(p.n, p.pinned)
            for k in range(1, p.n + 1):
                name = f"theta{k}"
                label = f"theta{k} (°)" if k <= count else f"theta{k} (°, assembled)"
                add(name, ANGLE_SLIDER, p.theta0[k - 1], label=label, to_slider=_degrees, from_slider=math.radians,
                    disabled=k > count)
                self._angle_names.append(name)
                self._dynamic_numbers.append(name)
            if p.pinned and p.n == 3:  # a four-bar: the range of theta1 over which the loop closes, in closed form
                self.reach_line = gui.add_markdown(reach_text(p))
                self._dynamic.append(self.reach_line)
            else:
                self.reach_line = None
        with self.speeds_folder:
            for k in range(1, p.n + 1):
                name = f"omega{k}"
                label = f"omega{k} (°/s)" if k <= count else f"omega{k} (°/s, follows the loop)"
                add(name, SPEED_START_SLIDER, p.omega0[k - 1], label=label, to_slider=_degrees_per_second,
                    from_slider=math.radians, disabled=k > count)
                self._speed_names.append(name)
                self._dynamic_numbers.append(name)
        self.pin_folder.visible = p.pinned
        if p.pin is not None:
            with self.pin_folder:
                for name, value in zip(("pin_x", "pin_y"), p.pin):
                    add(name, PIN_SLIDER, value, label=f"pin {name[-1]} (m)")
                    self._dynamic_numbers.append(name)
        self._set(self.mechanism, p.preset)
        self.description.content = "*" + markdown_literal(preset_description(p)) + "*"
        self.links.visible = p.preset == "chain"
        if self.angle_plot is None or len(self.angle_plot.labels) != p.n:
            self._make_angle_plot(p.n)
        self._set(self.links, p.n)
        self.constraint_plot.set_visible(p.pinned)
        self.sync_method()
        self.sync_integrator()
        self.sync_compare()
        self.sync_trace_point()
        self.equations.content = "<p>Press the button to show the equations for this mechanism and method.</p>"

    # ------------------------------------------------------------------ write-backs
    def sync_after(self, name: str) -> None:
        """After the session applied ``name``: the controls it may have moved show the values in force."""
        key, k = split_name(name)
        p = self.port.setup
        if key == "L" and k is not None:
            self.sync_bar(k)
            if p.pinned:
                self.sync_angles()
                self.sync_reach()
        elif key in ("theta", "omega") or name in ("pin_x", "pin_y"):
            self.sync_angles()  # a closed loop assembles the other angles and projects the velocities
            self.sync_reach()
            self.numbers.sync(name)
        elif name in ("method", "integrator", "stabilization"):
            self.sync_method()
            self.sync_integrator()
        elif name == "trace":
            self.sync_trace_point()
        else:
            self.numbers.sync(name)

    def sync_bar(self, k: int) -> None:
        """After bar k's length changed: the d slider's max follows L, and d may have been pulled in."""
        p = self.port.setup
        if f"d{k}" not in self.numbers.controls:
            return
        d_slider = self.numbers.controls[f"d{k}"].slider
        self._quiet(lambda: setattr(d_slider, "max", max(p.L[k - 1], BAR_SLIDERS["d"].step)))
        for field in BAR_SLIDERS:
            self.numbers.sync(f"{field}{k}")
        self.sync_trace_point()

    def sync_trace_point(self) -> None:
        p = self.port.setup
        self._set_options(self.trace_point, p.trace_choices())
        self._set(self.trace_point, p.trace_label())

    def sync_reach(self) -> None:
        """The four-bar's reachable theta1 after a length or the pin changed."""
        if getattr(self, "reach_line", None) is not None:
            self.reach_line.content = reach_text(self.port.setup)

    def sync_angles(self) -> None:
        """Every initial angle and angular velocity slider (a closed loop moves the assembled ones too)."""
        for name in self._angle_names + self._speed_names:
            self.numbers.sync(name)

    def sync_method(self) -> None:
        self.refresh_equations()
        p = self.port.setup
        self._set_options(self.method, self._method_labels())
        self._set(self.method, method_label(p.method))

    def sync_integrator(self) -> None:
        p = self.port.setup
        self._set(self.integrator, p.integrator)
        fixed = p.integrator in FIXED_STEP_INTEGRATORS
        baumgarte = p.pinned and p.stabilization == "baumgarte"
        for name, visible in (("step", fixed), ("rtol", not fixed), ("baumgarte_alpha", baumgarte),
                              ("baumgarte_beta", baumgarte)):
            control = self.numbers.controls[name]
            control.slider.visible = visible
            control.box.visible = visible
        self.stabilization.visible = p.pinned
        self._set(self.stabilization, p.stabilization)

    def sync_compare(self) -> None:
        s = self.port
        self._set(self.compare, s.compare)
        self.divergence_plot.set_visible(s.compare)
        self.method.disabled = s.compare

    def sync_all(self) -> None:
        """Write every value in force back into the controls (after a refused value, or a Reset)."""
        p = self.port.setup
        for k in range(1, p.n + 1):
            d_slider = self.numbers.controls.get(f"d{k}")
            if d_slider is not None:
                self._quiet(lambda s=d_slider.slider, k=k: setattr(s, "max", max(p.L[k - 1], BAR_SLIDERS["d"].step)))
        self.numbers.sync_all()
        self.sync_method()
        self.sync_integrator()
        self.sync_compare()
        self.sync_trace_point()
        self._set(self.reactions, self.port.reactions_on)

    def clear_plots(self) -> None:
        """Empty every plot of the run (a new start is being prepared)."""
        for plot in (self.energy_plot, self.drift_plot, self.constraint_plot, self.angle_plot):
            if plot is not None:
                plot.clear()

    @property
    def plot_kind(self) -> str:
        """``energy``, ``angles`` or ``phase``: which plot the frame view keeps up to date (the last choice
        accepted, never the dropdown's raw value: a client may have stored anything there)."""
        return getattr(self, "_plot_kind", "energy")

    def choose_plot(self, label) -> None:
        self._plot_kind = kind = plot_kind(PLOT_CHOICES, label)
        show_plot(kind, [self.energy_plot, self.drift_plot], self.angle_plot, self.phase_image)
        self.port.refresh_plots()

    def _make_angle_plot(self, n: int) -> None:
        if self.angle_plot is not None:
            self.angle_plot.remove()
        self.angle_plot = Plot(self.gui, "Angles", [f"θ{k}" for k in range(1, n + 1)],
                               [BAR_COLORS[k % len(BAR_COLORS)] for k in range(n)], y_label="°",
                               order=self.energy_plot.handle.order - 0.5)
        self.angle_plot.set_visible(self.plot_kind == "angles")

    def show_timeline(self, t: float, t_first: float, restarted: bool) -> None:
        """The timeline's range is the run so far (what the rings still hold), its thumb the time shown."""
        if restarted:
            self._timeline_end = 0.0
        self._timeline_end = max(self._timeline_end, t)
        low, high, value = timeline_window(t, t_first, self._timeline_end)
        handle = self.timeline

        def write() -> None:
            if (handle.min, handle.max) != (low, high):
                handle.min, handle.max = low, high
            if handle.value != value:
                handle.value = value

        self._quiet(write)

    def show_status(self, text: str) -> None:
        if text != self._status_text:
            self._status_text = text
            quietly(lambda: setattr(self.status, "content", text), "updating the status line")

    # ------------------------------------------------------------------ equations
    def refresh_equations(self) -> None:
        """The Equations tab never shows another method's system: once shown, it follows the method in force."""
        p = self.port.setup
        if self._equations_key is not None and self._equations_key != (p.method, p.n, p.pinned):
            self.show_equations()

    def reset_to_preset(self) -> None:
        """The preset's own values again (picking the preset already shown in the menu fires no event)."""
        p = self.port.setup
        self.port.set_mechanism(p.preset, links=p.n if p.preset == "chain" else None)

    def show_equations(self) -> None:
        """Render the current system's equations in a worker thread (sympy is imported there, never at start)."""
        from . import equations  # noqa: PLC0415 - imports sympy: only when asked for

        p = self.port.setup
        method, chain = p.method, p.chain
        key = (method, p.n, p.pinned)  # a chain's equations depend on its bar count and closure only
        self._equations_key = key
        self.equations.content = (f"<p><b>Deriving</b> the {method_label(method)} equations for {p.n} bars (the "
                                  f"first time for this chain and method: a few seconds)...</p>")
        if self._equations_job is not None and self._equations_job.is_alive():
            return  # the running job sees the new key when it finishes and derives again

        def work() -> None:
            try:
                html = equations.equations_html(chain, method)
            except Exception as error:  # shown in the panel; the session goes on
                html = f"<p>Could not render the equations: {html_literal(f'{type(error).__name__}: {error}')}</p>"
            if self._equations_key == key:
                if not self.port.closed:  # the session (and its panel) may have gone while deriving
                    quietly(lambda: setattr(self.equations, "content", html), "showing the equations")
            elif self._equations_key is not None and not self.port.closed:
                self._equations_job = None
                self.show_equations()  # the method changed while deriving: show the one in force

        self._equations_job = threading.Thread(target=work, name="equations", daemon=True)
        self._equations_job.start()

    # ------------------------------------------------------------------ lifetime
    def close(self) -> None:
        """Stop pending typed values (the session is closing)."""
        self.numbers.close()

    def remove(self) -> None:
        self.close()
        # every control made outside the tabs too: one left behind after a switch to a mechanism session acted
        # on this closed session (found by tests/app/test_every_control.py)
        for handle in [self.status, self.transport, self.timeline, self.camera_view, self.plot_choice,
                       self.phase_image, self.tabs]:
            quietly(handle.remove, "removing a control")
        for plot in (self.energy_plot, self.drift_plot, self.constraint_plot, self.divergence_plot, self.angle_plot):
            if plot is not None:
                plot.remove()
