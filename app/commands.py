"""The command layer: one named edit of a session's ``(Chain, Settings, start)``, validated by the models.

Why one layer: a slider, a typed box, ``python -m app snapshot --set`` and a test all change a value the same
way, by the name ``python -m physics --set`` uses (``L2``, ``m3``, ``theta1``, ``g``; see
``physics.model.parameter_names``) or the settings field's own name (``method``, ``rtol``, ``step``, ...).
:func:`apply` builds the changed model with ``model_validate`` (the pydantic models own every bound), then
:meth:`SessionParameters.replaced` checks the models together (method available, loop closed). A refusal is a
``LinkageError`` whose text names the field, the value as typed and the allowed range in the control's units.

Values arrive in SI units (radians, seconds) unless ``units=CONTROL``: then angles are in degrees and the
fixed step in milliseconds, as the panel shows them. Text is parsed here (``1e-3`` is a number), never by
the browser.
"""

from __future__ import annotations

import math
import re
import typing
from dataclasses import dataclass

import annotated_types
import numpy as np
from pydantic import BaseModel, ValidationError

from physics import Bar, Chain, LinkageError, Settings, TracePoint, loop_closure
from physics.model import MAX_LINKS, PARAMETER_FIELDS, check_mass_matrix

from .parameters import Display, SessionParameters, driving_count, settings_data

SI = "si"
CONTROL = "control"
MAX_TEXT = 64  # characters of a typed number; anything longer is not a number anyone typed
PER_BAR_STATE = ("theta", "omega")  # with PARAMETER_FIELDS: the per-bar names of ``--set`` (L2, theta1, ...)
_PER_BAR = re.compile(rf"({'|'.join((*PARAMETER_FIELDS, *PER_BAR_STATE))})([1-9][0-9]?)")


@dataclass(frozen=True)
class Quantity:
    """A number the user can set: where its bounds live (``model.field``), its unit on the panel."""

    label: str
    unit: str
    model: type[BaseModel] | None  # None: any finite number (angles, pin position)
    field: str
    scale: float = 1.0  # control units per SI unit (degrees per radian, milliseconds per second)
    per_bar: bool = False

    def bounds(self) -> tuple[float, bool, float, bool]:
        """``(lo, lo_open, hi, hi_open)`` in SI from the model field's metadata (``-inf``/``inf`` if none)."""
        lo, lo_open, hi, hi_open = -math.inf, False, math.inf, False
        if self.model is None:
            return lo, lo_open, hi, hi_open
        for item in self.model.model_fields[self.field].metadata:
            if isinstance(item, annotated_types.Ge):
                lo, lo_open = _number(item.ge), False
            elif isinstance(item, annotated_types.Gt):
                lo, lo_open = _number(item.gt), True
            elif isinstance(item, annotated_types.Le):
                hi, hi_open = _number(item.le), False
            elif isinstance(item, annotated_types.Lt):
                hi, hi_open = _number(item.lt), True
        return lo, lo_open, hi, hi_open

    def shown(self, value_si: float) -> str:
        """A value in the control's units, with the unit: ``90 °``, ``1 ms``, ``0.001 kg·m²``."""
        text = f"{value_si * self.scale:.6g}"
        if self.unit.startswith("°"):
            return f"{text}{self.unit}"
        return f"{text} {self.unit}" if self.unit else text


def _number(bound: object) -> float:
    return float(bound)  # type: ignore[arg-type]  # the models' bounds are numbers


