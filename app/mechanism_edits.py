"""The panel's values of a general mechanism, generated from its description, and edits through its models.

Every control of a mechanism session is a :class:`Knob`: a name (``mass:crank``, ``size:coupler``,
``speed:O2``, ``g``), a label with units, a range and the value in force. :func:`apply_edit` returns the edited
mechanism, validated again by ``physics.mechanism``'s pydantic models and assembled, or raises LinkageError
naming the body or joint, the field, the value and the allowed range. Plain data; no viser.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pydantic import ValidationError

from physics import LinkageError
from physics.mechanism import Body, Driver, Mechanism
from physics.mechanism.validation import MIN_INERTIA, MIN_MASS, check_runnable


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


def body_size(body: Body) -> float:
    """A body's size: the largest distance between two of its points (a bar's length)."""
    points = np.array(list(body.points.values()), dtype=float).reshape(-1, 2)
    if len(points) < 2:
        return 0.0
    gaps = points[:, None, :] - points[None, :, :]
    return float(np.max(np.hypot(gaps[..., 0], gaps[..., 1])))


def _step(value: float) -> float:
    """A slider step about a hundredth of ``value``: the power of ten at or below it."""
    if value <= 0 or not math.isfinite(value):
        return 0.01
    exponent = math.floor(math.log10(value / 100.0))
    return 10.0 ** exponent


def knobs(mechanism: Mechanism, reference: Mechanism | None = None) -> list[Knob]:
    """The controls of ``mechanism``: per body its size (bodies with two or more points), mass and inertia;
    per motor its speed (°/s) or torque (N·m); gravity. Ranges come from ``reference`` (the preset or file
    as loaded), so a slider's range does not move as it is dragged."""
    reference = reference or mechanism
    out: list[Knob] = []
    for body, ref in zip(mechanism.bodies, reference.bodies):
        size, ref_size = body_size(body), body_size(ref)
        if ref_size > 0:
            out.append(Knob(f"size:{body.name}", f"{body.name}: size (m)", round(0.25 * ref_size, 6),
                            round(3.0 * ref_size, 6), _step(ref_size), size,
                            "The largest distance between its points; the body is scaled about its first point "
                            "and the mechanism re-assembled (its inertia scales with the square)", True))
        mass_top = max(10.0 * ref.mass, 1.0)
        out.append(Knob(f"mass:{body.name}", f"{body.name}: m (kg)", MIN_MASS, mass_top, _step(mass_top / 10),
                        body.mass, "Mass of the body", False))
        inertia_top = max(10.0 * ref.inertia, 1e-4)
        out.append(Knob(f"inertia:{body.name}", f"{body.name}: I (kg·m²)", MIN_INERTIA, inertia_top,
                        _step(inertia_top / 10), body.inertia, "Centroidal moment of inertia of the body", False))
    for driver in mechanism.drivers:
        if driver.speed is not None:
            out.append(Knob(f"speed:{driver.joint}", f"motor {driver.joint}: speed (°/s)", -720.0, 720.0, 5.0,
                            math.degrees(driver.speed), "Constant relative angular speed the motor holds", False))
        else:
            torque = float(driver.torque or 0.0)
            top = max(10.0 * abs(torque), 1.0)
            out.append(Knob(f"torque:{driver.joint}", f"motor {driver.joint}: torque (N·m)", -top, top,
                            _step(top / 10), torque, "Constant torque the motor applies", False))
    out.append(Knob("g", "g (m/s²)", 0.0, 30.0, 0.01, mechanism.g, "Gravitational acceleration, along -y", False))
    return out


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


def _number(name: str, value: object) -> float:
    if isinstance(value, bool):
        raise LinkageError(f"{name} = {value!r}: expected a number")
    try:
        number = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError, OverflowError):  # OverflowError: an integer beyond any float (10**400)
        shown = repr(value)
        raise LinkageError(f"{name} = {shown if len(shown) <= 40 else shown[:39] + '…'}: expected a number") from None
    if not math.isfinite(number):
        raise LinkageError(f"{name} = {value!r}: expected a finite number")
    return number


def apply_edit(mechanism: Mechanism, name: str, value: object, reference: Mechanism | None = None,
               sample_interval: float | None = None) -> Mechanism:
    """``mechanism`` with the control ``name`` set to ``value`` (SI units except a motor speed in °/s),
    validated, assembled and checked to run (motors followed at ``sample_interval``); LinkageError naming the
    element, the field and the allowed range otherwise."""
    knob = next((k for k in knobs(mechanism, reference) if k.name == name), None)
    if knob is None:
        raise LinkageError(f"{name!r}: not a control of {mechanism.name} "
                           f"(controls: {', '.join(k.name for k in knobs(mechanism, reference))})")
    number = _number(knob.label, value)
    if not knob.low <= number <= knob.high:
        raise LinkageError(f"{knob.label} = {number:g}: allowed range {knob.low:g} to {knob.high:g}")
    kind, _, element = name.partition(":")
    data = mechanism.model_dump()
    try:
        if kind == "g":
            data["g"] = number
        elif kind in ("mass", "inertia", "size"):
            index = [body.name for body in mechanism.bodies].index(element)
            body = mechanism.bodies[index]
            if kind == "size":
                if number <= 0:
                    raise LinkageError(f"body {element!r}: size = {number:g}: must be above 0 m")
                new = _scaled(body, number / body_size(body))
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
        raise LinkageError(f"{knob.label} = {number:g}: {detail['msg']}") from None
    try:  # the whole still runs (physics/mechanism/validation.py), as a file must before it is shown
        check_runnable(edited, sample_interval)
    except LinkageError as error:
        reason = "the mechanism cannot be assembled" if knob.geometry else "the mechanism cannot run"
        raise LinkageError(f"{knob.label} = {number:g}: {reason} ({error})") from None
    return edited


MAX_TYPED = 60  # characters: longer is no number a person typed


def shown_value(value: float) -> str:
    """A value in force as its box shows it (``0.001``, ``25``, ``1e-09``): the chain panel's format."""
    return f"{value:.6g}"


def typed_number(knob: Knob, text: object) -> float:
    """What a person typed into ``knob``'s box, read as Python reads a number (``2.5e1``, ``1e-3``, ``-0``,
    ``1_000``, a typographic minus), never as the browser's number box does (which drops the exponent: 2.51);
    LinkageError naming the field otherwise (``1,5`` is no number: a decimal comma is refused, not read as 15).
    The range is the model's, checked by :func:`apply_edit`."""
    unit = knob.label[knob.label.rfind("(") + 1: -1] if knob.label.endswith(")") else ""
    example = f"type a number{' in ' + unit if unit else ''}, e.g. 1.5 or 1e-3"
    if not isinstance(text, str):
        raise LinkageError(f"{knob.label} = {text!r}: not a number; {example}")
    cleaned = text.strip().replace("\u2212", "-")
    if not cleaned:
        raise LinkageError(f"{knob.label}: the box is empty; {example}")
    if len(cleaned) > MAX_TYPED:
        raise LinkageError(f"{knob.label}: {len(cleaned)} characters is not a number; {example}")
    try:
        number = float(cleaned)
    except ValueError:
        raise LinkageError(f"{knob.label} = {cleaned!r}: not a number; {example}") from None
    if not math.isfinite(number):
        raise LinkageError(f"{knob.label} = {cleaned}: must be a finite number")
    return number
