"""A chain hosted by the mechanism session: its knobs, its mechanism, its start and its state, by the chain's names.

Why: issue 24 wants one app session. The mechanism session (app/session.py) runs a chain preset as
``physics.mechanism.chains.chain_mechanism(chain, theta_sketch, damping)`` and shows the chain's own panel
numbers as :class:`~app.mechanism_edits.Knob` objects, so the one control generator draws them: the number of
bars (the ``chain`` preset), g, per bar L, d, m and I, the start (per driving bar its initial angle in degrees and
speed in degrees per second; a pinned chain's last two angles come from its loop closure), the pin H of a
pinned chain and the joint damping. Each knob's name is the chain's ``--set`` and share-link name (``L1``,
``d2``, ``m3``, ``I1``, ``g``, ``theta1``, ``omega1``, ``pin_x``, ``pin_y``, ``damping``), its label, unit and
slider range those of the chain panel (kept here), its typed range the pydantic models' bounds
(:meth:`app.commands.Quantity.bounds`). Every edit goes through the chain's one validation layer,
:func:`app.commands.apply`, so a refusal reads as the chain panel's.

The sketch is the chain hanging straight down (``theta_sketch = 0``, as physics' own chain route,
physics/simulate/mechanism_route.py): a body's angle in ``q`` is then the chain's absolute angle theta itself,
and an edit of any number changes only numbers (physics.mechanism.parameters.structure_key never moves: no
derivation or compilation on an edit). A pinned chain's sketch does not close; its start does (the chain's
loop closure assembles it, app/parameters.py), and the run starts from that start, never from the sketch.
Plain data and numpy; no viser.
"""

from __future__ import annotations

import math
import re
from dataclasses import replace

import numpy as np

import physics
from physics import LinkageError, Settings, loop_closure
from physics.kinematics import point_on_bar
from physics.mechanism import Mechanism
from physics.mechanism.chains import chain_mechanism, chain_state
from physics.model import MAX_LINKS, validated

from .commands import QUANTITIES, Quantity
from .mechanism_edits import Knob
from .mechanism_runs import MechanismSettings, is_reduced
from .mechanism_start import FreeCoordinate
from .number_inputs import SliderSpec
from .parameters import SessionParameters, driving_count, methods_for, settings_data, wrap_degrees
from .text import markdown_literal

# The chain's slider ranges (its sliders' useful span; a typed value may go to the models' bounds)
BAR_SLIDERS = {
    "L": SliderSpec("L", 0.05, 3.0, 0.01),
    "d": SliderSpec("d", 0.0, 3.0, 0.01),  # max follows L
    "m": SliderSpec("m", 0.0, 5.0, 0.05),
    "I": SliderSpec("I", 0.0, 1.0, 0.005),
}
GRAVITY_SLIDER = SliderSpec("g", 0.0, 20.0, 0.05)
DAMPING_SLIDER = SliderSpec("damping", 0.0, 2.0, 0.01)
ANGLE_SLIDER = SliderSpec("theta", -180.0, 180.0, 0.5)
SPEED_START_SLIDER = SliderSpec("omega", -720.0, 720.0, 5.0)  # initial angular velocity in degrees per second
PIN_SLIDER = SliderSpec("pin_x", -5.0, 5.0, 0.01)


def preset_description(p) -> str:
    """The preset's own description (physics.chain_presets), for the line under the mechanism menu."""
    preset = physics.get_preset(p.preset, p.n if p.preset == "chain" else None)
    return preset.description or p.preset


def reach_text(p) -> str:
    """Where a four-bar's theta1 can be set: the closed-form intervals of physics.loop_closure.driving_range, in
    degrees within one turn, as the slider shows angles."""
    intervals = physics.loop_closure.driving_range(p.L, p.pin)
    if not intervals:
        return "*theta1 reachable: nowhere: this loop cannot close (change a length or the pin)*"
    parts = []
    for low, high in intervals:
        if high - low >= 2 * math.pi - 1e-9:
            return "*theta1 reachable: every angle (bar 1 is a crank)*"
        start, end = wrap_degrees(low), wrap_degrees(high)
        parts.append(f"{start:.1f}° to {end:.1f}°" + (" (through ±180°)" if start > end else ""))
    return "*theta1 reachable: " + " and ".join(parts) + "*"


