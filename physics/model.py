"""The boundary: pydantic models that own every bound, and their one-line error messages.

Everything user-supplied (command-line ``--set``, JSON cases, app sliders) enters through
:func:`make_chain`, :class:`Settings` or :func:`apply_overrides`; past this module the code
works on plain float arrays (``Chain.params()``) and never re-checks.
"""

from __future__ import annotations

import math
from typing import Literal, Optional

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from .errors import LinkageError
from .kinematics import mass_matrix
from .registry import (
    BACKENDS,
    COMPILED_INTEGRATORS,
    DEFAULT_BACKEND,
    FIXED_STEP_INTEGRATORS,
    FORMULATION_NAMES,
    INTEGRATOR_NAMES,
    INTEGRATORS,
    METHOD_NAMES,
    STABILIZATIONS,
    backend_for,
    incompatibility,
)

__all__ = [
    "COMPILED_INTEGRATORS",
    "FIXED_STEP_INTEGRATORS",
    "FORMULATION_NAMES",
    "INTEGRATOR_NAMES",
    "METHOD_NAMES",
    "STABILIZATIONS",
    "Bar",
    "Chain",
    "Settings",
    "TracePoint",
    "apply_overrides",
    "check_state",
    "make_chain",
    "parameter_names",
    "validated",
]

MAX_LINKS = 12

# Upper bounds of the physical inputs: far beyond any linkage a course or a lab builds, and low enough that
# the energies, the mass matrix and the angles stay well inside double precision (L = 1e308 used to pass and
# overflow in the mass matrix). docs/reliability.md lists them.
MAX_LENGTH = 1e3  # m
MAX_MASS = 1e6  # kg
MAX_INERTIA = 1e12  # kg m^2 (a 1e6 kg bar 1 km long has m L^2 / 12 = 8.3e10)
MAX_GRAVITY = 1e3  # m/s^2, about 100 g
MAX_ANGLE = 1e4  # rad, about 1600 turns from the reference direction
MAX_ANGULAR_SPEED = 1e4  # rad/s

# The allowed values of Settings' name fields, built from the registry (physics.registry) so that a new
# integrator or formulation is declared once. mypy cannot see through a Literal built at run time.
MethodName = Literal[METHOD_NAMES]  # type: ignore[valid-type]
IntegratorName = Literal[INTEGRATOR_NAMES]  # type: ignore[valid-type]
BackendName = Literal[BACKENDS]  # type: ignore[valid-type]
StabilizationName = Literal[STABILIZATIONS]  # type: ignore[valid-type]

# Baumgarte gains: critically damped constraint error (alpha = beta), time constant 1/alpha = 0.1 s, two
# orders of magnitude faster than the seed four-bar's swing (about 9.4 s), so drift is pulled back long before
# it grows. The price is mild stiffness: the adaptive integrator's steps shrink to follow the 0.1 s
# constraint dynamics (858 -> 3017 DOP853 steps over the seed's 100 s, measured); larger gains cost more
# steps for little gain (alpha = beta = 100: 27620 steps). docs/physics.md has the figures.
BAUMGARTE_ALPHA = 10.0
BAUMGARTE_BETA = 10.0

# Relative size of the smallest mass-matrix eigenvalue below which a chain is rejected as singular.
SINGULAR_MASS_RTOL = 1e-12
# kg m^2: the least inertia an angle may carry about its joint (a milligram at a millimetre's radius of gyration is
# 1e-12; with margin), the same floor as a general mechanism's bodies (physics/mechanism/validation.py). Far
# below it the motion is numerically meaningless: a bar of I = 1.2e-38 kg m^2 with a damped pin needed more
# integrator steps for one sample than a run may take.
MIN_JOINT_INERTIA = 1e-9