DEG = 180.0 / math.pi
QUANTITIES: dict[str, Quantity] = {
    "L": Quantity("length L", "m", Bar, "L", per_bar=True),
    "d": Quantity("centre of mass d", "m", Bar, "d", per_bar=True),
    "m": Quantity("mass m", "kg", Bar, "m", per_bar=True),
    "I": Quantity("inertia I", "kg·m²", Bar, "I", per_bar=True),
    "theta": Quantity("initial angle theta", "°", None, "theta0", scale=DEG, per_bar=True),
    "omega": Quantity("initial angular velocity omega", "°/s", None, "omega0", scale=DEG, per_bar=True),
    "g": Quantity("gravity g", "m/s²", Chain, "g"),
    "pin_x": Quantity("pin x", "m", None, "pin"),
    "pin_y": Quantity("pin y", "m", None, "pin"),
    "rtol": Quantity("tolerance rtol = atol", "", Settings, "rtol"),
    "step": Quantity("fixed step", "ms", Settings, "step", scale=1e3),
    "baumgarte_alpha": Quantity("Baumgarte alpha", "1/s", Settings, "baumgarte_alpha"),
    "baumgarte_beta": Quantity("Baumgarte beta", "1/s", Settings, "baumgarte_beta"),
    "damping": Quantity("joint damping", "N·m·s", Settings, "damping"),
    "speed": Quantity("playback speed", "×", Display, "speed"),
    "trace_seconds": Quantity("trace length", "s", Display, "trace_seconds"),
    "arrow_scale": Quantity("arrow scale", "", Display, "arrow_scale"),
}
LINKS = Quantity("number of bars", "", None, "links")
TIMELINE = Quantity("timeline", "s", None, "timeline")  # a time of the run so far (Session.scrub)  # a whole number; choosing it loads the chain preset
assert set(PARAMETER_FIELDS) <= set(QUANTITIES), "every --set field of the CLI has its quantity here"
CHOICES = ("method", "integrator", "stabilization", "trace")
DISPLAY_NAMES = tuple(name for name, q in QUANTITIES.items() if q.model is Display)


@dataclass(frozen=True)
class Edit:
    """The result of an edit: the new parameters and what the session must do with them."""

    params: SessionParameters
    restart: bool  # start again at t = 0 (a new start); otherwise go on from the displayed state
    geometry: bool  # lengths or pin changed: resize the scene and reframe the camera


# ------------------------------------------------------------------------------------------ names
def split_name(name: str) -> tuple[str, int | None]:
    """``"L2"`` -> ``("L", 2)``; ``"g"`` -> ``("g", None)``: the quantity's key and the bar (1-based)."""
    match = _PER_BAR.fullmatch(name) if isinstance(name, str) else None
    if match:
        return match.group(1), int(match.group(2))
    return name, None


def quantity(name: str) -> tuple[Quantity, int | None]:
    """The quantity a name stands for and its bar (1-based) if it is per bar; LinkageError if unknown."""
    key, k = split_name(name)
    if k is not None:
        return QUANTITIES[key], k
    q = QUANTITIES.get(name) if isinstance(name, str) else None
    if q is None or q.per_bar:
        raise LinkageError(f"unknown parameter {name!r}; allowed: {allowed_names()}")
    return q, None


def allowed_names(n: int | None = None) -> str:
    bars = f"1..{n}" if n else "1.."
    per_bar = ", ".join(f"{f}{bars}" for f in (*PARAMETER_FIELDS, *PER_BAR_STATE))
    single = [name for name, q in QUANTITIES.items() if not q.per_bar]
    return ", ".join([per_bar, *single, *CHOICES])


# ------------------------------------------------------------------------------------------ numbers
def parse_links(value) -> int:
    """The number of bars of a chain from a number or a typed text: a whole number 1..MAX_LINKS, else a
    LinkageError naming the field, what was given and the allowed range (the app's box, a share link)."""
    number = parse_number("links", LINKS, value)
    if not (number == int(number) and 1 <= number <= MAX_LINKS):
        raise LinkageError(f"links = {shown_value(value)}: allowed whole numbers 1 <= links <= {MAX_LINKS}")
    return int(number)


def parse_number(name: str, q: Quantity, value, units: str = SI) -> float:
    """A finite float in SI from a number or a typed text (``1e-3``, `` 2.5 ``, ``−1`` with a minus sign);
    LinkageError naming the field and what was typed otherwise (:func:`read_number`)."""
    number = read_number(name, q.unit if units == CONTROL else "", value)
    return number / q.scale if units == CONTROL else number


