"""What one session simulates: the physics models themselves, plus the app's own display settings.

:class:`SessionParameters` is an immutable value holding the validated ``physics.Chain`` and
``physics.Settings`` and the start state; every number it offers (``L``, ``m``, ``method``, ...) is read from
those models, never kept a second time. A change builds a new value through :mod:`app.commands`, so a session
always holds a mechanism the models accepted. :class:`Display` is the same idea for what only the picture uses
(playback speed, trace length, arrow scale): a pydantic model owns their bounds too.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

import physics
from physics import Chain, LinkageError, Settings, TracePoint, get_preset, loop_closure
from physics.model import check_state, validated

METHOD_LABELS = {
    "newton_euler": "Newton-Euler",
    "lagrange": "Lagrange",
    "dae": "DAE",
    "reduced": "Reduced (1 dof)",
    "reduced_fixed": "Reduced, theta1 fixed",
}
DEFAULT_METHOD = "lagrange"
DEFAULT_TOLERANCE = 1e-9
# Settings of a session are validated for a one-second chunk: the player sets the real horizon per chunk, and
# a fixed step is refused only when one second of it would exceed the model's step budget.
CHUNK_T_END = 1.0


def methods_for(chain: Chain) -> tuple[str, ...]:
    """Methods offered for a chain: the three formulations, and the reduced models where physics has them."""
    names = tuple(physics.FORMULATION_NAMES)
    if physics.reduced_available(chain):
        names += tuple(m for m in physics.METHOD_NAMES if m not in names)
    return names


def settings_data(settings: Settings) -> dict:
    """A Settings' fields for building a changed copy; ``backend`` is left out because the model decides it
    from the integrator (Radau and LSODA switch it to scipy, and a later compiled integrator must switch back)."""
    data = dict(settings)
    data.pop("backend", None)
    return data


# A general mechanism's fixed-coordinate reduced model keeps its first free joint, which is theta1's only for a chain
MECHANISM_FIXED_LABEL = "Reduced, first free joint fixed"


def method_label(method: str, chain: bool = True) -> str:
    """The words a Method menu shows for a method key (``dae`` reads ``DAE``): the one labelling of both
    panels, chains' and mechanisms'; share links, snapshots and the command line keep the keys. ``chain``:
    False for a general mechanism, whose ``reduced_fixed`` keeps its first free joint, not theta1."""
    if method == "reduced_fixed" and not chain:
        return MECHANISM_FIXED_LABEL
    return METHOD_LABELS.get(method, method)


def method_from_label(label: object) -> object:
    """The method key a Method menu's label stands for (the inverse of :func:`method_label`); anything else
    is returned as it came, for the session's check to refuse with the allowed values."""
    for name, text in METHOD_LABELS.items():
        if text == label:
            return name
    return "reduced_fixed" if label == MECHANISM_FIXED_LABEL else label


_METHOD_NAME = re.compile(r"\b(" + "|".join(sorted(METHOD_LABELS, key=len, reverse=True)) + r")\b")


def in_menu_words(message: str) -> str:
    """A physics message as the panel's menus word it: ``method = lagrange (got dae)`` reads ``method =
    Lagrange (got DAE)``, ``choose method 'reduced'`` reads ``choose method 'Reduced (1 dof)'``."""
    return _METHOD_NAME.sub(lambda match: METHOD_LABELS[match.group(1)], message)


def driving_count(n: int, pinned: bool) -> int:
    """How many initial angles the user sets: all of them, or the first n - 2 of a closed loop."""
    return n - 2 if pinned else n


class Display(BaseModel):
    """What only the picture uses; bounds as for the physics fields, so the same command layer checks them."""

    model_config = ConfigDict(frozen=True)

    speed: float = Field(1.0, ge=0.01, le=8.0, description="simulated seconds shown per second")
    trace_seconds: float = Field(4.0, ge=0.0, le=30.0, description="length of the drawn trace")
    arrow_scale: float = Field(0.5, gt=0.0, le=10.0, description="1 draws the total weight as long as the reach")