def _finite(name: str, value) -> float:
    """Checked before the range checks, so NaN is reported as "not finite" rather than "not >= 0"."""
    # Strict: a number, never text ("1") or a boolean (true is not 1 kg); the command line parses its text
    # options into numbers before they get here.
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} = {value!r}: must be a number, got {type(value).__name__}")
    try:
        number = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name} = {value!r}: must be a number") from None
    if not math.isfinite(number):
        raise ValueError(f"{name} = {value}: must be a finite number")
    return number


class Bar(BaseModel):
    """One rigid bar: length ``L``, centre-of-mass distance ``d`` from its proximal joint, mass ``m``,
    centroidal moment of inertia ``I``."""

    model_config = ConfigDict(frozen=True)

    L: float = Field(1.0, ge=0.0, le=MAX_LENGTH, description="length")
    d: float = Field(0.5, ge=0.0, description="centre-of-mass distance from the proximal joint")
    m: float = Field(1.0, ge=0.0, le=MAX_MASS, description="mass")
    I: float = Field(0.1, ge=0.0, le=MAX_INERTIA, description="centroidal moment of inertia")

    @field_validator("L", "d", "m", "I", mode="before")
    @classmethod
    def _check_finite(cls, value: float, info) -> float:
        return _finite(info.field_name, value)

    @model_validator(mode="after")
    def _check_d_within_bar(self) -> "Bar":
        if self.d > self.L:
            raise ValueError(f"d = {self.d} exceeds L = {self.L}: allowed range 0 <= d <= L")
        return self


class TracePoint(BaseModel):
    """A point fixed on bar ``bar`` (1-based): ``along`` the bar from its proximal joint, ``across`` it
    (counter-clockwise side positive). The tip is ``TracePoint(bar=n, along=L_n)``."""

    model_config = ConfigDict(frozen=True)

    bar: int = Field(ge=1, le=MAX_LINKS, strict=True)
    # within a sketch's reach (the bars are at most MAX_LENGTH long): 1e308 would overflow the traced path
    along: float = Field(ge=-MAX_LENGTH, le=MAX_LENGTH)
    across: float = Field(0.0, ge=-MAX_LENGTH, le=MAX_LENGTH)

    @field_validator("along", "across", mode="before")
    @classmethod
    def _check_finite(cls, value: float, info) -> float:
        return _finite(info.field_name, value)


class Chain(BaseModel):
    """A planar chain of bars hinged end to end from the fixed origin O; optionally its tip pinned at ``pin``."""

    model_config = ConfigDict(frozen=True)

    bars: list[Bar] = Field(min_length=1, max_length=MAX_LINKS)
    g: float = Field(1.0, ge=0.0, le=MAX_GRAVITY, description="gravity")
    pin: Optional[tuple[float, float]] = None

    @field_validator("g", mode="before")
    @classmethod
    def _check_g(cls, value: float) -> float:
        return _finite("g", value)

    @field_validator("pin")
    @classmethod
    def _check_pin(cls, value):
        if value is not None:
            for name, v in zip(("pin_x", "pin_y"), value):
                _finite(name, v)
        return value

    @property
    def n(self) -> int:
        return len(self.bars)

    @property
    def pinned(self) -> bool:
        return self.pin is not None

    def array(self, field: str) -> np.ndarray:
        return np.array([getattr(bar, field) for bar in self.bars], dtype=float)

    def params(self, damping: float = 0.0) -> np.ndarray:
        """``[L_1..L_n, d_1..d_n, m_1..m_n, I_1..I_n, g, pin_x, pin_y, damping]`` (docs/architecture.md)."""
        pin = self.pin if self.pin is not None else (0.0, 0.0)
        return np.concatenate(
            [self.array("L"), self.array("d"), self.array("m"), self.array("I"), [self.g, pin[0], pin[1], damping]]
        )

    def with_pin(self, pin: Optional[tuple[float, float]]) -> "Chain":
        return Chain(bars=self.bars, g=self.g, pin=pin)