def read_number(field: str, unit: str, value: object) -> float:
    """What was typed (or sent) for ``field``, read as Python reads a number: ``2.5e1`` is 25, ``1e-3``,
    ``-0``, ``1_000`` and a typographic minus are numbers as written (never the browser's number box, which
    drops an exponent: 2.51), and ``1,5`` is no number (a decimal comma is refused, not read as 15). The one
    reader of every panel's typed boxes, chains' and mechanisms' alike, so that they read and refuse the same
    way; ``unit`` (the control's, or empty) goes into the refusal. LinkageError naming ``field`` otherwise."""
    example = f"type a number{f' in {unit}' if unit else ''}, e.g. 1.5 or 1e-3"
    if isinstance(value, str):
        text = value.strip().replace("\u2212", "-")
        if not text:
            raise LinkageError(f"{field}: the box is empty; {example}")
        if len(text) > MAX_TEXT:
            raise LinkageError(f"{field}: {len(text)} characters is not a number; {example}")
        try:
            number = float(text)
        except ValueError:
            raise LinkageError(f"{field} = {text!r}: not a number; {example}") from None
        shown = text
    elif isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool):
        try:
            number = float(value)
        except OverflowError:  # an integer beyond any float (10**400)
            number = math.inf
        shown = shown_value(value)
    else:
        raise LinkageError(f"{field} = {shown_value(value)}: not a number; {example}")
    if not math.isfinite(number):
        raise LinkageError(f"{field} = {shown}: must be a finite number")
    return number


def allowed_range(low: float, high: float, low_open: bool = False, high_open: bool = False) -> str:
    """The words of every panel's range refusal, a chain's box and a mechanism's alike (``0 to 1000``; with an
    open bound ``above 0 up to 1000``; a missing one ``0 or more`` / ``up to 1000``), in the control's units."""
    has_low, has_high = math.isfinite(low), math.isfinite(high)
    low_words = f"above {low:g}" if low_open else f"{low:g}"
    high_words = f"below {high:g}" if high_open else f"{high:g}"
    if has_low and has_high:
        if not (low_open or high_open):
            return f"{low:g} to {high:g}"
        return f"{'above' if low_open else 'from'} {low:g} {'and below' if high_open else 'up to'} {high:g}"
    if has_low:
        return low_words if low_open else f"{low_words} or more"
    if has_high:
        return high_words if high_open else f"up to {high_words}"
    return "any finite number"


def refused_range(label: str, value: float, allowed: str) -> LinkageError:
    """The one refusal of a value outside its range, every panel's: ``g (m/s²) = 2000: allowed range 0 to 1000``
    (``label`` with its unit in brackets, the value and the range in that unit)."""
    return LinkageError(f"{label} = {value:g}: allowed range {allowed}")


def control_label(name: str, q: Quantity) -> str:
    """A chain control as its refusals name it: the field and its unit in brackets (``g (m/s²)``, ``rtol``)."""
    return f"{name} ({q.unit})" if q.unit else name


def range_text(q: Quantity, params: SessionParameters | None = None, k: int | None = None) -> str:
    """The allowed range of ``q`` in the control's units (:func:`allowed_range`): ``0 to 1.5`` for ``d2`` on
    a bar 1.5 m long, ``above 0 up to 1000`` for the step in ms."""
    lo, lo_open, hi, hi_open = q.bounds()
    if q.field == "d" and params is not None and k is not None:
        hi, hi_open = params.L[k - 1], False
    return allowed_range(lo * q.scale, hi * q.scale, lo_open, hi_open)


def _refusal(name: str, q: Quantity, number: float, error: ValidationError, params, k) -> LinkageError:
    """One line: the field, the value in the control's units, and the range (or the model's own reason)."""
    reasons = []
    for item in error.errors():
        reason = str(item.get("msg", "invalid")).removeprefix("Value error, ")
        reason = re.sub(rf"^{re.escape(name)} = [^:]*: ", "", reason)  # the model named the field already
        out_of_range = item.get("type", "").startswith(("greater_than", "less_than")) or "allowed range" in reason
        reasons.append(None if out_of_range else reason)
    if None in reasons:
        return refused_range(control_label(name, q), number * q.scale, range_text(q, params, k))
    return LinkageError(f"{name} = {q.shown(number)}: " + "; ".join(dict.fromkeys(r for r in reasons if r)))


def _degrees_in_turn(radians: float) -> float:
    """An angle in degrees, within one turn [0, 360)."""
    return math.degrees(radians) % 360.0


def _in_degrees(text: str) -> str:
    """physics.loop_closure speaks radians; the panel's angles are degrees: one unit in one message, angles within
    one turn (a range that passes 360 reads "300.0° round to 6.0°"), and the loop's reason without repeating
    "the loop cannot close"."""
    text = re.sub(r"(theta\d+)=(-?[\d.]+(?:e-?\d+)?)",
                  lambda m: f"{m.group(1)} = {_degrees_in_turn(float(m.group(2))):.1f}°", text)
    text = re.sub(r"^the loop cannot close at theta\d+ = [\d.]+°: ", "", text)

    def reachable(match: re.Match) -> str:
        low, high = float(match.group(2)), float(match.group(3))
        start, end = _degrees_in_turn(low), _degrees_in_turn(high)
        if high - low >= 2 * math.pi - 1e-9:
            return f"reachable {match.group(1)}: every angle"
        joined = "to" if start < end else "round to"
        return f"reachable {match.group(1)}: {start:.1f}° {joined} {end:.1f}°"

    return re.sub(r"allowed (theta\d+): \[(-?[\d.]+(?:e-?\d+)?), (-?[\d.]+(?:e-?\d+)?)\]", reachable, text)


