"""The DOP853 stepper of the mechanism runs (physics/mechanism/stepper.py) against exact solutions and against
scipy's own DOP853: same order of accuracy, a comparable number of steps, samples hit exactly, the hook after
every accepted step applied."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from physics.errors import LinkageError
from physics.mechanism.stepper import Stepper


def oscillator(_t: float, y: np.ndarray) -> np.ndarray:
    return np.array([y[1], -4.0 * y[0]])


def test_an_oscillator_to_its_exact_solution_in_about_scipys_steps():
    stepper = Stepper(oscillator, 0.0, np.array([1.0, 0.0]), 1e-10, 1e-10)
    times = np.linspace(0.0, 10.0, 41)
    states = np.array([stepper.advance_to(float(t)).copy() for t in times])
    exact = np.column_stack([np.cos(2 * times), -2 * np.sin(2 * times)])
    assert np.max(np.abs(states - exact)) <= 1e-8
    reference = solve_ivp(oscillator, (0.0, 10.0), [1.0, 0.0], method="DOP853", rtol=1e-10, atol=1e-10)
    assert stepper.t == 10.0
    assert 0.5 * reference.t.size <= stepper.steps <= 1.5 * reference.t.size + 40  # 40 samples may shorten steps


def test_tolerance_controls_the_error():
    errors = []
    for tolerance in (1e-6, 1e-10):
        stepper = Stepper(oscillator, 0.0, np.array([1.0, 0.0]), tolerance, tolerance)
        y = stepper.advance_to(5.0)
        errors.append(abs(y[0] - np.cos(10.0)))
    assert errors[1] < errors[0] / 100


def test_the_hook_runs_after_every_accepted_step():
    calls = []

    def hook(t: float, y: np.ndarray) -> np.ndarray:
        calls.append(t)
        return y / np.hypot(y[0], y[1] / 2.0)  # back onto the exact orbit x^2 + (v/2)^2 = 1

    stepper = Stepper(oscillator, 0.0, np.array([1.0, 0.0]), 1e-6, 1e-6, after_step=hook)
    y = stepper.advance_to(3.0)
    assert len(calls) == stepper.steps and calls[-1] == 3.0
    assert abs(np.hypot(y[0], y[1] / 2.0) - 1.0) <= 1e-15


def test_a_blow_up_is_refused_in_one_line():
    stepper = Stepper(lambda _t, y: y**2, 0.0, np.array([1.0]), 1e-10, 1e-10)
    with pytest.raises(LinkageError, match="the integration failed at t = "):
        stepper.advance_to(2.0)  # y = 1 / (1 - t) leaves at t = 1
