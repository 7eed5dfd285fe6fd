"""Position and velocity analysis of a closed loop: a chain of n bars whose tip is pinned at ``pin``.

The loop closes when the tip lands on the pin, ``tip(theta) = pin``: two equations in n angles, so a
pinned chain keeps ``n - 2`` degrees of freedom (one for the four-bar, n = 3). Here the first ``n - 2``
angles drive; the last two are found in closed form as the intersection of two circles. Two solutions
exist (two *branches*, mirror images about the line from joint n-2 to the pin); they meet where bars
n-1 and n are collinear, the *dead centres* at the ends of the driving range.

Conventions are those of docs/architecture.md: ``theta_i`` absolute from the downward vertical,
counter-clockwise positive; bar i points along ``e_i = (sin theta_i, -cos theta_i)``. A student's
guide with the seed four-bar's numbers is docs/closed-loops.md.

Everything here is plain numpy and ``math``; shapes are ``L (n,)``, ``pin (2,)``, ``theta (n,)``
(or ``(..., n)`` where a docstring says batched).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import LinkageError

# A loop that misses closure by less than this fraction of its bar lengths counts as exactly closed
# at the limit: the ends of a driving range, computed in closed form, then assemble instead of
# raising on the last bit of rounding.
CLOSURE_RTOL = 1e-12

# Relative tolerance of the change-point equality s + l = p + q (relative to s + l + p + q).
CHANGE_POINT_RTOL = 1e-9

# Reciprocal condition below which a 2 x 2 dependent Jacobian counts as singular when velocities are
# solved from it: a driving speed imposed at a dead centre has no consistent completion, and one located in
# closed form is only found to ~sqrt(machine epsilon) ~ 1e-8 in angle, where the solved speeds would be
# ~1e8 times the driving speed: noise, not an answer.
VELOCITY_RCOND = 1e-6

GRASHOF_CLASSES = (
    "Grashof (crank-rocker)",
    "Grashof (double-crank)",
    "Grashof (double-rocker)",
    "change-point",
    "non-Grashof (triple-rocker)",
)

# The three dead-centre events of a four-bar and the bars (1-based) whose angle between them vanishes.
DEAD_CENTRE_EVENTS = {"fold": (2, 3), "straighten": (1, 2), "parallel": (1, 3)}


# --------------------------------------------------------------------------------------------------
# Loop closure


def _as_lengths(L) -> np.ndarray:
    L = np.asarray(L, dtype=float).reshape(-1)
    if L.size < 2:
        raise LinkageError(f"L: a closed loop needs at least 2 bars, got {L.size}")
    return L


def tip_position(L, theta) -> np.ndarray:
    """Tip (joint n) position, shape ``theta.shape[:-1] + (2,)``; batched over leading axes."""
    L = np.asarray(L, dtype=float)
    theta = np.asarray(theta, dtype=float)
    return np.stack([np.sum(L * np.sin(theta), axis=-1), -np.sum(L * np.cos(theta), axis=-1)], axis=-1)


def loop_residual(L, theta, pin) -> np.ndarray:
    """``tip - pin``: zero when the loop is closed. Shape ``theta.shape[:-1] + (2,)``."""
    return tip_position(L, theta) - np.asarray(pin, dtype=float)


def loop_jacobian(L, theta) -> np.ndarray:
    """``d tip / d theta``, shape ``theta.shape[:-1] + (2, n)``: column i is ``L_i (cos theta_i, sin theta_i)``."""
    L = np.asarray(L, dtype=float)
    theta = np.asarray(theta, dtype=float)
    return np.stack([L * np.cos(theta), L * np.sin(theta)], axis=-2)


def direction_angle(x: float, y: float) -> float:
    """The angle ``theta`` (from the downward vertical, counter-clockwise) of the vector ``(x, y)``."""
    return math.atan2(x, -y)


def wrap_near(angle: float, reference: float) -> float:
    """``angle + 2 pi k`` closest to ``reference``."""
    return angle + 2.0 * math.pi * round((reference - angle) / (2.0 * math.pi))


def solve_two_bars(wx: float, wy: float, a: float, b: float, elbow: int) -> tuple[float, float] | None:
    """Angles ``(theta_a, theta_b)`` with ``a e_a + b e_b = w``, or ``None`` if the two bars cannot span w.

    ``elbow = +1`` puts the joint between the bars on the counter-clockwise (left) side of ``w``, which is
    ``sin(theta_b - theta_a) < 0``; ``elbow = -1`` is the mirror image. At a dead centre both coincide.
    """
    D = math.hypot(wx, wy)
    slack = CLOSURE_RTOL * (a + b + D)
    if D > a + b + slack or D < abs(a - b) - slack:
        return None
    beta = direction_angle(wx, wy)
    if D <= slack:  # the two bars fold back onto one point: any theta_a works when a == b
        theta_a = beta
        return theta_a, theta_a + math.pi
    cos_gamma = (a * a + D * D - b * b) / (2.0 * a * D) if a > 0.0 else 1.0
    gamma = math.acos(min(1.0, max(-1.0, cos_gamma)))
    theta_a = beta + elbow * gamma
    bx, by = wx - a * math.sin(theta_a), wy + a * math.cos(theta_a)
    theta_b = direction_angle(bx, by) if b > 0.0 else theta_a
    return theta_a, theta_b


def elbow_of(theta_a: float, theta_b: float) -> int:
    """The branch (+1 or -1, see :func:`solve_two_bars`) a pair of bar angles lies on."""
    return 1 if math.sin(theta_b - theta_a) <= 0.0 else -1


def _driving_label(theta_driving: np.ndarray) -> str:
    if theta_driving.size == 1:
        return f"theta1={theta_driving[0]:.6g}"
    values = ", ".join(f"{v:.6g}" for v in theta_driving)
    return f"theta1..theta{theta_driving.size}=({values})"


def assemble(L, pin, theta_driving, theta_prev=None, elbow: int | None = None) -> np.ndarray:
    """Close the loop: given the first ``n - 2`` angles, solve the last two (position analysis).

    Parameters
    ----------
    L : (n,) bar lengths, n >= 2.
    pin : (2,) ground point holding the tip.
    theta_driving : (n - 2,) the driving angles theta_1 .. theta_{n-2} (theta1 alone for a four-bar).
    theta_prev : (n,), optional. The previous configuration: the branch nearest to it is chosen and the
        solved angles are unwrapped to lie nearest its entries, so a slider sweeping theta1 moves the
        linkage continuously.
    elbow : +1 or -1, optional. Force a branch (see :func:`solve_two_bars`); overrides ``theta_prev``'s
        choice. Default without either: ``elbow = +1``, joint n-1 on the counter-clockwise side of the
        line from joint n-2 to the pin (the seed four-bar starts on it).

    Returns
    -------
    theta : (n,) with ``theta[:n-2] == theta_driving`` and the tip on the pin.

    Raises
    ------
    LinkageError
        When no assembly exists: the message names the driving angle and the gap by which the loop fails
        to close (distance from joint n-2 to the pin minus ``L_{n-1} + L_n``, or ``|L_{n-1} - L_n|`` minus it).
    """
    L = _as_lengths(L)
    n = L.size
    pin = np.asarray(pin, dtype=float).reshape(2)
    theta_driving = np.asarray(theta_driving, dtype=float).reshape(-1)
    if theta_driving.size != n - 2:
        raise LinkageError(
            f"theta_driving: a loop of {n} bars is driven by {n - 2} angle(s) (theta1..theta{n - 2}), "
            f"got {theta_driving.size}"
        )
    if theta_prev is not None:
        theta_prev = np.asarray(theta_prev, dtype=float).reshape(-1)
        if theta_prev.size != n:
            raise LinkageError(f"theta_prev: expected {n} angles, got {theta_prev.size}")
    if elbow not in (None, 1, -1):
        raise LinkageError(f"elbow = {elbow}: allowed values +1 or -1")

    start_x = float(np.sum(L[: n - 2] * np.sin(theta_driving)))
    start_y = float(-np.sum(L[: n - 2] * np.cos(theta_driving)))
    wx, wy = pin[0] - start_x, pin[1] - start_y
    a, b = L[n - 2], L[n - 1]
    if elbow is None and theta_prev is None:
        elbow = 1
    branches = (elbow,) if elbow is not None else (1, -1)
    candidates = [solve_two_bars(wx, wy, a, b, e) for e in branches]
    if candidates[0] is None:
        distance = math.hypot(wx, wy)
        joint = f"joint {n - 2}" if n > 2 else "the origin O"
        if distance > a + b:
            detail = (
                f"{joint} is {distance:.6g} from the pin but bars {n - 1} and {n} reach at most "
                f"L{n - 1}+L{n} = {a + b:.6g}: gap {distance - (a + b):.3g}"
            )
        else:
            detail = (
                f"{joint} is {distance:.6g} from the pin but bars {n - 1} and {n} span at least "
                f"|L{n - 1}-L{n}| = {abs(a - b):.6g}: gap {abs(a - b) - distance:.3g}"
            )
        allowed = ""
        if n == 3:
            ranges = driving_range(L, pin)
            allowed = "; allowed theta1: " + (
                " or ".join(f"[{lo:.6g}, {hi:.6g}]" for lo, hi in ranges) if ranges else "none (the loop never closes)"
            )
        raise LinkageError(f"the loop cannot close at {_driving_label(theta_driving)}: {detail}{allowed}")

    if theta_prev is not None:
        ref_a, ref_b = theta_prev[n - 2], theta_prev[n - 1]

        def distance_to_prev(pair):
            return (wrap_near(pair[0], ref_a) - ref_a) ** 2 + (wrap_near(pair[1], ref_b) - ref_b) ** 2

        theta_a, theta_b = min((c for c in candidates if c is not None), key=distance_to_prev)
        theta_a, theta_b = wrap_near(theta_a, ref_a), wrap_near(theta_b, ref_b)
    else:
        theta_a, theta_b = candidates[0]
    return np.concatenate([theta_driving, [theta_a, theta_b]])


def project_velocity(L, theta, omega) -> np.ndarray:
    """Angular velocities ``(n,)`` that keep the tip still, ``J omega = 0``.

    ``omega`` of length ``n - 2`` is the driving speed: the last two are solved from the velocity
    constraint. ``omega`` of length ``n`` is projected onto the null space of ``J`` (the closest
    consistent velocity in the Euclidean norm, i.e. minimum-norm correction).
    """
    L = _as_lengths(L)
    n = L.size
    theta = np.asarray(theta, dtype=float).reshape(n)
    omega = np.asarray(omega, dtype=float).reshape(-1)
    J = loop_jacobian(L, theta)
    if omega.size == n:
        correction = np.linalg.lstsq(J, J @ omega, rcond=None)[0]
        return omega - correction
    if omega.size != n - 2:
        raise LinkageError(f"omega: expected {n - 2} driving speeds or {n} angular velocities, got {omega.size}")
    J_dep = J[:, n - 2 :]
    s = np.linalg.svd(J_dep, compute_uv=False)
    if s[1] <= VELOCITY_RCOND * max(s[0], 1e-300):
        raise LinkageError(
            f"omega: bars {n - 1} and {n} are collinear (a dead centre) at this configuration, so the driving "
            f"speed does not fix their velocities; drive from a configuration away from the dead centre"
        )
    omega_dep = np.linalg.solve(J_dep, -J[:, : n - 2] @ omega)
    return np.concatenate([omega, omega_dep])


# --------------------------------------------------------------------------------------------------
# Four-bar classification and range


@dataclass(frozen=True)
class GrashofReport:
    """Grashof classification of a four-bar (ground, input bar 1, coupler bar 2, output bar 3).

    ``s, l`` are the shortest and longest link lengths, ``p, q`` the other two; ``margin = (p + q) - (s + l)``
    (positive: Grashof, zero: change point, negative: non-Grashof); ``shortest`` names the shortest link.
    """

    ground_length: float
    linkage_class: str
    shortest: str
    s: float
    l: float
    p: float
    q: float
    margin: float

    def as_dict(self) -> dict:
        """JSON shape used by ``presets`` and ``accelerations``: ``class`` holds :attr:`linkage_class`."""
        return {
            "class": self.linkage_class,
            "ground_length": self.ground_length,
            "shortest": self.shortest,
            "s": self.s,
            "l": self.l,
            "p": self.p,
            "q": self.q,
            "margin": self.margin,
        }


def grashof(L, pin) -> GrashofReport:
    """Grashof class of a pinned 3-bar chain (a four-bar whose ground link runs from O to the pin).

    Rule (Grashof's criterion, with s <= p, q <= l the four link lengths):

    * ``s + l = p + q`` (to ``CHANGE_POINT_RTOL``): **change-point**; the linkage can become fully collinear.
    * ``s + l < p + q``: Grashof, the shortest link turns fully relative to the others, and the class is set by
      where the shortest link sits: the ground -> double-crank; bar 1 or bar 3 (a link next to the ground)
      -> crank-rocker; the coupler (bar 2) -> double-rocker.
    * ``s + l > p + q``: **non-Grashof (triple-rocker)**; no link turns fully.

    In the strict Grashof case the shortest link is unique (two equal shortest links force ``s + l >= p + q``).
    """
    L = _as_lengths(L)
    if L.size != 3:
        raise LinkageError(f"L: the Grashof class is defined for a four-bar (3 bars and the ground), got {L.size} bars")
    pin = np.asarray(pin, dtype=float).reshape(2)
    ground = float(math.hypot(pin[0], pin[1]))
    names = ("ground", "input (bar 1)", "coupler (bar 2)", "output (bar 3)")
    lengths = np.array([ground, L[0], L[1], L[2]])
    order = np.argsort(lengths, kind="stable")
    s, p, q, l = (float(lengths[k]) for k in order)
    margin = (p + q) - (s + l)
    shortest = int(order[0])
    if abs(margin) <= CHANGE_POINT_RTOL * (s + l + p + q):
        linkage_class = "change-point"
    elif margin < 0.0:
        linkage_class = "non-Grashof (triple-rocker)"
    elif shortest == 0:
        linkage_class = "Grashof (double-crank)"
    elif shortest == 2:
        linkage_class = "Grashof (double-rocker)"
    else:
        linkage_class = "Grashof (crank-rocker)"
    return GrashofReport(ground, linkage_class, names[shortest], s, l, p, q, margin)


def _normalise_interval(lo: float, hi: float) -> tuple[float, float]:
    shift = 2.0 * math.pi * math.floor((lo + math.pi) / (2.0 * math.pi))
    return lo - shift, hi - shift


def driving_range(L, pin) -> list[tuple[float, float]]:
    """The intervals of theta1 over which a four-bar (n = 3) assembles, in closed form.

    Joint 1 sits at distance ``D(theta1)`` from the pin with ``D^2 = G^2 + L1^2 - 2 G L1 cos(theta1 - alpha)``
    (G = |pin|, alpha = direction of the pin). The loop closes when ``|L2 - L3| <= D <= L2 + L3``, i.e. when
    ``cos(theta1 - alpha)`` lies between two bounds. Result: zero, one or two intervals ``(lo, hi)`` with
    ``lo`` in ``[-pi, pi)`` and ``lo < hi`` (``hi`` may exceed pi); a full turn is one interval of width 2 pi.
    """
    L = _as_lengths(L)
    if L.size != 3:
        raise LinkageError(f"L: driving_range is defined for a four-bar (3 bars), got {L.size} bars")
    pin = np.asarray(pin, dtype=float).reshape(2)
    L1, L2, L3 = (float(v) for v in L)
    G = math.hypot(pin[0], pin[1])
    outer, inner = L2 + L3, abs(L2 - L3)
    slack = CLOSURE_RTOL * (G + L1 + L2 + L3)
    if G * L1 <= 0.0:  # joint 1 stays at distance G + L1 (one of them is zero) from the pin
        D = G + L1
        return [(-math.pi, math.pi)] if inner - slack <= D <= outer + slack else []
    alpha = direction_angle(pin[0], pin[1])
    cos_high = (G * G + L1 * L1 - inner * inner) / (2.0 * G * L1)  # D >= inner
    cos_low = (G * G + L1 * L1 - outer * outer) / (2.0 * G * L1)  # D <= outer
    rel = slack * (G + L1) / (G * L1)
    if cos_high < -1.0 - rel or cos_low > 1.0 + rel or cos_low > cos_high + rel:
        return []
    A = math.acos(min(1.0, max(-1.0, cos_high)))  # |phi| >= A
    B = math.acos(min(1.0, max(-1.0, cos_low)))  # |phi| <= B
    if A <= 0.0 and B >= math.pi:
        return [_normalise_interval(alpha - math.pi, alpha + math.pi)]
    if A <= 0.0:
        return [_normalise_interval(alpha - B, alpha + B)]
    if B >= math.pi:
        return [_normalise_interval(alpha + A, alpha + 2.0 * math.pi - A)]
    return sorted([_normalise_interval(alpha + A, alpha + B), _normalise_interval(alpha - B, alpha - A)])


# --------------------------------------------------------------------------------------------------
# Singular positions


def loop_singular_values(L, theta) -> np.ndarray:
    """Singular values ``(sigma_1 >= sigma_2)`` of the loop Jacobian J (2 x n); batched ``(..., 2)``."""
    return np.linalg.svd(loop_jacobian(L, theta), compute_uv=False)


def loop_condition(L, theta):
    """Condition number ``sigma_1 / sigma_2`` of the loop Jacobian J (``cond(J J^T)`` is its square).

    Infinite where the whole loop is singular: every bar collinear, the position a change-point four-bar
    passes through. Batched over leading axes of ``theta``.
    """
    sv = loop_singular_values(L, theta)
    with np.errstate(divide="ignore"):
        cond = np.where(sv[..., 1] > 0.0, sv[..., 0] / np.where(sv[..., 1] > 0.0, sv[..., 1], 1.0), np.inf)
    return float(cond) if np.ndim(cond) == 0 else cond


def dead_centre_metrics(theta) -> np.ndarray:
    """Sines of the angles between bars 2&3, 1&2 and 1&3 of a four-bar; shape ``theta.shape[:-1] + (3,)``.

    Order as :data:`DEAD_CENTRE_EVENTS`: ``fold`` (bars 2, 3), ``straighten`` (bars 1, 2), ``parallel``
    (bars 1, 3). Each passes through zero when its two bars become collinear (folded or stretched); there
    the remaining angle (theta1, theta3, theta2 respectively) reverses and stops being a valid coordinate.
    """
    theta = np.asarray(theta, dtype=float)
    if theta.shape[-1] != 3:
        raise LinkageError(f"theta: dead-centre metrics are defined for a four-bar (3 angles), got {theta.shape[-1]}")
    t1, t2, t3 = theta[..., 0], theta[..., 1], theta[..., 2]
    return np.stack([np.sin(t3 - t2), np.sin(t2 - t1), np.sin(t3 - t1)], axis=-1)


def count_dead_centres(theta_samples) -> dict[str, int]:
    """Number of sign changes of each dead-centre metric along a sampled trajectory ``(T, 3)``.

    Exact zeros take the sign of the sample before them, so touching zero is counted once.
    """
    metrics = dead_centre_metrics(np.asarray(theta_samples, dtype=float))
    counts = {}
    for k, name in enumerate(DEAD_CENTRE_EVENTS):
        signs = np.sign(metrics[:, k])
        for j in range(1, signs.size):
            if signs[j] == 0.0:
                signs[j] = signs[j - 1]
        counts[name] = int(np.count_nonzero(signs[1:] * signs[:-1] < 0.0))
    return counts
