"""The rows every linkage's panel has, a chain's and any mechanism's, in functions of their own.

The one session (:class:`app.session.Session`) builds these rows with the functions here, so
the panel's module stays about what changes with the model, and each row is tested on its own:

* the **View** button group beside Playback (Front / 3D; the page's F key presses it, static/page.html);
* the **Plot** menu (energy and its error, coordinates over time, a phase portrait) and which plot it shows;
* the relative energy error plot and a constraint residual plot (log scales);
* the Display tab's playback speed, trace length and arrow scale (slider and typed box each,
  :mod:`app.number_inputs`, so typed numbers are read as in every other box);
* the Export tab's buttons, among them "Save HTML replay".

A panel hands over what it needs as a :class:`RowsPort` and a ``bind(handle, action)`` that runs
``action(value, event)`` inside its error boundary (:func:`guarded_bind`). The timeline slider's window
(:func:`timeline_window`) is here too.
"""

from __future__ import annotations

import math
import threading
from typing import Any, Callable, Protocol

import numpy as np

from physics import LinkageError

from .number_inputs import SliderSpec
from .overlays import RESIDUAL_COLOR, Plot
from .parameters import Display
from .phase_view import phase_picture

TIMELINE_STEP = 0.05  # s: three samples; the slider's ends read as round numbers
TIMELINE_MIN_SPAN = 1.0  # s: the slider's range before the run has gone that far

VIEWS = ("Front", "3D")
VIEW_HINT = "Front: the plane of the motion as a drawing. 3D: from above"
PLOT_KINDS = ("energy", "angles", "phase")  # what a Plot menu's choices show, in its order ("angles": the
# coordinates a start is set by, over time: a chain's bar angles, a mechanism's free coordinates)
CHAIN_PLOT_CHOICES = ("Energy", "Angles θ(t)", "Phase portrait (θ, ω)")
MECHANISM_PLOT_CHOICES = ("Energy", "Coordinates over time", "Phase portrait")
SPEED_SLIDER = SliderSpec("speed", 0.1, 4.0, 0.05)
TRACE_SLIDER = SliderSpec("trace_seconds", 0.0, 20.0, 0.5)
ARROW_SLIDER = SliderSpec("arrow_scale", 0.05, 3.0, 0.05)
DRIFT_TITLE = "Relative energy error since last change"
EXPORT_TITLES = {"csv": "Download CSV", "json": "Download JSON", "html": "Save HTML replay"}
EXPORT_NOTE = ("Exports hold the run up to the displayed time (at most the last two minutes, 60 samples per "
               "second). The replay plays without the server.")

Bind = Callable[[Any, Callable[[Any, Any], None]], None]


class RowsPort(Protocol):
    """What these rows ask of a session."""

    def set_camera_view(self, view: str) -> None:
        """``"front"`` or ``"3d"``."""

    def refresh_plots(self) -> None:
        """Redraw the chosen plot now (a paused player draws no new frame)."""

    def download(self, kind: str, client: object | None) -> None:
        """Send the run (``csv``, ``json``, ``html``) to a browser."""


def guarded_bind(guard: Callable[[Callable[[], object]], object], muted: Callable[[], bool]) -> Bind:
    """A ``bind`` for a panel without one of its own: ``action(value, event)`` inside ``guard`` (the session's
    error boundary), never while ``muted()`` (the panel is writing the values in force back)."""

    def bind(handle, action) -> None:
        def callback(event) -> None:
            if muted():
                return
            value = handle.value
            guard(lambda: action(value, event))

        if hasattr(handle, "on_click") and not hasattr(handle, "on_update"):
            handle.on_click(callback)
        else:
            handle.on_update(callback)

    return bind


class Muting:
    """A per-thread switch that keeps a panel's own callbacks quiet while it writes values back (viser calls
    ``on_update`` for a value the server sets too)."""

    def __init__(self) -> None:
        self._local = threading.local()

    def muted(self) -> bool:
        return getattr(self._local, "on", False)

    def quiet(self, action: Callable[[], object]) -> None:
        self._local.on = True
        try:
            action()
        finally:
            self._local.on = False


