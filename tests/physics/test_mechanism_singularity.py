"""Singular poses of a general mechanism (issue 16: dead-centre and change-point detection, as the four-bar has):
the constraint Jacobian's condition at every sample, and a run stopped at a singular pose naming the time and
the joints whose constraints became dependent."""

from __future__ import annotations

import numpy as np
import pytest

from physics import LinkageError, get_preset
from physics.mechanism import MECHANISM_PRESETS
from physics.mechanism.assembly import assemble
from physics.mechanism.chains import chain_mechanism, chain_state
from physics.mechanism.constraints import Constraints
from physics.mechanism.simulate import simulate_mechanism
from physics.mechanism.singularity import NEAR_SINGULAR_CONDITION, dependent_joints, jacobian_condition

COLLINEAR = np.array([np.pi / 2, np.pi / 2, -np.pi / 2])  # the parallelogram's links all on the x axis


@pytest.fixture(scope="module")
def parallelogram():
    """The change-point preset (a parallelogram four-bar, s + l = p + q) written as a mechanism."""
    preset = get_preset("change-point")
    return preset, chain_mechanism(preset.chain, preset.theta0)


def test_the_condition_is_moderate_away_from_the_change_point_and_infinite_at_it(parallelogram):
    preset, mechanism = parallelogram
    constraints = Constraints(mechanism)
    q_start, _ = chain_state(preset.chain, preset.theta0, preset.theta0, np.zeros(3))
    q_flat, _ = chain_state(preset.chain, preset.theta0, COLLINEAR, np.zeros(3))
    assert np.max(np.abs(constraints.residual(q_flat))) < 1e-12  # a pose of the mechanism
    assert jacobian_condition(constraints, q_start) < 1e3
    assert jacobian_condition(constraints, q_flat) > 1e14
    assert set(dependent_joints(constraints, q_flat)) == {"O", "J1", "J2", "H"}  # the whole loop


def test_every_preset_reports_its_condition_at_every_sample():
    for name, make in MECHANISM_PRESETS.items():
        mechanism = make()
        run = simulate_mechanism(mechanism, 0.5, 11)
        assert run.condition.shape == (11,), name
        assert np.all(np.isfinite(run.condition)) and np.all(run.condition >= 1.0), name
        q = assemble(mechanism).q
        assert run.condition[0] == pytest.approx(jacobian_condition(Constraints(mechanism), q), rel=1e-6), name


def test_a_run_through_the_change_point_carries_on_and_its_samples_show_the_passage(parallelogram):
    """Cranks turned up through the collinear pose (theta1 reaches pi/2 at t = 0.05 / 3 s) in the parallelogram
    mode: every formulation carries through on the compiled engine (the singular pose is crossed between steps,
    the projection holds the loop), all three agree on where the linkage goes, and the samples' Jacobian
    condition peaks at the crossing and falls away again."""
    preset, mechanism = parallelogram
    q0, qdot0 = chain_state(preset.chain, preset.theta0, preset.theta0, np.array([3.0, 0.0, 3.0]))
    ends = []
    for method in ("dae", "lagrange", "newton_euler"):
        run = simulate_mechanism(mechanism, 0.1, 101, q0=q0, qdot0=qdot0, method=method)
        peak = int(np.argmax(run.condition))
        assert run.condition[peak] > 1e3 and abs(run.t[peak] - 0.05 / 3) < 0.002, (method, run.condition[peak])
        assert run.condition[-1] < run.condition[peak] / 10  # and away again
        assert np.max(run.residual) < 1e-10 and np.ptp(run.energy) < 1e-6 * np.max(np.abs(run.energy))
        ends.append(run.q[-1])
    np.testing.assert_allclose(ends[1], ends[0], atol=1e-7)
    np.testing.assert_allclose(ends[2], ends[0], atol=1e-7)


def test_a_run_released_at_the_change_point_stops_naming_the_loop():
    """Released 1e-6 rad from the singular pose, the system is singular at once: one line naming the time, the
    joints whose constraints became dependent, and the kernels' reason."""
    from physics.studies.mechanism_stability import change_point_mechanism  # noqa: PLC0415

    mechanism, _ = change_point_mechanism(1e-6)
    for method in ("dae", "lagrange", "newton_euler"):
        with pytest.raises(LinkageError) as error:
            simulate_mechanism(mechanism, 1.0, 11, method=method)
        message = str(error.value)
        assert "singular pose at t = 0 s" in message and "\n" not in message, message
        assert set(message.split("joints ")[1].split(" became")[0].split(", ")) == {"O", "J1", "J2", "H"}, message


def test_the_near_singular_threshold_is_far_above_the_presets():
    for name, make in MECHANISM_PRESETS.items():
        run = simulate_mechanism(make(), 2.0, 41)
        assert np.max(run.condition) < NEAR_SINGULAR_CONDITION / 100, name