DEFAULT_MAX_STEPS = 10_000_000  # about 20 s of integration for a triple pendulum
MAX_STEPS_LIMIT = 1_000_000_000  # about an hour: beyond it a request is out of proportion for this tool
MIN_RTOL = 1e-14
MIN_ATOL = 1e-16
# A general mechanism's run takes the one Settings below within tighter spans (its samples are heavier; documented
# in docs/mechanisms.md): physics.mechanism.simulate.run_options checks them, the app's mechanism panel reads them.
MECHANISM_MAX_T_END = 1e4  # s
MECHANISM_MAX_SAMPLES = 1_000_000
MECHANISM_MAX_TOLERANCE = 1e-2  # rtol and atol


class Settings(BaseModel):
    """How to integrate: formulation, integrator, tolerances, horizon, stabilisation of closed loops."""

    model_config = ConfigDict(frozen=True)

    method: MethodName = "lagrange"
    integrator: IntegratorName = "DOP853"
    backend: BackendName = DEFAULT_BACKEND
    # Below 1e-14 relative (about 50 ulp) no step meets the tolerance and the step size collapses, which used to
    # be reported as a singular position; refused with the range instead.
    rtol: float = Field(1e-10, ge=MIN_RTOL, le=0.1)
    atol: float = Field(1e-10, ge=MIN_ATOL, le=0.1)
    t_end: float = Field(20.0, gt=0.0, le=1e6)
    samples: int = Field(201, ge=2, le=10_000_000, strict=True)
    stabilization: StabilizationName = "projection"
    baumgarte_alpha: float = Field(BAUMGARTE_ALPHA, ge=0.0, le=1e4)
    baumgarte_beta: float = Field(BAUMGARTE_BETA, ge=0.0, le=1e4)
    damping: float = Field(0.0, ge=0.0, le=1e3, description="viscous damping torque per unit relative joint speed")
    step: float = Field(1e-3, gt=0.0, le=1.0, description="fixed step of the midpoint and variational integrators")
    trace: Optional[TracePoint] = None
    max_steps: int = Field(DEFAULT_MAX_STEPS, ge=1, le=MAX_STEPS_LIMIT, strict=True,
                           description="integration steps allowed before a run is stopped")

    @field_validator("rtol", "atol", "t_end", "step", "baumgarte_alpha", "baumgarte_beta", "damping", mode="before")
    @classmethod
    def _check_finite(cls, value: float, info) -> float:
        return _finite(info.field_name, value)

    @model_validator(mode="after")
    def _check_backend(self) -> "Settings":
        # Radau and LSODA exist only in scipy; asking for them (on the default back end) means asking for scipy.
        object.__setattr__(self, "backend", backend_for(self.integrator, self.backend))
        # A fixed-step integrator on scipy, or the variational integrator (it discretises the Lagrangian T - V
        # itself) on a formulation without one: refused with the fix.
        problem = incompatibility(self.method, self.integrator, self.backend)
        if problem:
            raise ValueError(problem)
        if INTEGRATORS[self.integrator].fixed_step:
            # A fixed-step run's cost is known before it starts: refuse one out of proportion up front.
            steps = math.ceil(self.t_end / self.step * (1.0 - 1e-12))
            if steps > self.max_steps:
                raise ValueError(
                    f"integrator = {self.integrator}: t_end / step = {self.t_end:g} / {self.step:g} = {steps:.3g} "
                    f"steps, more than max_steps = {self.max_steps:.3g} (about {steps * 2e-6:.3g} s at 2 us a "
                    f"step); use a larger step, a shorter t_end, or raise max_steps (at most {MAX_STEPS_LIMIT:.0e})"
                )
        return self


# ---------------------------------------------------------------------------------------------
# Turning pydantic's errors into one clear line that names the field as the user spells it.

