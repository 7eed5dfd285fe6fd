"""Run results print as one line in a notebook (issue 25): the dataclass repr printed every array (48,777
characters for a 201-sample Trajectory)."""

from __future__ import annotations

import numpy as np

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
    assert text.startswith(f"Trajectory(method={run.method!r}, integrator={run.integrator!r}, bodies={bodies}, ")
    assert "samples=51, t=0..1 s, status=ok" in text
    assert ("position analysis" in text) != run.integrated
    assert (f"n_steps={run.n_steps}" in text) == run.integrated
    assert "\n" not in text and len(text) < 200


def test_a_mechanism_run_is_a_trajectory_with_the_chain_fields_empty():
    """One result type (issue 24): a mechanism's run is the chain's Trajectory; what only a chain has is an empty
    (T, 0) array, so slicing along the samples treats every field alike."""
    mechanism = MECHANISM_PRESETS["crank-rocker"]()
    run = simulate_mechanism(mechanism, 0.5, 11, integrate=True)
    assert type(run) is physics.Trajectory and run.is_mechanism and run.integrated and run.n_steps > 0
    assert run.theta.shape == (11, 0) and run.joints.shape == (11, 0, 2) and run.reactions.shape == (11, 0, 2)
    assert run.n == 0 and run.bodies == len(mechanism.bodies) and run.q.shape == (11, 3 * run.bodies)
    assert run.coordinate_names[:3] == (f"{mechanism.bodies[0].name}.x", f"{mechanism.bodies[0].name}.y",
                                        f"{mechanism.bodies[0].name}.phi")
    assert len(run.coordinate_names) == run.q.shape[1]
    assert run.reaction_rows.shape == (11, len(run.row_names)) and len(run.row_names) > 0
    assert np.array_equal(run.energy, run.kinetic + run.potential)
    columns = run.columns()
    assert list(columns)[:7] == ["t", "trace_x", "trace_y", "kinetic", "potential", "energy", "constraint_residual"]
    assert [name for name in columns if name.startswith("lambda[")] == [f"lambda[{row}]" for row in run.row_names]


def test_a_chain_run_leaves_the_mechanism_fields_empty():
    preset = physics.get_preset("triple-a")
    run = physics.simulate(preset.chain, preset.theta0, preset.omega0, physics.Settings(t_end=1.0, samples=11))
    assert not run.is_mechanism and run.n == 3 and run.bodies == 0
    assert run.q.shape == (11, 0) and run.reaction_rows.shape == (11, 0) and run.row_names == ()
    assert list(run.columns())[:2] == ["t", "theta1"]


def test_a_mechanism_run_records_the_coordinates_it_ran_in():
    """The DAE runs in maximal or in tree coordinates and ``method`` is "dae" for both: the run says which, and
    its one-line repr shows it (a chain's run has no such choice and records none)."""
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    expected = {("dae", "maximal"): "maximal", ("dae", "tree"): "tree", ("lagrange", "maximal"): "tree",
                ("newton_euler", "maximal"): "tree", ("reduced", "maximal"): "reduced"}
    for (method, coordinates), recorded in expected.items():
        run = simulate_mechanism(mechanism, 0.2, 11, method=method, coordinates=coordinates)
        assert run.method == method and run.coordinates == recorded, (method, coordinates)
        assert f"coordinates={recorded!r}" in repr(run)
    driven = simulate_mechanism(MECHANISM_PRESETS["crank-rocker"](), 0.2, 11)
    assert not driven.integrated and driven.coordinates == "maximal" and "coordinates='maximal'" in repr(driven)
    preset = physics.get_preset("triple-a")
    chain_run = physics.simulate(preset.chain, preset.theta0, preset.omega0, physics.Settings(t_end=0.2, samples=11))
    assert chain_run.coordinates == "" and "coordinates" not in repr(chain_run)
