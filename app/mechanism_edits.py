"""The panel's values of a general mechanism, generated from its description, and edits through its models.

Every number of a mechanism session's panel is a :class:`Knob`: a name (``mass:crank``, ``size:coupler``,
``speed:O2``, ``ratio:mesh``, ``g``; the run's ``rtol`` and ``step``; a start's ``angle0:crank`` and
``omega0:crank``), a label with units, a range and the value in force. :func:`apply_edit` returns the edited
mechanism, validated again by ``physics.mechanism``'s pydantic models and assembled, or raises LinkageError
naming the body or joint, the field, the value and the allowed range; :func:`apply_setting` does the same for
the run's settings and :func:`start_knobs` / :func:`start_value` for the start (app/mechanism_start.py).
Typed text and sent values are read by the one reader of every panel (:func:`app.commands.read_number`). Plain data; no viser.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pydantic import ValidationError

from physics import LinkageError
from physics.mechanism import Body, Driver, Gear, Mechanism
from physics.mechanism.assembly import sketch_size
from physics.mechanism.description import MAX_INERTIA
from physics.mechanism.validation import MAX_COORDINATE, MIN_INERTIA, MIN_MASS, check_runnable
from physics.model import MAX_ANGULAR_SPEED, MECHANISM_MAX_TOLERANCE, MIN_RTOL

from .commands import allowed_range, read_number, refused_range
from .mechanism_runs import MechanismSettings
from .mechanism_start import FreeCoordinate


@dataclass(frozen=True)
class Knob:
    """One generated control: ``name`` (what :func:`apply_edit` takes), ``label`` (with units), its range."""

    name: str
    label: str
    low: float
    high: float
    step: float
    value: float
    hint: str
    geometry: bool  # changing it moves points: the run starts again from the re-assembled sketch
    log: bool = False  # its slider shows log10 of the value (a tolerance); its box the value itself
    # what a typed (or linked) value may take, where it is wider than the slider: the model's own bounds, as the
    # chain panel's boxes take them (a mass of 1000 kg, g = 1000 m/s²); the slider widens to show it
    typed: tuple[float, float] | None = None
    low_open: bool = False  # the lower bound itself is refused (a size, a step: above 0)
    follows: bool = False  # a value the model sets (a closed chain's assembled angles): shown greyed, not set

    @property
    def allowed(self) -> tuple[float, float]:
        """The range a value is checked against: ``typed`` where given, else the slider's."""
        return self.typed if self.typed is not None else (self.low, self.high)

    def check(self, number: float) -> float:
        """``number`` when inside :attr:`allowed`; LinkageError naming the control and the range otherwise."""
        low, high = self.allowed
        if not ((low < number) if self.low_open else (low <= number)) or not number <= high:
            raise refused_range(self.label, number, allowed_range(low, high, self.low_open))
        return number

    @property
    def unit(self) -> str:
        """The unit in the label's brackets (``m/s²``), or empty."""
        return self.label[self.label.rfind("(") + 1: -1] if self.label.endswith(")") else ""

    @property
    def slider_range(self) -> tuple[float, float]:
        return (math.log10(self.low), math.log10(self.high)) if self.log else (self.low, self.high)

    def slider_bounds(self, value: float | None = None) -> tuple[float, float]:
        """The slider's range, widened to show ``value`` (default: the value in force; a typed one may lie
        beyond the range a slider is useful over, as in the chain panel)."""
        low, high = self.slider_range
        shown = self._position(self.value if value is None else value)
        return min(low, shown), max(high, shown)

    def slider_value(self, value: float | None = None) -> float:
        """Where the slider's thumb stands for ``value`` (default: the value in force), inside its range."""
        low, high = self.slider_bounds(value)
        return min(max(self._position(self.value if value is None else value), low), high)

    def _position(self, value: float) -> float:
        if not math.isfinite(value):
            return self.slider_range[0]
        return math.log10(value) if self.log and value > 0 else (self.slider_range[0] if self.log else value)

    def from_slider(self, position: float) -> float:
        """The value a slider position means (a log slider's 10**position, kept a float the range refuses)."""
        if not self.log:
            return position
        return 10.0 ** min(max(position, -400.0), 300.0) if position == position else position


def body_size(body: Body) -> float:
    """A body's size: the largest distance between two of its points (a bar's length)."""
    points = np.array(list(body.points.values()), dtype=float).reshape(-1, 2)
    if len(points) < 2:
        return 0.0
    gaps = points[:, None, :] - points[None, :, :]
    return float(np.max(np.hypot(gaps[..., 0], gaps[..., 1])))


def _upper(model, field: str) -> float:
    """A pydantic model field's upper bound (``Field(le=...)``): how far a typed value may go, as the chain
    panel's boxes read theirs from the models (app.commands.Quantity.bounds)."""
    return next(float(item.le) for item in model.model_fields[field].metadata if getattr(item, "le", None) is not None)


