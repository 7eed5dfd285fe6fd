"""DOP853 stepped through a run without restarting, every step ending on the sample times it reaches, with a
hook after every accepted step (projection onto the constraints).

scipy's ``solve_ivp`` restarted at every sample interval pays its start-up each time (the first-step estimate,
a fresh step size); the steps of one continuous run are the same DOP853 steps (scipy's coefficients, error norm
and step-size control) without that cost. A step that would pass a sample is shortened to end on it, and the
step size it had before is kept for the next one, so samples cost no interpolation and no extra evaluations.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..errors import LinkageError
from ..kernels import tables

SAFETY = 0.9  # scipy's: steps from the asymptotic error estimate are multiplied by this
MIN_FACTOR = 0.2  # scipy's: largest decrease of a step size after a rejected step
MAX_FACTOR = 10.0  # scipy's: largest increase after an accepted one
ERROR_EXPONENT = -1.0 / 8.0  # DOP853's error estimate is of order 7
MAX_STEPS = 5_000_000

_STAGES = tables.DOP853_N_STAGES  # scipy's coefficients, as the compiled kernels use them (same doubles)
_A = tables.DOP853_A[:_STAGES, :_STAGES]
_B = tables.DOP853_B
_C = tables.DOP853_C[:_STAGES]
_E3, _E5 = tables.DOP853_E3, tables.DOP853_E5


def _error_norm(stages: np.ndarray, h: float, scale: np.ndarray) -> float:
    """scipy's DOP853 error norm: the fifth- and third-order estimates combined."""
    err5 = (stages.T @ _E5) / scale
    err3 = (stages.T @ _E3) / scale
    err5_squared, err3_squared = float(err5 @ err5), float(err3 @ err3)
    if err5_squared == 0.0 and err3_squared == 0.0:
        return 0.0
    return abs(h) * err5_squared / np.sqrt((err5_squared + 0.01 * err3_squared) * len(scale))


def _first_step(rhs: Callable, t: float, y: np.ndarray, f: np.ndarray, rtol: float, atol: float) -> float:
    """Hairer's starting step, as scipy chooses it."""
    scale = atol + np.abs(y) * rtol
    d0, d1 = np.sqrt(np.mean((y / scale) ** 2)), np.sqrt(np.mean((f / scale) ** 2))
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    f1 = rhs(t + h0, y + h0 * f)
    d2 = np.sqrt(np.mean(((f1 - f) / scale) ** 2)) / h0
    h1 = max(1e-6, h0 * 1e-3) if d1 <= 1e-15 and d2 <= 1e-15 else (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    return float(min(100.0 * h0, h1))


class Stepper:
    """Integrates ``y' = rhs(t, y)`` from sample to sample; ``after_step(t, y) -> y`` runs after every
    accepted step (it may move the state; the derivative is then evaluated again at the moved state)."""

    def __init__(self, rhs: Callable, t: float, y: np.ndarray, rtol: float, atol: float,
                 after_step: Callable | None = None) -> None:
        self.rhs, self.rtol, self.atol, self.after_step = rhs, rtol, atol, after_step
        self.t, self.y = float(t), np.array(y, dtype=float)
        self.f = rhs(self.t, self.y)
        self.h = _first_step(rhs, self.t, self.y, self.f, rtol, atol)
        self.stages = np.empty((_STAGES + 1, self.y.size))
        self.steps = 0
        self.evaluations = 2

    def advance_to(self, t_target: float) -> np.ndarray:
        """The state at ``t_target`` (not before the current time); LinkageError if the step size collapses."""
        while self.t < t_target:
            self._step(t_target)
        return self.y

    def _step(self, t_target: float) -> None:
        rejected = False
        while True:
            min_step = 10.0 * abs(np.nextafter(self.t, np.inf) - self.t)
            if self.h < min_step or not np.isfinite(self.h):
                raise LinkageError(f"the integration failed at t = {self.t:.4g} s (the step size fell to "
                                   f"{self.h:.3g} s)")
            h = min(self.h, t_target - self.t)
            last = h < self.h
            y_new = self._stages(h)
            f_new = self.rhs(self.t + h, y_new)
            self.evaluations += _STAGES
            self.stages[_STAGES] = f_new
            scale = self.atol + np.maximum(np.abs(self.y), np.abs(y_new)) * self.rtol
            error = _error_norm(self.stages, h, scale)
            if error < 1.0:
                factor = MAX_FACTOR if error == 0.0 else min(MAX_FACTOR, SAFETY * error**ERROR_EXPONENT)
                if rejected:
                    factor = min(1.0, factor)
                self.h = max(h * factor, self.h if last and not rejected else 0.0)
                break
            self.h = h * max(MIN_FACTOR, SAFETY * error**ERROR_EXPONENT)
            rejected = True
        self.steps += 1
        if self.steps > MAX_STEPS:
            raise LinkageError(f"the integration needs more than {MAX_STEPS} steps by t = {self.t:.4g} s")
        self.t = t_target if last else self.t + h
        if self.after_step is not None:
            moved = self.after_step(self.t, y_new)
            if moved is not y_new:
                y_new, f_new = moved, self.rhs(self.t, moved)
                self.evaluations += 1
        self.y, self.f = y_new, f_new

    def _stages(self, h: float) -> np.ndarray:
        stages = self.stages
        stages[0] = self.f
        for s in range(1, _STAGES):
            stages[s] = self.rhs(self.t + _C[s] * h, self.y + h * (_A[s, :s] @ stages[:s]))
        return self.y + h * (_B @ stages[:_STAGES])