@dataclass(frozen=True)
class SessionParameters:
    """One session's mechanism (``chain``), integration choices (``settings``) and start (radians)."""

    preset: str
    chain: Chain
    settings: Settings
    theta0: np.ndarray = field(repr=False)
    omega0: np.ndarray = field(repr=False)
    default_trace: TracePoint | None = field(default=None, repr=False)

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_preset(cls, name: str, links: int | None = None, method: str | None = None) -> "SessionParameters":
        preset = get_preset(name, links=links)
        settings = validated(
            Settings, method=method or DEFAULT_METHOD, rtol=DEFAULT_TOLERANCE, atol=DEFAULT_TOLERANCE,
            trace=preset.trace, t_end=CHUNK_T_END, samples=2,
        )
        params = cls(
            preset=preset.name,
            chain=preset.chain,
            settings=settings,
            theta0=np.array(preset.theta0, dtype=float),
            omega0=np.array(preset.omega0, dtype=float),
            default_trace=preset.trace,
        )
        params.validate()
        return params

    def replaced(self, **updates) -> "SessionParameters":
        """A copy with ``updates`` (already validated models or arrays), checked together (:meth:`validate`)."""
        new = replace(self, **updates)
        new.validate()
        return new

    # ------------------------------------------------------------------ read from the models
    @property
    def n(self) -> int:
        return self.chain.n

    @property
    def links(self) -> int:
        return self.chain.n

    @property
    def pinned(self) -> bool:
        return self.chain.pinned

    @property
    def L(self) -> list[float]:
        return [bar.L for bar in self.chain.bars]

    @property
    def d(self) -> list[float]:
        return [bar.d for bar in self.chain.bars]

    @property
    def m(self) -> list[float]:
        return [bar.m for bar in self.chain.bars]

    @property
    def I(self) -> list[float]:  # noqa: E743 - the model's name for the centroidal inertia
        return [bar.I for bar in self.chain.bars]

    @property
    def g(self) -> float:
        return self.chain.g

    @property
    def pin(self) -> tuple[float, float] | None:
        pin = self.chain.pin
        return (float(pin[0]), float(pin[1])) if pin is not None else None

    @property
    def trace(self) -> TracePoint:
        trace = self.settings.trace
        assert trace is not None, "a session's settings always name the traced point (from_preset sets it)"
        return trace

    @property
    def method(self) -> str:
        return self.settings.method

    @property
    def integrator(self) -> str:
        return self.settings.integrator

    @property
    def tolerance(self) -> float:
        return self.settings.rtol

    @property
    def step(self) -> float:
        return self.settings.step

    @property
    def stabilization(self) -> str:
        return self.settings.stabilization

    @property
    def baumgarte_alpha(self) -> float:
        return self.settings.baumgarte_alpha

    @property
    def baumgarte_beta(self) -> float:
        return self.settings.baumgarte_beta

    @property
    def damping(self) -> float:
        return self.settings.damping

    def settings_for(self, method: str) -> Settings:
        """These settings with another method (compare mode); LinkageError if that method refuses them."""
        if method == self.settings.method:
            return self.settings
        return validated(Settings, **{**settings_data(self.settings), "method": method})

    # ------------------------------------------------------------------ checks across models
    def validate(self) -> None:
        """Raise LinkageError if chain, settings, method and start do not fit together."""
        chain = self.chain
        if self.method not in methods_for(chain):
            allowed = ", ".join(methods_for(chain))
            raise LinkageError(f"method = {self.method}: not available for this mechanism; allowed: {allowed}")
        if self.trace is None or self.trace.bar > self.n:
            raise LinkageError(f"trace: the traced point must lie on one of the {self.n} bars")
        check_state(self.n, self.theta0, self.omega0)
        if chain.pinned:
            gap = float(np.hypot(*loop_closure.loop_residual(self.L, self.theta0, self.pin)))
            if not gap <= 1e-8:
                raise LinkageError(f"the start does not close the loop (tip misses the pin by {gap:.3g})")

    def assembled(self, theta_driving, theta_prev=None, L=None, pin=None) -> np.ndarray:
        """Start angles of a closed loop from its driving angles (physics.loop_closure); LinkageError if unreachable."""
        return loop_closure.assemble(
            self.L if L is None else L, self.pin if pin is None else pin,
            np.asarray(theta_driving, float), theta_prev=theta_prev,
        )

    # ------------------------------------------------------------------ the traced point
    def trace_choices(self) -> dict[str, TracePoint]:
        """Points the trace can follow: the preset's coupler point (if it has one), the tip, every joint and
        centre of mass. The first entry is the default."""
        L, d = self.L, self.d
        standard = {"tip H": TracePoint(bar=self.n, along=L[-1])}
        for k in range(1, self.n):
            standard[f"joint {k}"] = TracePoint(bar=k, along=L[k - 1])
        for k in range(1, self.n + 1):
            standard[f"centre of mass {k}"] = TracePoint(bar=k, along=d[k - 1])
        preset_point = self.default_trace
        if preset_point is not None and preset_point.bar <= self.n and preset_point not in standard.values():
            return {"coupler point": preset_point, **standard}
        return standard

    def trace_label(self) -> str:
        for label, point in self.trace_choices().items():
            if point == self.trace:
                return label
        return f"bar {self.trace.bar}, {self.trace.along:g} along, {self.trace.across:g} across"

    def as_dict(self) -> dict:
        """JSON-able description (the snapshot's ``parameters``)."""
        return {
            "preset": self.preset,
            "links": self.n,
            "pinned": self.pinned,
            "bars": [{"L": bar.L, "d": bar.d, "m": bar.m, "I": bar.I} for bar in self.chain.bars],
            "g": float(self.g),
            "pin": [float(v) for v in self.pin] if self.pin is not None else None,
            "theta0": [float(v) for v in self.theta0],
            "omega0": [float(v) for v in self.omega0],
            "trace": {"bar": self.trace.bar, "along": self.trace.along, "across": self.trace.across},
            "method": self.method,
            "integrator": self.integrator,
            "rtol": self.settings.rtol,
            "atol": self.settings.atol,
            "step": self.step,
            "stabilization": self.stabilization,
            "baumgarte_alpha": self.baumgarte_alpha,
            "baumgarte_beta": self.baumgarte_beta,
            "damping": self.damping,
        }


def wrap_degrees(angle_rad: float) -> float:
    """An angle in degrees within [-180, 180], for the angle sliders."""
    deg = math.degrees(angle_rad)
    return (deg + 180.0) % 360.0 - 180.0 if abs(deg) > 180.0 else deg
