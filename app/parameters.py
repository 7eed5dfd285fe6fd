"""What a session lets the user change, and its translation into validated physics objects.

:class:`SessionParameters` is plain mutable data (lists and arrays). Every change goes through
:meth:`SessionParameters.changed`, which builds the physics ``Chain`` and ``Settings`` from a copy and
keeps the change only if they validate, so a session always holds a valid mechanism; an invalid value
raises :class:`physics.LinkageError` with the model's one-line message and leaves the state as it was.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

import numpy as np

import physics
from physics import LinkageError, Settings, TracePoint, assembly, get_preset, make_chain

METHOD_LABELS = {
    "newton_euler": "Newton-Euler",
    "lagrange": "Lagrange",
    "dae": "DAE",
    "reduced": "Reduced (1 dof)",
    "reduced_fixed": "Reduced, theta1 fixed",
}
DEFAULT_METHOD = "lagrange"
DEFAULT_INTEGRATOR = "DOP853"
DEFAULT_TOLERANCE = 1e-9
STABILIZATIONS = ("none", "baumgarte", "projection")


def methods_for(chain) -> tuple[str, ...]:
    """Methods offered for a chain: the three formulations, and the reduced models where physics has them."""
    names = tuple(physics.FORMULATION_NAMES)
    if physics.reduced_available(chain):
        names += tuple(m for m in physics.METHOD_NAMES if m not in names)
    return names


def method_label(method: str) -> str:
    return METHOD_LABELS.get(method, method)


def driving_count(n: int, pinned: bool) -> int:
    """How many initial angles the user sets: all of them, or the first n - 2 of a closed loop."""
    return n - 2 if pinned else n


@dataclass
class SessionParameters:
    """One session's mechanism, start state and integration choices (angles in radians)."""

    preset: str
    links: int
    L: list[float]
    d: list[float]
    m: list[float]
    I: list[float]
    g: float
    pin: tuple[float, float] | None
    theta0: np.ndarray
    omega0: np.ndarray
    trace: TracePoint
    method: str = DEFAULT_METHOD
    integrator: str = DEFAULT_INTEGRATOR
    tolerance: float = DEFAULT_TOLERANCE
    step: float = 1e-3
    stabilization: str = "projection"
    baumgarte_alpha: float = 10.0
    baumgarte_beta: float = 10.0
    damping: float = 0.0
    default_trace: TracePoint | None = field(default=None, repr=False)

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_preset(cls, name: str, links: int | None = None, method: str | None = None) -> "SessionParameters":
        preset = get_preset(name, links=links)
        chain = preset.chain
        params = cls(
            preset=preset.name,
            links=chain.n,
            L=[b.L for b in chain.bars],
            d=[b.d for b in chain.bars],
            m=[b.m for b in chain.bars],
            I=[b.I for b in chain.bars],
            g=chain.g,
            pin=tuple(chain.pin) if chain.pin is not None else None,
            theta0=np.array(preset.theta0, dtype=float),
            omega0=np.array(preset.omega0, dtype=float),
            trace=preset.trace,
            default_trace=preset.trace,
        )
        if method is not None:
            params = params.changed(method=method)
        params.validate()
        return params

    # ------------------------------------------------------------------ derived views
    @property
    def n(self) -> int:
        return len(self.L)

    @property
    def pinned(self) -> bool:
        return self.pin is not None

    def chain(self):
        """The validated physics ``Chain`` (raises LinkageError naming the field)."""
        return make_chain(self.L, self.d, self.m, self.I, g=self.g, pin=self.pin)

    def settings(self, method: str | None = None):
        """Validated physics ``Settings`` (horizon and samples are set per chunk by the player)."""
        from physics.model import validated

        return validated(
            Settings,
            method=method or self.method,
            integrator=self.integrator,
            rtol=self.tolerance,
            atol=self.tolerance,
            step=self.step,
            stabilization=self.stabilization,
            baumgarte_alpha=self.baumgarte_alpha,
            baumgarte_beta=self.baumgarte_beta,
            damping=self.damping,
            trace=self.trace,
            t_end=1.0,
            samples=2,
        )

    def validate(self) -> None:
        """Raise LinkageError if the chain, settings, method or start state are not valid together."""
        chain = self.chain()
        self.settings()
        if self.method not in methods_for(chain):
            allowed = ", ".join(methods_for(chain))
            raise LinkageError(f"method = {self.method}: not available for this mechanism; allowed: {allowed}")
        if self.trace.bar > self.n:
            raise LinkageError(f"trace.bar = {self.trace.bar}: the mechanism has {self.n} bars")
        physics.model.check_state(self.n, self.theta0, self.omega0)
        if chain.pinned:
            gap = assembly.loop_residual(self.L, self.theta0, self.pin)
            if not float(np.hypot(*gap)) <= 1e-8:
                raise LinkageError(f"the start does not close the loop (tip misses the pin by {np.hypot(*gap):.3g})")

    def changed(self, **updates) -> "SessionParameters":
        """A validated copy with ``updates`` applied; raises LinkageError and leaves ``self`` untouched."""
        new = copy.deepcopy(self)
        for key, value in updates.items():
            if not hasattr(new, key):
                raise LinkageError(f"unknown parameter {key!r}")
            setattr(new, key, value)
        new.validate()
        return new

    def assembled(self, theta_driving, theta_prev=None) -> np.ndarray:
        """Start angles of a closed loop from its driving angles (physics.assembly); LinkageError if unreachable."""
        return assembly.assemble(self.L, self.pin, np.asarray(theta_driving, float), theta_prev=theta_prev)

    def trace_choices(self) -> dict[str, TracePoint]:
        """Points the trace can follow: the preset's coupler point (if it has one), the tip, every joint and
        centre of mass. The first entry is the default."""
        standard = {"tip H": TracePoint(bar=self.n, along=self.L[-1])}
        for k in range(1, self.n):
            standard[f"joint {k}"] = TracePoint(bar=k, along=self.L[k - 1])
        for k in range(1, self.n + 1):
            standard[f"centre of mass {k}"] = TracePoint(bar=k, along=self.d[k - 1])
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
            "bars": [
                {"L": float(self.L[i]), "d": float(self.d[i]), "m": float(self.m[i]), "I": float(self.I[i])}
                for i in range(self.n)
            ],
            "g": float(self.g),
            "pin": [float(v) for v in self.pin] if self.pin is not None else None,
            "theta0": [float(v) for v in self.theta0],
            "omega0": [float(v) for v in self.omega0],
            "trace": {"bar": self.trace.bar, "along": self.trace.along, "across": self.trace.across},
            "method": self.method,
            "integrator": self.integrator,
            "rtol": self.tolerance,
            "atol": self.tolerance,
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