# the methods the mechanism session runs (app/session.py METHODS), in the chain panel's order
HOSTED_METHODS = ("newton_euler", "lagrange", "dae", "reduced", "reduced_fixed")
BAR_HINTS = {"L": "Length of the bar (pin to pin)", "d": "Distance of the centre of mass from the proximal pin",
             "m": "Mass of the bar", "I": "Centroidal moment of inertia of the bar"}


def sketch(params: SessionParameters) -> np.ndarray:
    """The hosted chain's sketch: hanging straight down (see the module's docstring)."""
    return np.zeros(params.n)


def hosted_mechanism(params: SessionParameters) -> Mechanism:
    """The chain of ``params`` as a mechanism (bars ``bar1..barn``, pins ``O``, ``J1..``, a pinned tip ``H``),
    its joints damped by the settings' damping, named as the preset."""
    mechanism = chain_mechanism(params.chain, sketch(params), damping=params.damping)
    return mechanism.model_copy(update={"name": params.preset})


def hosted_start(params: SessionParameters) -> tuple[np.ndarray, np.ndarray]:
    """``(q0, qdot0)`` of :func:`hosted_mechanism` at the chain's start ``(theta0, omega0)``."""
    return chain_state(params.chain, sketch(params), params.theta0, params.omega0)


def chain_angles(params: SessionParameters, q: np.ndarray, qdot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The chain's ``(theta, omega)`` of hosted states ``q, qdot`` (..., 3 n) (each bar's angle is the sketch's plus its
    turn; on the sketch hanging down, the turn itself)."""
    q, qdot = np.asarray(q, dtype=float), np.asarray(qdot, dtype=float)
    return q[..., 2::3] + sketch(params), qdot[..., 2::3].copy()


def mobility(params: SessionParameters) -> int:
    """The chain's degrees of freedom: its driving angles (a closed loop loses two)."""
    return driving_count(params.n, params.pinned)


def free_coordinates(params: SessionParameters) -> tuple[FreeCoordinate, ...]:
    """The coordinates the start is set by: the driving bars' angles (``q[3 k + 2]``)."""
    return tuple(FreeCoordinate(f"bar{k + 1}", "angle", 3 * k + 2) for k in range(mobility(params)))


