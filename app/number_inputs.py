"""Each number of the panel as a slider paired with a box for typed values, both showing the value in force.

Why a box of our own: viser's slider has a number box beside it, but the browser parses what is typed there
(Mantine drops the exponent: ``1e-3`` arrives as ``-13``, ``1e6`` as ``16``) before the server sees it. The
paired box is a plain text box (``gui.add_text``): the server receives exactly what was typed and
:mod:`app.commands` parses it and lets the models check it. The text box sends every keystroke, so a value is
applied once typing has paused for :data:`TYPING_PAUSE_S`; afterwards slider and box show the value in force,
whether the typed one was applied or refused (with a notice naming the field and its range).

Slider ranges come from the model fields' bounds (``Field(ge=..., le=...)``) intersected with a range that is
useful on a slider (:class:`SliderSpec`); a value in force outside that range widens the slider to show it.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import Any, Callable, Protocol

from .commands import QUANTITIES, Quantity, split_name
from .logs import quietly

TYPING_PAUSE_S = 0.6  # seconds without a keystroke before a typed value is applied


class NumbersPort(Protocol):
    """What the numbers of a panel ask of their session (app/session.py's, for the Display tab's numbers
    built by app/panel_rows.py): a narrow interface, so that the numbers never reach into the player or scene."""

    @property
    def closed(self) -> bool: ...

    def guard(self, action: Callable[[], object]) -> object: ...

    def set(self, name: str, value: object) -> None: ...

    def set_typed(self, name: str, text: str) -> None: ...


@dataclass(frozen=True)
class SliderSpec:
    """A slider for one quantity (by its command-layer key): the useful range on screen (control units),
    clipped to the model's bounds."""

    key: str
    ui_min: float
    ui_max: float
    step: float

    @property
    def quantity(self) -> Quantity:
        return QUANTITIES[self.key]

    @property
    def model(self) -> Any:
        return self.quantity.model

    @property
    def field(self) -> str:
        return self.quantity.field

    @property
    def label(self) -> str:
        """The slider's label with the unit: ``mass m (kg)``."""
        q = self.quantity
        return f"{q.label} ({q.unit})" if q.unit else q.label

    def bounds(self) -> tuple[float, bool, float, bool]:
        """``(lo, lo_open, hi, hi_open)`` in control units from the model field's metadata."""
        lo, lo_open, hi, hi_open = self.quantity.bounds()
        scale = self.quantity.scale
        return lo * scale, lo_open, hi * scale, hi_open

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
        return self.model.model_fields[self.field].description if self.model is not None else None


@dataclass
class NumberControl:
    """One number's slider and typed box; ``to_slider`` maps the SI value to the slider's scale."""

    name: str  # the command-layer name (L2, g, rtol, ...)
    slider: Any  # viser's GuiSliderHandle
    box: Any  # viser's GuiTextHandle
    to_slider: Callable[[float], float]
    timer: threading.Timer | None = None


def shown(name: str, value_si: float) -> str:
    """The box's text for a value in force, in the control's units (``0.001``, ``1e-09``, ``90``)."""
    q = QUANTITIES[split_name(name)[0]]
    return f"{value_si * q.scale:.6g}"


class NumberInputs:
    """The numbers of one panel. ``mute(action)`` runs a write-back without running callbacks and ``muted()``
    tells whether one is under way; ``bind(handle, action)`` attaches a callback inside the session's error
    boundary; ``value_of(name)`` is the SI value in force."""

    def __init__(self, gui, port: NumbersPort, bind: Callable, mute: Callable, muted: Callable[[], bool],
                 value_of: Callable[[str], float]) -> None:
        self.gui = gui
        self.port = port
        self._value_of = value_of
        self._bind = bind
        self._mute = mute
        self._muted = muted
        self.controls: dict[str, NumberControl] = {}
        self._lock = threading.Lock()
        self.commits = 0  # typed values applied or refused so far (tests wait for the next one)

    def add(self, name: str, spec: SliderSpec, value_si: float, *, label: str | None = None,
            to_slider: Callable[[float], float] | None = None, from_slider: Callable[[float], float] | None = None,
            max_value: float | None = None, slider_range: tuple[float, float] | None = None,
            disabled: bool = False, hint: str | None = None) -> NumberControl:
        """A slider and its typed box for ``name``; the slider sends ``from_slider(position)`` in SI units."""
        scale = spec.quantity.scale
        to_slider = to_slider or (lambda v: v * scale)
        from_slider = from_slider or (lambda x: x / scale)
        position = to_slider(value_si)
        low, high = slider_range or spec.range(position)
        if max_value is not None:
            high = max(min(high, max_value), low + spec.step)
        slider = self.gui.add_slider(
            label or spec.label, min=low, max=high, step=spec.step, initial_value=min(max(position, low), high),
            hint=hint or spec.hint, disabled=disabled,
        )
        q = spec.quantity
        box = self.gui.add_text(
            f"type {name}" + (f" ({q.unit})" if q.unit else ""), initial_value=shown(name, value_si),
            disabled=disabled, hint=f"Type a value for {name} (e.g. 1.5 or 1e-3); applied when you stop typing",
        )
        control = NumberControl(name, slider, box, to_slider)
        self.controls[name] = control
        self._bind(slider, lambda value, event: self.port.set(name, from_slider(value)))
        box.on_update(lambda event: None if self._muted() else self._typed(control))
        return control

    def _typed(self, control: NumberControl) -> None:
        """A keystroke in a box: (re)start the pause timer; the value is applied when typing stops."""
        text = control.box.value

        def commit() -> None:
            if self.port.closed or self.controls.get(control.name) is not control:
                return
            self.port.guard(lambda: self.port.set_typed(control.name, text))
            self.sync(control.name)  # the box shows the value in force, applied or not
            with self._lock:
                self.commits += 1

        with self._lock:
            if control.timer is not None:
                control.timer.cancel()
            control.timer = threading.Timer(TYPING_PAUSE_S, commit)
            control.timer.daemon = True
            control.timer.start()

    def typing(self) -> bool:
        """True while a typed value waits for its pause (tests wait for this to end)."""
        with self._lock:
            return any(c.timer is not None and c.timer.is_alive() for c in self.controls.values())

    def sync(self, name: str, value_si: float | None = None) -> None:
        """Write the value in force into slider and box (widening the slider when it lies outside)."""
        control = self.controls.get(name)
        if control is None:
            return
        if value_si is None:
            value_si = self._value_of(name)
        position = control.to_slider(value_si)
        slider = control.slider

        def write() -> None:
            if position > slider.max:
                slider.max = position
            if position < slider.min:
                slider.min = position
            slider.value = position
            control.box.value = shown(name, value_si)

        self._mute(write)

    def sync_all(self) -> None:
        for name in list(self.controls):
            self.sync(name)

    def remove(self, names) -> None:
        for name in list(names):
            control = self.controls.pop(name, None)
            if control is None:
                continue
            if control.timer is not None:
                control.timer.cancel()
            quietly(control.slider.remove, "removing a slider")
            quietly(control.box.remove, "removing a text box")

    def close(self) -> None:
        with self._lock:
            for control in self.controls.values():
                if control.timer is not None:
                    control.timer.cancel()