def _rebuilt(model: BaseModel, update: dict, name: str, q: Quantity, number: float, params=None, k=None):
    """``model`` with ``update``, validated again by its class (pydantic's ``model_copy`` does not validate)."""
    data = settings_data(model) if isinstance(model, Settings) else dict(model)
    try:
        return type(model).model_validate({**data, **update})
    except ValidationError as error:
        raise _refusal(name, q, number, error, params, k) from None


# ------------------------------------------------------------------------------------------ edits
def apply(params: SessionParameters, name: str, value, units: str = SI) -> Edit:
    """Apply one edit by name; LinkageError (nothing changed) when the models refuse it. Its text always names
    the field: a reason found further in (a singular mass matrix, an open loop) is prefixed with it."""
    try:
        return _apply(params, name, value, units)
    except (ArithmeticError, np.linalg.LinAlgError) as error:  # inside the bounds, beyond what floats can hold
        raise LinkageError(f"{name} = {value!r}: too extreme to compute with ({type(error).__name__}: {error})") from None
    except LinkageError as error:
        text = str(error)
        if not isinstance(name, str) or re.search(rf"\b{re.escape(name)}\b", text):
            raise  # already names the field (or the name itself was refused)
        shown = str(value)[:MAX_TEXT] if isinstance(value, str) else repr(value)
        raise LinkageError(f"{name} = {shown}: {text}") from None


def _apply(params: SessionParameters, name: str, value, units: str) -> Edit:
    if isinstance(name, str) and name in CHOICES:
        return _apply_choice(params, name, value)
    q, k = quantity(name)
    if q.model is Display:
        raise LinkageError(f"{name}: a display setting, not a parameter of the simulation")
    number = parse_number(name, q, value, units)
    if k is not None and not 1 <= k <= params.n:
        raise LinkageError(f"{name}: this mechanism has bars 1..{params.n}")
    if q.model is Bar and k is not None:
        return _apply_bar(params, name, q, k, number)
    if q.field in ("theta0", "omega0") and k is not None:
        return _apply_start(params, name, q, k, number)
    if name == "g":
        chain = _rebuilt(params.chain, {"g": number}, name, q, number)
        return Edit(params.replaced(chain=chain), restart=False, geometry=False)
    if q.field == "pin":
        return _apply_pin(params, name, q, number)
    update = {"rtol": number, "atol": number} if name == "rtol" else {name: number}
    settings = _rebuilt(params.settings, update, name, q, number)
    return Edit(params.replaced(settings=settings), restart=False, geometry=False)


def apply_display(display: Display, name: str, value, units: str = SI) -> Display:
    """A display setting changed by name (``speed``, ``trace_seconds``, ``arrow_scale``)."""
    q, _ = quantity(name)
    if q.model is not Display:
        raise LinkageError(f"{name}: not a display setting; allowed: {', '.join(DISPLAY_NAMES)}")
    number = parse_number(name, q, value, units)
    return _rebuilt(display, {name: number}, name, q, number)


def _apply_bar(params: SessionParameters, name: str, q: Quantity, k: int, number: float) -> Edit:
    field = q.field
    bar = params.chain.bars[k - 1]
    update = {field: number}
    if field == "L":
        update["d"] = min(bar.d, number)  # the centre of mass stays on the bar
    new_bar = _rebuilt(bar, update, name, q, number, params, k)
    bars = list(params.chain.bars)
    bars[k - 1] = new_bar
    chain = params.chain.model_copy(update={"bars": bars})  # bars validated one by one above
    check_mass_matrix(chain)
    updates: dict = {"chain": chain}
    if field == "L" and params.pinned:
        count = driving_count(params.n, True)
        updates["theta0"] = params.assembled(params.theta0[:count], theta_prev=params.theta0, L=chain.array("L"))
    trace = params.trace
    old = getattr(bar, field)
    if trace.bar == k and field in ("L", "d") and trace.along == old or (
        trace.bar == k and field == "L" and trace.along > number
    ):  # the end of a bar (tip, joint) or its centre of mass stays what is traced
        point = TracePoint(bar=k, along=number, across=trace.across)
        updates["settings"] = params.settings.model_copy(update={"trace": point})
    return Edit(params.replaced(**updates), restart=False, geometry=field == "L")