def close_loop(params: SessionParameters, theta: np.ndarray, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A pinned chain's state put exactly on its loop with ``params``' lengths and pin (a displayed state after
    an edit), as the chain's start always was; LinkageError when it cannot close."""
    if not params.pinned:
        return theta, omega
    k = driving_count(params.n, True)
    try:
        theta = params.assembled(theta[:k], theta_prev=theta)
    except LinkageError as error:
        raise LinkageError(f"the moving linkage cannot close with these values: {error}") from None
    try:
        omega = loop_closure.project_velocity(params.L, theta, omega)
    except LinkageError:  # a dead centre: the loop goes on from rest
        omega = np.zeros_like(omega)
    return theta, omega


class ChainTrace:
    """The chain's traced point (:class:`~physics.TracePoint`: bar, along, across; a coupler point, the tip, a
    centre of mass) on hosted states ``q`` (T, 3 n): :func:`physics.kinematics.point_on_bar` of the chain's
    angles, so that any point of the chain panel's menu is traced without a named point in the mechanism (its
    compiled structure stays: the path is computed from the run's q, in numpy)."""

    def __init__(self, params: SessionParameters) -> None:
        self.L = np.asarray(params.L, dtype=float)
        self.point = params.trace
        self.sketch = sketch(params)

    def __call__(self, q: np.ndarray) -> np.ndarray:
        q = np.atleast_2d(np.asarray(q, dtype=float))
        theta = q[:, 2::3] + self.sketch
        point = self.point
        return point_on_bar(self.L, theta, point.bar, point.along, point.across).reshape(len(q), 2)


def trace_label(params: SessionParameters) -> str | None:
    """The chain's traced point as a named point of the hosted mechanism (``bar3.D``: the tip), or None where it
    is no named point (a centre of mass, a coupler point off the bar): the mechanism traces named points only."""
    point = params.trace
    if point.across != 0.0:
        return None
    if point.along == 0.0:
        return f"bar{point.bar}.P"
    if math.isclose(point.along, params.L[point.bar - 1], rel_tol=1e-12, abs_tol=0.0):
        return f"bar{point.bar}.D"
    return None


def hosted_settings(params: SessionParameters) -> MechanismSettings:
    """The mechanism session's run settings for the chain's (method, integrator, tolerance, step, stabilisation,
    Baumgarte gains; the traced point where it is a named point); LinkageError for a method the mechanism session
    does not run (``reduced_fixed``), naming the allowed ones."""
    s = params.settings
    allowed = methods(params, mobility(params))
    if s.method not in allowed:
        raise LinkageError(f"method = {s.method}: allowed values {', '.join(allowed)}")
    return MechanismSettings(method=s.method, stabilization=s.stabilization, trace=trace_label(params),
                             rtol=s.rtol, integrator=s.integrator, step=s.step,
                             baumgarte_alpha=s.baumgarte_alpha, baumgarte_beta=s.baumgarte_beta,
                             max_steps=s.max_steps, chain_coordinates=True)


def with_settings(params: SessionParameters, settings: MechanismSettings) -> SessionParameters:
    """``params`` with the mechanism session's run settings in force (rtol = atol, as the chain panel sets
    them), validated by the chain's models: what a share link and a snapshot of the chain carry."""
    update = {"method": settings.method, "stabilization": settings.stabilization, "rtol": settings.rtol,
              "atol": settings.rtol, "integrator": settings.integrator, "step": settings.step,
              "baumgarte_alpha": settings.baumgarte_alpha, "baumgarte_beta": settings.baumgarte_beta}
    return params.replaced(settings=validated(Settings, **{**settings_data(params.settings), **update}))


def same_shape(mechanism: Mechanism, params: SessionParameters) -> bool:
    """``mechanism`` is a hosted chain of ``params``' shape (as many bars, pinned alike): a state of it maps to
    the chain's angles (:func:`chain_angles`)."""
    return ([body.name for body in mechanism.bodies] == [f"bar{k}" for k in range(1, params.n + 1)]
            and ("H" in mechanism.ground) == params.pinned)


def methods(params: SessionParameters, mobility_now: int) -> tuple[str, ...]:
    """The methods offered for the hosted chain: the chain's (app.parameters.methods_for) that the mechanism
    session runs, the reduced model only for mobility 1."""
    offered = methods_for(params.chain)
    return tuple(m for m in HOSTED_METHODS if m in offered and (not is_reduced(m) or mobility_now == 1))


def facts_line(params: SessionParameters) -> str:
    """The chain panel's words under the menu: bars, pinned or open, the degrees of freedom and, for a four-bar,
    where theta1 can be set (:func:`reach_text`, with its Grashof reading)."""
    kind = "closed loop, tip pinned at H" if params.pinned else "open chain"
    freedom = mobility(params)
    bars = f"{params.n} bar{'' if params.n == 1 else 's'}"
    line = markdown_literal(f"{bars}, {kind}; {freedom} degree{'' if freedom == 1 else 's'} of freedom")
    if params.pinned and params.n == 3:
        line += "\n\n" + reach_text(params)
    return line


def description(params: SessionParameters) -> str:
    """The preset's own description (physics.chain_presets), as the chain panel shows it."""
    return preset_description(params)


# ---------------------------------------------------------------------------------------------- knobs
def _typed(q: Quantity) -> tuple[tuple[float, float], bool]:
    """A quantity's model bounds in the control's units, and whether the lower one is open."""
    lo, lo_open, hi, _ = q.bounds()
    return (lo * q.scale, hi * q.scale), lo_open


def _knob(name: str, spec: SliderSpec, value_si: float, *, label: str | None = None, high: float | None = None,
          hint: str | None = None, geometry: bool = False) -> Knob:
    """A chain number as a generated control: the chain panel's slider range (app/number_inputs.py
    ``SliderSpec.range``), its typed range the model's bounds, its value in the control's units."""
    q = QUANTITIES[spec.key]
    value = value_si * q.scale
    low, top = spec.range()
    if high is not None:  # d's range follows its bar's length, as the chain panel's
        top = max(min(top, high), low + spec.step)
    typed, low_open = _typed(q)
    if high is not None:
        typed = (typed[0], high)
    return Knob(name, label or spec.label, low, top, spec.step, value, hint or spec.hint or q.label, geometry,
                typed=typed, low_open=low_open)


def chain_knobs(params: SessionParameters) -> list[Knob]:
    """The hosted chain's numbers (not its start, :func:`start_knobs`): the number of bars (the ``chain``
    preset only, as the chain panel shows it), g, per bar L, d, m and I, the pin H of a pinned chain and the
    joint damping, in the order a share link sets them."""
    out: list[Knob] = []
    if params.preset == "chain":
        out.append(Knob("links", "Bars (chain)", 1.0, float(MAX_LINKS), 1.0, float(params.n),
                        "Number of bars: loads the chain preset of that size", True, typed=(1.0, float(MAX_LINKS))))
    out.append(_knob("g", GRAVITY_SLIDER, params.g))
    for k, bar in enumerate(params.chain.bars, start=1):
        for field, spec in BAR_SLIDERS.items():
            q = QUANTITIES[field]
            out.append(_knob(f"{field}{k}", spec, getattr(bar, field), label=f"bar {k}: {q.label} ({q.unit})",
                             high=bar.L if field == "d" else None, hint=BAR_HINTS[field],
                             geometry=field in ("L", "d")))
    if params.pin is not None:
        for name, value in zip(("pin_x", "pin_y"), params.pin):
            out.append(_knob(name, PIN_SLIDER, value, label=f"pin {name[-1]} (m)",
                             hint="Where the tip is pinned to the ground (H)", geometry=True))
    out.append(_knob("damping", DAMPING_SLIDER, params.damping))
    return out


def start_knobs(params: SessionParameters) -> list[Knob]:
    """The start's controls, as the chain panel's: per driving bar its initial angle (°) and speed (°/s); a
    pinned chain's other angles are assembled so that the loop closes, its other speeds follow the loop."""
    count = mobility(params)
    angles = [_knob(f"theta{k}", ANGLE_SLIDER, float(params.theta0[k - 1]), label=f"theta{k} (°)",
                    hint="The run starts again at t = 0 from this angle (from the downward vertical)")
              for k in range(1, count + 1)]
    speeds = [_knob(f"omega{k}", SPEED_START_SLIDER, float(params.omega0[k - 1]), label=f"omega{k} (°/s)",
                    hint="Its angular velocity at t = 0")
              for k in range(1, count + 1)]
    # a pinned chain's other angles and speeds, shown greyed as the loop sets them (the chain panel's)
    angles += [replace(_knob(f"theta{k}", ANGLE_SLIDER, float(params.theta0[k - 1]),
                             label=f"theta{k} (°), follows the loop",
                             hint="Assembled so that the loop closes (set the driving angle)"), follows=True)
               for k in range(count + 1, params.n + 1)]
    speeds += [replace(_knob(f"omega{k}", SPEED_START_SLIDER, float(params.omega0[k - 1]),
                             label=f"omega{k} (°/s), follows the loop",
                             hint="The speed the loop gives it (set the driving speed)"), follows=True)
               for k in range(count + 1, params.n + 1)]
    return angles + speeds


START_KEYS = ("theta", "omega")


def is_start(name: str) -> bool:
    """A start knob's name (``theta2``, ``omega1``)."""
    return isinstance(name, str) and name.rstrip("0123456789") in START_KEYS and name[-1:].isdigit()


def angles_in_degrees(theta: np.ndarray) -> list[float]:
    """Angles as the panel shows them (degrees), for snapshots and tests."""
    return [math.degrees(float(v)) for v in theta]


# The mechanism's fixed-coordinate stop at pin O (physics.mechanism.reduced), read to say it as the chain does
_FIXED_STOP = re.compile(r"joint 'O' stopped being a valid coordinate at t = (?P<t>\S+) s: a dead centre \(its speed "
                         r"share fell to (?P<share>\S+), limit (?P<limit>[^)]+)\)")


def chain_failure(message: str, at_start: bool = False) -> str:
    """A hosted chain's stop in the chain's words: the fixed-coordinate model's stop at pin ``O`` is theta1's,
    where bars 2 and 3 of a four-bar fold into line (the chain's own sentence, physics/simulate/reduced_adapter.py);
    a loop found dependent at a start (``at_start``: nothing ran) is a singular pose of the chain, whose loop
    always closes with one freedom elsewhere; any other message as it came."""
    if at_start and "over-constrained" in message:
        return (f"the start is a singular pose: the loop's bars are in line there, so its constraints are dependent "
                f"({message.split(': ', 1)[-1]}); choose another start")
    found = _FIXED_STOP.search(message)
    if found is None:
        return message
    return (f"theta1 stopped being a valid coordinate at t = {found['t']} s: bars 2 and 3 became collinear (a dead "
            f"centre: its speed share fell to {found['share']}, limit {found['limit']}); the fixed-coordinate "
            "reduced model cannot continue past it, choose method 'reduced', which switches coordinates "
            "(generalized coordinate partitioning)")