def _step(value: float) -> float:
    """A slider step about a hundredth of ``value``: the power of ten at or below it."""
    if value <= 0 or not math.isfinite(value):
        return 0.01
    exponent = math.floor(math.log10(value / 100.0))
    return 10.0 ** exponent


# The largest size a body can have: every point of a sketch lies within MAX_COORDINATE of the origin in x and y
# (physics.mechanism.validation), so no two are further apart than the diagonal of that square.
MAX_SIZE = 2.0 * math.sqrt(2.0) * MAX_COORDINATE


def knobs(mechanism: Mechanism, reference: Mechanism | None = None) -> list[Knob]:
    """The controls of ``mechanism``: per body its size (bodies with two or more points), mass and inertia;
    per motor its speed (°/s) or torque (N·m); gravity. Ranges come from ``reference`` (the preset or file
    as loaded), so a slider's range does not move as it is dragged."""
    reference = reference or mechanism
    out: list[Knob] = []
    for body, ref in zip(mechanism.bodies, reference.bodies):
        # to 12 digits, as a person reads it: a size typed, then another, then the first again scales the points
        # twice, and their distance comes back within rounding (0.049999999999999996 for 0.05), not to the bit
        size, ref_size = float(f"{body_size(body):.12g}"), body_size(ref)
        if ref_size > 0:
            out.append(Knob(f"size:{body.name}", f"{body.name}: size (m)", round(0.25 * ref_size, 6),
                            round(3.0 * ref_size, 6), _step(ref_size), size,
                            "The largest distance between its points; the body is scaled about its first point "
                            "and the mechanism re-assembled (its inertia scales with the square)", True,
                            typed=(0.0, MAX_SIZE), low_open=True))
        mass_top = max(10.0 * ref.mass, 1.0)
        out.append(Knob(f"mass:{body.name}", f"{body.name}: m (kg)", MIN_MASS, mass_top, _step(mass_top / 10),
                        body.mass, "Mass of the body", False, typed=(MIN_MASS, _upper(Body, "mass"))))
        inertia_top = max(10.0 * ref.inertia, 1e-4)
        out.append(Knob(f"inertia:{body.name}", f"{body.name}: I (kg·m²)", MIN_INERTIA, inertia_top,
                        _step(inertia_top / 10), body.inertia, "Centroidal moment of inertia of the body", False,
                        typed=(MIN_INERTIA, _upper(Body, "inertia"))))
    for driver in mechanism.drivers:
        if driver.speed is not None:
            top = math.degrees(_upper(Driver, "speed"))
            out.append(Knob(f"speed:{driver.joint}", f"motor {driver.joint}: speed (°/s)", -720.0, 720.0, 5.0,
                            math.degrees(driver.speed), "Constant relative angular speed the motor holds", False,
                            typed=(-top, top)))
        else:
            torque = float(driver.torque or 0.0)
            top = max(10.0 * abs(torque), 1.0)
            out.append(Knob(f"torque:{driver.joint}", f"motor {driver.joint}: torque (N·m)", -top, top,
                            _step(top / 10), torque, "Constant torque the motor applies", False,
                            typed=(-_upper(Driver, "torque"), _upper(Driver, "torque"))))
    for joint, ref_joint in zip(mechanism.joints, reference.joints):
        if isinstance(joint, Gear):
            ref_ratio = ref_joint.ratio if isinstance(ref_joint, Gear) else joint.ratio
            top = max(4.0 * abs(ref_ratio), 4.0)
            out.append(Knob(f"ratio:{joint.name}", f"gear {joint.name}: ratio", -top, top, 0.01, joint.ratio,
                            f"Angle of joint {joint.joints[1]} per unit of joint {joint.joints[0]}'s (not 0); the "
                            "mechanism is re-assembled", True, typed=(-_upper(Gear, "ratio"), _upper(Gear, "ratio"))))
            out.append(Knob(f"offset:{joint.name}", f"gear {joint.name}: offset (°)", -180.0, 180.0, 0.5,
                            math.degrees(joint.offset), f"Angle of joint {joint.joints[1]} when joint "
                            f"{joint.joints[0]}'s is zero; the mechanism is re-assembled", True,
                            typed=(-math.degrees(_upper(Gear, "offset")), math.degrees(_upper(Gear, "offset")))))
    out.append(Knob("g", "g (m/s²)", 0.0, 30.0, 0.01, mechanism.g, "Gravitational acceleration, along -y", False,
                    typed=(0.0, _upper(Mechanism, "g"))))
    return out


TOLERANCE_RANGE = (MIN_RTOL, MECHANISM_MAX_TOLERANCE)  # rtol = atol: what a mechanism's run allows
STEP_RANGE_MS = (0.01, 100.0)  # the fixed step of midpoint and variational, in ms
BAUMGARTE_RANGE = (0.0, 50.0)  # 1/s: the chain panel's sliders


