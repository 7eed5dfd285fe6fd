"""Run results print as one line in a notebook (issue 25): the dataclass repr printed every array (48,777
characters for a 201-sample Trajectory)."""

from __future__ import annotations

import physics
from physics.mechanism import MECHANISM_PRESETS
from physics.mechanism.simulate import simulate_mechanism
from physics.status import Status


def test_trajectory_repr_is_one_short_line():
    preset = physics.get_preset("triple-a")
    settings = physics.Settings(method="dae", integrator="DOP853", t_end=20.0, samples=201)
    run = physics.simulate(preset.chain, preset.theta0, preset.omega0, settings)
    text = repr(run)
    assert text == "Trajectory(method='dae', integrator='DOP853', links=3, samples=201, t=0..20 s, status=ok)"
    assert "\n" not in text and len(text) < 200
    assert str(run) == text


def test_trajectory_repr_names_a_failure_and_its_message():
    preset = physics.get_preset("triple-a")
    settings = physics.Settings(method="lagrange", integrator="RK45", t_end=20.0, samples=11, max_steps=5)
    run = physics.simulate(preset.chain, preset.theta0, preset.omega0, settings)
    assert run.status != Status.OK
    text = repr(run)
    assert f"status={Status(run.status).name.lower()}" in text
    assert f"message={run.message!r}" in text
    assert f"samples={run.t.shape[0]}" in text and "\n" not in text


def test_mechanism_run_repr_is_one_short_line():
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    run = simulate_mechanism(mechanism, 1.0, 51)
    text = repr(run)
    bodies = len(mechanism.bodies)
    assert text.startswith(f"MechanismRun(method={run.method!r}, bodies={bodies}, samples=51, t=0..1 s, ")
    assert ("position analysis" in text) != run.integrated
    assert "\n" not in text and len(text) < 200