_FIELD_RANGE = {
    "L": f"0 <= L <= {MAX_LENGTH:g} m",
    "d": "0 <= d <= L",
    "m": f"0 <= m <= {MAX_MASS:g} kg",
    "I": f"0 <= I <= {MAX_INERTIA:g} kg m^2",
    "g": f"0 <= g <= {MAX_GRAVITY:g} m/s^2",
    "rtol": f"{MIN_RTOL:g} <= rtol <= 0.1",
    "atol": f"{MIN_ATOL:g} <= atol <= 0.1",
    "t_end": "0 < t_end <= 1e6",
    "samples": "2 <= samples",
    "step": "0 < step <= 1",
    "along": f"-{MAX_LENGTH:g} <= along <= {MAX_LENGTH:g} m",
    "across": f"-{MAX_LENGTH:g} <= across <= {MAX_LENGTH:g} m",
}


def _format_validation_error(error: ValidationError) -> str:
    parts = []
    for item in error.errors():
        loc = list(item.get("loc", ()))
        name = ""
        if len(loc) >= 3 and loc[0] == "bars" and isinstance(loc[1], int):
            field = str(loc[2])
            name = f"{field}{loc[1] + 1}"
        elif len(loc) == 2 and loc[0] == "bars" and isinstance(loc[1], int):
            field = "d"
            name = f"d{loc[1] + 1}"
        elif loc:
            field = str(loc[-1]) if not isinstance(loc[-1], int) else str(loc[0])
            name = ".".join(str(p) for p in loc)
        else:
            field = ""
        msg = str(item.get("msg", "invalid"))
        msg = msg.removeprefix("Value error, ")
        value = item.get("input")
        allowed = _FIELD_RANGE.get(field)
        text = f"{name}: {msg}"
        if not isinstance(value, (dict, list)) and value is not None and str(value) not in msg:
            text = f"{name} = {value}: {msg}"
        if allowed and allowed not in text:
            text += f" (allowed range: {allowed})"
        parts.append(text)
    return "; ".join(parts)


def validated(model_cls, **kwargs):
    """Build a pydantic model, turning a ValidationError into a LinkageError with one readable line."""
    try:
        return model_cls(**kwargs)
    except ValidationError as error:
        raise LinkageError(_format_validation_error(error)) from None


def make_chain(L, d, m, I, g=1.0, pin=None) -> Chain:
    """Validated chain from per-bar sequences; also rejects a singular mass matrix, naming the bar."""
    lengths = [len(L), len(d), len(m), len(I)]
    if len(set(lengths)) != 1:
        raise LinkageError(f"L, d, m, I must have one entry per bar; got lengths {lengths}")
    n = lengths[0]
    if not 1 <= n <= MAX_LINKS:
        raise LinkageError(f"links = {n}: allowed range 1 <= links <= {MAX_LINKS}")
    chain = validated(
        Chain,
        bars=[{"L": L[i], "d": d[i], "m": m[i], "I": I[i]} for i in range(n)],
        g=g,
        pin=pin,
    )
    check_mass_matrix(chain)
    return chain


def check_mass_matrix(chain: Chain) -> None:
    """Reject a chain whose mass matrix is singular, naming the bar that carries no inertia and the fix.

    Bar k's angular velocity moves its own mass (``m_k d_k^2 + I_k``) and every mass beyond it on the lever
    ``L_k``; when all of that vanishes the angle has no inertia and its acceleration is undetermined.
    """
    n = chain.n
    L, d, m, I = (chain.array(f) for f in "LdmI")
    for k in range(n - 1, -1, -1):
        beyond = m[k + 1 :].sum()
        inertia = m[k] * d[k] ** 2 + I[k] + L[k] ** 2 * beyond
        if inertia <= 0.0:
            raise LinkageError(
                f"bar {k + 1} has no inertia (m{k + 1}*d{k + 1}^2 + I{k + 1} + L{k + 1}^2 * mass beyond = 0): "
                f"the mass matrix is singular; give bar {k + 1} a positive I{k + 1}, or m{k + 1} > 0 with d{k + 1} > 0"
            )
        if inertia < MIN_JOINT_INERTIA:
            raise LinkageError(
                f"bar {k + 1}'s inertia about its joint (m{k + 1}*d{k + 1}^2 + I{k + 1} + L{k + 1}^2 * mass beyond) "
                f"= {inertia:.3g} kg·m²: allowed range >= {MIN_JOINT_INERTIA:g} kg·m²; give bar {k + 1} a larger "
                f"I{k + 1}, or more mass m{k + 1} at a larger d{k + 1}"
            )
    theta = np.linspace(0.3, 2.9, n) + 0.17 * np.arange(n) ** 2  # a generic configuration
    M = mass_matrix(chain.params(), theta)
    eig = np.linalg.eigvalsh(M)
    if eig[0] <= SINGULAR_MASS_RTOL * max(eig[-1], 1e-300):
        null = np.linalg.eigh(M)[1][:, 0]
        k = int(np.flatnonzero(np.abs(null) > 1e-6)[-1])
        raise LinkageError(
            f"the mass matrix is singular (bar {k + 1} and the bars before it carry no independent inertia); "
            f"give bar {k + 1} a positive I{k + 1}"
        )