def settings_knobs(settings: MechanismSettings) -> list[Knob]:
    """The run's numbers, as the chain's Simulation tab has them: the tolerance (adaptive integrators; its
    slider in log10) and the fixed step in ms (midpoint, variational)."""
    return [
        Knob("rtol", "tolerance rtol = atol", *TOLERANCE_RANGE, 0.5, settings.rtol,
             "rtol = atol of the adaptive integrators; the slider is log10(rtol), the box rtol itself (e.g. 1e-9)",
             False, log=True),
        Knob("step", "fixed step (ms)", *STEP_RANGE_MS, 0.01, settings.step * 1e3,
             "The step of the fixed-step integrators (midpoint, variational)", False,
             typed=(0.0, _upper(MechanismSettings, "step") * 1e3), low_open=True),
        Knob("baumgarte_alpha", "Baumgarte alpha (1/s)", *BAUMGARTE_RANGE, 0.5, settings.baumgarte_alpha,
             "Damping gain of the Baumgarte terms (stabilisation baumgarte)", False,
             typed=(0.0, _upper(MechanismSettings, "baumgarte_alpha"))),
        Knob("baumgarte_beta", "Baumgarte beta (1/s)", *BAUMGARTE_RANGE, 0.5, settings.baumgarte_beta,
             "Stiffness gain of the Baumgarte terms (stabilisation baumgarte)", False,
             typed=(0.0, _upper(MechanismSettings, "baumgarte_beta"))),
    ]


def apply_setting(settings: MechanismSettings, name: str, value: object) -> MechanismSettings:
    """``settings`` with ``rtol``, ``step`` (ms), ``baumgarte_alpha`` or ``baumgarte_beta`` set to ``value``;
    LinkageError naming the range otherwise."""
    knobs_now = settings_knobs(settings)
    _, number = _in_range(knobs_now, name, value,
                          f"not a setting of the run (settings: {', '.join(k.name for k in knobs_now)})")
    return settings.model_copy(update={name: number / 1e3 if name == "step" else number})


def _in_range(knobs_now: list[Knob], name: str, value: object, unknown: str) -> tuple[Knob, float]:
    """The knob called ``name`` and ``value`` read as its number, within its range; LinkageError naming the
    knob and its range otherwise (``unknown``: what to say of a name that is none of them)."""
    knob = next((k for k in knobs_now if k.name == name), None)
    if knob is None:
        raise LinkageError(f"{name!r}: {unknown}")
    number = read_number(knob.label, knob.unit, value)
    knob.check(number)
    return knob, number


START_NAMES = {"angle": ("angle0", "start angle (°)", "omega0", "start angular speed (°/s)"),
               "x": ("x0", "start x (m)", "vx0", "start x speed (m/s)"),
               "y": ("y0", "start y (m)", "vy0", "start y speed (m/s)")}
START_TURN_SPEED = 720.0  # °/s: the chain's initial angular velocity sliders
# A start's turning speed takes, typed, what a chain's start takes (physics.model.MAX_ANGULAR_SPEED rad/s). Its
# angle and place keep their sliders' ranges: one turn (a place within the size) reaches every pose, and a new
# start is reached from the one in force in small sub-steps along its branch (app/mechanism_start.py), whose
# count grows with the distance (1e4 rad took two minutes of the session's lock).
START_TURN_TYPED = (-math.degrees(MAX_ANGULAR_SPEED), math.degrees(MAX_ANGULAR_SPEED))


def start_knobs(mechanism: Mechanism, free: tuple[FreeCoordinate, ...], sketch_q: np.ndarray, q0: np.ndarray,
                qdot0: np.ndarray) -> list[Knob]:
    """The start's controls, as the chain's angle and speed sliders: each free coordinate's value (a body's
    angle from its sketch in degrees, or its centre's x or y in m, around the assembled sketch ``sketch_q``)
    and its speed, from the start in force ``q0, qdot0``."""
    size = sketch_size(mechanism)
    values, speeds = [], []
    for coordinate in free:
        name, label, rate_name, rate_label = START_NAMES[coordinate.axis]
        k = coordinate.index
        hint = ("The mechanism is re-assembled with this held (the other free coordinates kept); the run starts "
                "again at t = 0")
        if coordinate.angular:
            values.append(Knob(f"{name}:{coordinate.body}", f"{coordinate.body}: {label}", -180.0, 180.0, 0.5,
                               math.degrees(q0[k]), hint, False))
            speeds.append(Knob(f"{rate_name}:{coordinate.body}", f"{coordinate.body}: {rate_label}",
                               -START_TURN_SPEED, START_TURN_SPEED, 5.0, math.degrees(qdot0[k]),
                               "Its speed at t = 0; the others follow from the joints", False,
                               typed=START_TURN_TYPED))
        else:
            centre = float(sketch_q[k])
            values.append(Knob(f"{name}:{coordinate.body}", f"{coordinate.body}: {label}",
                               round(centre - size, 6), round(centre + size, 6), _step(size), q0[k], hint, False))
            top = round(4 * math.pi * size, 6)
            speeds.append(Knob(f"{rate_name}:{coordinate.body}", f"{coordinate.body}: {rate_label}", -top, top,
                               _step(top / 10), qdot0[k], "Its speed at t = 0; the others follow from the joints",
                               False))
    return values + speeds