def _apply_pin(params: SessionParameters, name: str, q: Quantity, number: float) -> Edit:
    old = params.pin
    if old is None:
        raise LinkageError(f"{name}: this mechanism is an open chain (no pinned tip)")
    pin = (number, old[1]) if name == "pin_x" else (old[0], number)
    chain = Chain.model_validate({**dict(params.chain), "pin": pin})
    count = driving_count(params.n, True)
    try:
        theta0 = params.assembled(params.theta0[:count], theta_prev=params.theta0, pin=pin)
    except LinkageError as error:
        raise LinkageError(f"{name} = {q.shown(number)}: the loop cannot close there ({error})") from None
    return Edit(params.replaced(chain=chain, theta0=theta0), restart=False, geometry=True)


def _apply_start(params: SessionParameters, name: str, q: Quantity, k: int, number: float) -> Edit:
    """Initial angle or angular velocity of bar ``k``. A closed loop takes only its driving angles and assembles
    the rest; an angle at which it cannot close is refused and the last valid start kept."""
    count = driving_count(params.n, params.pinned)
    if k > count:
        stem = name[: -len(str(k))]
        which = f"only {stem}1" if count == 1 else f"{stem}1..{stem}{count}"
        rest = " (the others are assembled so the loop closes)" if params.pinned else ""
        raise LinkageError(f"{name}: this mechanism takes {which}{rest}")
    theta0, omega0 = params.theta0.copy(), params.omega0.copy()
    if q.field == "theta0":
        theta0[k - 1] = number
        if params.pinned:
            try:
                theta0 = params.assembled(theta0[:count], theta_prev=params.theta0)
            except LinkageError as error:
                raise LinkageError(
                    f"{name} = {q.shown(number)}: the loop cannot close there ({_in_degrees(str(error))}); "
                    f"kept {name} = {q.shown(params.theta0[k - 1])}"
                ) from None
            try:
                omega0 = loop_closure.project_velocity(params.L, theta0, omega0)
            except LinkageError:  # a dead centre: start from rest rather than refuse the angle
                omega0 = np.zeros_like(omega0)
    else:
        omega0[k - 1] = number
        if params.pinned:
            omega0 = loop_closure.project_velocity(params.L, theta0, omega0[:count])
    return Edit(params.replaced(theta0=theta0, omega0=omega0), restart=True, geometry=False)


def _apply_choice(params: SessionParameters, name: str, value) -> Edit:
    if name == "trace":
        choices = params.trace_choices()
        if not isinstance(value, str) or value not in choices:
            raise LinkageError(f"traced point = {value!r}: allowed {', '.join(choices)}")
        settings = params.settings.model_copy(update={"trace": choices[value]})
        return Edit(params.replaced(settings=settings), restart=True, geometry=False)
    options = options_of(name)
    if not isinstance(value, str) or value not in options:
        raise LinkageError(f"{name} = {value!r}: allowed {', '.join(options)}")
    try:
        settings = Settings.model_validate({**settings_data(params.settings), name: value})
    except ValidationError as error:
        reasons = (str(item.get("msg", "invalid")).removeprefix("Value error, ") for item in error.errors())
        # a reason that names the field already is not prefixed twice
        reasons = (re.sub(rf"^{re.escape(name)} = [^:]*: ", "", reason) for reason in reasons)
        raise LinkageError(f"{name} = {value}: " + "; ".join(reasons)) from None
    return Edit(params.replaced(settings=settings), restart=False, geometry=False)


# ------------------------------------------------------------------------------------------ control values
def shown_value(value: object, limit: int = 80) -> str:
    """A value as a refusal quotes it: its repr, cut at ``limit`` characters (a hostile client's 10**400)."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 1] + "…"


def options_of(name: str) -> tuple[str, ...]:
    """The values a choice accepts, from the Settings field's ``Literal`` type."""
    return tuple(typing.get_args(Settings.model_fields[name].annotation))