PARAMETER_FIELDS = ("L", "d", "m", "I")


def parameter_names(n: int) -> list[str]:
    """The names accepted by ``--set`` and JSON cases for an n-bar chain."""
    names = [f"{f}{i}" for f in PARAMETER_FIELDS for i in range(1, n + 1)]
    return names + ["g"] + [f"theta{i}" for i in range(1, n + 1)] + [f"omega{i}" for i in range(1, n + 1)]


def _parse_float(name: str, text) -> float:
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise LinkageError(f"{name} = {text!r}: not a number") from None
    if not math.isfinite(value):
        raise LinkageError(f"{name} = {text}: must be a finite number")
    return value


def apply_overrides(chain: Chain, theta, omega, overrides: dict) -> tuple[Chain, np.ndarray, np.ndarray]:
    """Apply ``{"L3": 2.0, "theta1": 0.3, ...}`` to a chain and start state; unknown names are an error."""
    n = chain.n
    values = {f: list(chain.array(f)) for f in PARAMETER_FIELDS}
    g = chain.g
    theta = np.array(theta, dtype=float)
    omega = np.array(omega, dtype=float)
    allowed = parameter_names(n)
    for name, raw in overrides.items():
        if name not in allowed:
            raise LinkageError(
                f"unknown parameter {name!r} for a {n}-link chain; allowed: L1..L{n}, d1..d{n}, m1..m{n}, "
                f"I1..I{n}, g, theta1..theta{n}, omega1..omega{n}"
            )
        value = _parse_float(name, raw)
        if name == "g":
            g = value
        elif name.startswith("theta"):
            theta[int(name[5:]) - 1] = value
        elif name.startswith("omega"):
            omega[int(name[5:]) - 1] = value
        else:
            values[name[0]][int(name[1:]) - 1] = value
    new_chain = make_chain(values["L"], values["d"], values["m"], values["I"], g=g, pin=chain.pin)
    return new_chain, theta, omega


def check_state(n: int, theta, omega) -> tuple[np.ndarray, np.ndarray]:
    """Plain float arrays of shape (n,), finite, or a LinkageError naming the entry."""
    theta = np.asarray(theta, dtype=float).reshape(-1)
    omega = np.asarray(omega, dtype=float).reshape(-1)
    for name, arr in (("theta", theta), ("omega", omega)):
        if arr.shape != (n,):
            raise LinkageError(f"{name} must have {n} entries (one per bar), got {arr.shape[0]}")
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise LinkageError(f"{name}{bad[0] + 1} = {arr[bad[0]]}: must be a finite number")
    for name, arr, limit, unit in (("theta", theta, MAX_ANGLE, "rad"), ("omega", omega, MAX_ANGULAR_SPEED, "rad/s")):
        bad = np.flatnonzero(np.abs(arr) > limit)
        if bad.size:
            raise LinkageError(
                f"{name}{bad[0] + 1} = {arr[bad[0]]:g}: allowed range -{limit:g} <= {name} <= {limit:g} {unit}"
            )
    return theta, omega
