"""A slider's viscous damping (issue 28): a force ``-c v`` along the guide, ``v`` the sliding point's speed relative
to the guide's body, in every formulation (the DAE, numeric and compiled; Lagrange and Newton-Euler on a spanning
tree, where the slider is a tree joint or a cut joint; the reduced model). The energy lost is the integral of the
dissipated power ``c v^2``, computed here from the sampled velocities; the reactions agree between formulations
and balance the piston's motion with the damping force included."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import simpson

from physics.mechanism import MECHANISM_PRESETS, engine
from physics.mechanism.constraints import Constraints
from physics.mechanism.description import Prismatic
from physics.mechanism.numeric_dae import MechanismDAE
from physics.mechanism.parameters import parameter_vector
from physics.mechanism.simulate import simulate_mechanism

DAMPING = 1.5  # N s/m on a 0.3 kg piston: the crank's swing loses a good part of its energy within a second
T_END = 1.0
SAMPLES = 2001


def damped_slider_crank(damping=DAMPING):
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    joints = [j.model_copy(update={"damping": damping}) if isinstance(j, Prismatic) else j for j in mechanism.joints]
    return mechanism.model_copy(update={"joints": joints})


def sliding_speed(mechanism, run):
    constraints = Constraints(mechanism)
    return np.array([(constraints.sliding_jacobian(q) @ qdot)[0] for q, qdot in zip(run.q, run.qdot)])


@pytest.fixture(scope="module")
def runs():
    mechanism = damped_slider_crank()
    return mechanism, {method: simulate_mechanism(mechanism, T_END, SAMPLES, method=method)
                       for method in ("dae", "lagrange", "newton_euler", "reduced")}


@pytest.mark.parametrize("method", ["dae", "lagrange", "newton_euler", "reduced"])
def test_energy_lost_is_the_integral_of_c_v_squared(runs, method):
    mechanism, by_method = runs
    run = by_method[method]
    speed = sliding_speed(mechanism, run)
    dissipated = DAMPING * simpson(speed**2, x=run.t)
    lost = run.energy[0] - run.energy[-1]
    assert dissipated > 0.05 * abs(run.energy[0] - run.potential.min())  # the damper does real work here
    assert lost == pytest.approx(dissipated, rel=1e-6, abs=1e-9)
    # at every sample: dE/dt (central differences) = -c v^2
    rate = np.gradient(run.energy, run.t)[1:-1]
    assert np.max(np.abs(rate + DAMPING * speed[1:-1] ** 2)) < 1e-3 * np.max(DAMPING * speed**2)


def test_without_damping_the_energy_is_kept(runs):
    mechanism = damped_slider_crank(0.0)
    run = simulate_mechanism(mechanism, T_END, 201)
    assert np.ptp(run.energy) < 1e-8 * np.max(np.abs(run.kinetic))


@pytest.mark.parametrize("method", ["lagrange", "newton_euler"])
def test_formulations_agree_on_motion_and_reactions(runs, method):
    _, by_method = runs
    reference, run = by_method["dae"], by_method[method]
    assert run.row_names == reference.row_names
    assert np.max(np.abs(run.q - reference.q)) < 1e-8
    scale = 1.0 + np.max(np.abs(reference.reaction_rows))
    assert np.max(np.abs(run.reaction_rows - reference.reaction_rows)) < 1e-7 * scale


@pytest.mark.parametrize("method", ["dae", "lagrange", "newton_euler"])
def test_the_piston_obeys_newton_with_the_damping_force(runs, method):
    """Along the (horizontal) guide the piston feels only the rod's pin force and the damper: m a = -lambda_B,x - c v
    (the row holds the force on the rod by the piston). The accelerations are the numeric DAE's at each sample (the
    tree formulations recover their reactions from their own accelerations, which agree with these)."""
    mechanism, by_method = runs
    run = by_method[method]
    piston = [b.name for b in mechanism.bodies].index("piston")
    mass = mechanism.bodies[piston].mass
    dae = MechanismDAE(mechanism)
    acceleration = np.array([dae.solve(q, qdot).qddot[3 * piston] for q, qdot in zip(run.q, run.qdot)])
    pin = run.reaction_rows[:, run.row_names.index("B: x gap")]
    speed = sliding_speed(mechanism, run)
    inner = slice(None)
    residual = mass * acceleration[inner] + pin[inner] + DAMPING * speed[inner]
    without_damper = mass * acceleration[inner] + pin[inner]
    assert np.max(np.abs(residual)) < 1e-6 * np.max(np.abs(without_damper))  # the balance misses nothing ...
    assert np.max(np.abs(without_damper)) > 0.1  # ... and the damper's share is a real force (0.2 N)


def test_the_compiled_dae_has_the_damping_of_the_numeric_one():
    mechanism = damped_slider_crank()
    dae = MechanismDAE(mechanism)
    run = simulate_mechanism(mechanism, 0.5, 6)
    compiled = engine.compiled_system(mechanism, "dae")
    params = parameter_vector(mechanism)
    for q, qdot in zip(run.q, run.qdot):
        expected = dae.solve(q, qdot).qddot
        full, _ = compiled.solve_full(q, qdot, params)
        assert np.allclose(full[compiled.theta_ddot_index], expected, rtol=1e-9, atol=1e-9)