def view_of(label: object) -> str:
    """The camera view a View button names (``"front"`` or ``"3d"``); LinkageError for anything else."""
    if not isinstance(label, str) or label not in VIEWS:
        raise LinkageError(f"view = {label!r}: allowed {', '.join(VIEWS)}")
    return "front" if label == "Front" else "3d"


def add_view_row(gui, bind: Bind, port: RowsPort):
    """The View button group (beside Playback, not in a tab: a lecturer switches views often)."""
    handle = gui.add_button_group("View", VIEWS, hint=VIEW_HINT)
    bind(handle, lambda value, event: port.set_camera_view(view_of(value)))
    return handle


def add_plot_menu(gui, bind: Bind, choices: tuple[str, ...], choose: Callable[[object], None], hint: str):
    """The Plot menu: ``choices`` name :data:`PLOT_KINDS` in order; ``choose(label)`` shows the one chosen."""
    handle = gui.add_dropdown("Plot", choices, initial_value=choices[0], hint=hint)
    bind(handle, lambda value, event: choose(value))
    return handle


def plot_kind(choices: tuple[str, ...], label: object) -> str:
    """The kind (:data:`PLOT_KINDS`) a Plot menu's label names; LinkageError for a label it does not offer."""
    if not isinstance(label, str) or label not in choices:
        raise LinkageError(f"plot = {label!r}: allowed {', '.join(choices)}")
    return PLOT_KINDS[choices.index(label)]


def add_phase_image(gui):
    """The phase portrait's picture (hidden until chosen)."""
    return gui.add_image(phase_picture(np.zeros((0, 1)), np.zeros((0, 1))), format="png", visible=False)


def add_drift_plot(gui) -> Plot:
    """The relative energy error since the last change, on a log scale."""
    return Plot(gui, DRIFT_TITLE, ["|E - E0| / E0"], [(148, 103, 189)], log=True, height=130)


def add_residual_plot(gui, title: str, label: str, y_label: str) -> Plot:
    """How far the loops are from closed, on a log scale (a chain's tip from its pin, a mechanism's residual)."""
    return Plot(gui, title, [label], [RESIDUAL_COLOR], log=True, height=130, y_label=y_label)


def show_plot(kind: str, energy: list[Plot], coordinates: Plot | None, phase_image) -> None:
    """Show the plots of ``kind`` and hide the others (``energy``: the energy plot and its error)."""
    for plot in energy:
        plot.set_visible(kind == "energy")
    if coordinates is not None:
        coordinates.set_visible(kind == "angles")
    if phase_image.visible != (kind == "phase"):
        phase_image.visible = kind == "phase"


def add_motion_numbers(add: Callable[..., Any], display: Display) -> None:
    """The Display tab's playback speed and trace length (``add``: :meth:`app.number_inputs.NumberInputs.add`)."""
    add("speed", SPEED_SLIDER, display.speed)
    add("trace_seconds", TRACE_SLIDER, display.trace_seconds, label="Trace length (s)")


def add_arrow_number(add: Callable[..., Any], display: Display) -> None:
    """The Display tab's arrow scale (after the reaction arrows' checkbox)."""
    add("arrow_scale", ARROW_SLIDER, display.arrow_scale)


def add_export_button(gui, bind: Bind, port: RowsPort, kind: str):
    """One Export button: the run as ``kind`` (:data:`EXPORT_TITLES`) to the browser that pressed it."""
    button = gui.add_button(EXPORT_TITLES[kind])
    bind(button, lambda value, event: port.download(kind, getattr(event, "client", None)))
    return button


def timeline_window(t: float, t_first: float, t_end: float) -> tuple[float, float, float]:
    """The timeline slider's ``(min, max, value)``: the run so far, from the oldest sample the rings still hold
    (``t_first``) to the latest shown (``t_end``), in round steps, with its thumb at the time shown ``t`` (chains
    and mechanisms alike)."""
    low = round(max(0.0, math.ceil(t_first / TIMELINE_STEP - 1e-9) * TIMELINE_STEP), 2)
    high = round(max(math.ceil(t_end / TIMELINE_STEP - 1e-9) * TIMELINE_STEP, low + TIMELINE_MIN_SPAN), 2)
    value = min(max(round(round(t / TIMELINE_STEP) * TIMELINE_STEP, 2), low), high)
    return low, high, value