def start_value(knobs_now: list[Knob], name: str, value: object) -> float:
    """A start control's new value in SI (rad, rad/s, m, m/s), checked against its range."""
    knob, number = _in_range(knobs_now, name, value, "not a start control of this mechanism (start controls: "
                             f"{', '.join(k.name for k in knobs_now) or 'none: its motors fix it'})")
    return math.radians(number) if knob.unit.startswith("°") else number


def _scaled(body: Body, factor: float) -> Body:
    """``body`` scaled by ``factor`` about its first point (a crank keeps its pivot), inertia by factor²."""
    origin = np.array(next(iter(body.points.values())), dtype=float)

    def move(xy) -> list[float]:
        return [float(v) for v in origin + factor * (np.array(xy, dtype=float) - origin)]

    data = body.model_dump()
    data["points"] = {name: move(xy) for name, xy in body.points.items()}
    if body.com is not None:
        data["com"] = move(body.com)
    data["inertia"] = body.inertia * factor**2
    return Body.model_validate(data)


def apply_edit(mechanism: Mechanism, name: str, value: object, reference: Mechanism | None = None,
               sample_interval: float | None = None) -> Mechanism:
    """``mechanism`` with the control ``name`` set to ``value`` (SI units except a motor speed in °/s),
    validated, assembled and checked to run (motors followed at ``sample_interval``); LinkageError naming the
    element, the field and the allowed range otherwise."""
    knobs_now = knobs(mechanism, reference)
    knob, number = _in_range(knobs_now, name, value, f"not a control of {mechanism.name} "
                             f"(controls: {', '.join(k.name for k in knobs_now)})")
    kind, _, element = name.partition(":")
    data = mechanism.model_dump()
    try:
        if kind == "g":
            data["g"] = number
        elif kind in ("ratio", "offset"):
            index = [joint.name for joint in mechanism.joints].index(element)
            update = math.radians(number) if kind == "offset" else number
            data["joints"][index] = Gear.model_validate({**mechanism.joints[index].model_dump(),
                                                         kind: update}).model_dump()
        elif kind in ("mass", "inertia", "size"):
            index = [body.name for body in mechanism.bodies].index(element)
            body = mechanism.bodies[index]
            if kind == "size":
                factor = number / body_size(body)
                if body.inertia * factor**2 > MAX_INERTIA:  # its scaled inertia: a range of sizes, not pydantic's words
                    raise refused_range(knob.label, number, allowed_range(
                        0.0, body_size(body) * math.sqrt(MAX_INERTIA / body.inertia), low_open=True) +
                        f" (its inertia, {body.inertia:g} kg m² at {body_size(body):g} m, grows with the size squared "
                        f"and may not pass {MAX_INERTIA:g} kg m²)")
                new = _scaled(body, factor)
            else:
                new = Body.model_validate({**body.model_dump(), kind: number})
            data["bodies"][index] = new.model_dump()
        else:  # speed or torque of a motor
            index = [driver.joint for driver in mechanism.drivers].index(element)
            driver = mechanism.drivers[index]
            field = "speed" if kind == "speed" else "torque"
            update = math.radians(number) if kind == "speed" else number
            data["drivers"][index] = Driver.model_validate({**driver.model_dump(), field: update}).model_dump()
        edited = Mechanism.model_validate(data)
    except ValidationError as error:
        detail = error.errors()[0]
        field = str(detail["loc"][-1]) if detail.get("loc") else ""
        of = f"{field}: " if field and field != kind else ""  # what the model refused: a size's scaled inertia
        raise LinkageError(f"{knob.label} = {number:g}: {of}{detail['msg']}") from None
    try:  # the whole still runs (physics/mechanism/validation.py), as a file must before it is shown
        check_runnable(edited, sample_interval)
    except LinkageError as error:
        reason = "the mechanism cannot be assembled" if knob.geometry else "the mechanism cannot run"
        raise LinkageError(f"{knob.label} = {number:g}: {reason} ({error})") from None
    return edited


def shown_value(value: float) -> str:
    """A value in force as its box shows it (``0.001``, ``25``, ``1e-09``): the chain panel's format."""
    return f"{value:.6g}"
