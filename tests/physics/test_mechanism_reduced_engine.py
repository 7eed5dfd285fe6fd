"""The reduced model's compiled evaluation (physics/kernels/reduced_evaluation.py, physics/mechanism/reduced_engine.py)
against the numpy it replaced on the hot path: the joint coordinates of
physics/mechanism/joint_coordinates.py, the constraints' ``nu`` and ``gamma`` and the DAE's applied forces
(physics/mechanism/constraints.py, dae.py); and a run that evaluates no numpy constraint per step."""

from __future__ import annotations

import numpy as np
import pytest

from physics.kernels import reduced_evaluation as kernel
from physics.mechanism import MECHANISM_PRESETS, assemble
from physics.mechanism.assembly import sketch_size
from physics.mechanism.constraints import Constraints
from physics.mechanism.joint_coordinates import JointCoordinates
from physics.mechanism.numeric_dae import MechanismDAE
from physics.mechanism.reduced import simulate_reduced
from physics.mechanism.reduced_engine import joint_coordinate_arrays, reduced_engine
from physics.mechanism.reduced_partition import Partition

from .test_mechanism_reduced import driven_five_bar, motored_damped_slider_crank, quick_return

MAKERS = [*(MECHANISM_PRESETS[name] for name in ("slider-crank", "watt-six-bar", "stephenson-six-bar")),
          quick_return, driven_five_bar, motored_damped_slider_crank]


def random_state(mechanism, seed: int):
    """Any pose near the assembled one and any rates: the functions compared are identities in ``(q, qdot)``."""
    rng = np.random.default_rng(seed)
    size = 3 * len(mechanism.bodies)
    return assemble(mechanism).q + rng.normal(0.0, 0.05, size), rng.normal(0.0, 1.0, size)


@pytest.mark.parametrize("make", [*MAKERS, MECHANISM_PRESETS["geared-five-bar"]])
def test_the_compiled_joint_coordinates_are_the_numpy_ones(make):
    mechanism = make()
    dae = MechanismDAE(mechanism)
    coordinates = JointCoordinates(mechanism, dae.constraints)
    arrays = joint_coordinate_arrays(mechanism)  # the geared five-bar's gear offers none, as in JointCoordinates
    assert arrays.names == coordinates.names
    assert np.array_equal(arrays.speed_scale, coordinates.speed_scale)
    q, qdot = random_state(mechanism, 3)
    row = np.empty(q.size)
    for which in range(len(coordinates.names)):
        value = kernel.coordinate_value(arrays.kinds, arrays.ends, arrays.geometry, which, q)
        assert value == pytest.approx(coordinates.value(q, which), abs=1e-14)
        kernel.coordinate_gradient(arrays.kinds, arrays.ends, arrays.geometry, which, q, row)
        assert np.max(np.abs(row - coordinates.gradient(q, which))) <= 1e-14
        curvature = kernel.coordinate_curvature(arrays.kinds, arrays.ends, arrays.geometry, which, q, qdot)
        assert curvature == pytest.approx(coordinates.curvature(q, qdot, which), abs=1e-13)
    shares = np.empty(len(coordinates.names))
    kernel.speed_shares(arrays.kinds, arrays.ends, arrays.geometry, arrays.speed_scale, q, qdot, row, shares)
    assert np.max(np.abs(shares - coordinates.speed_shares(q, qdot))) <= 1e-14
    assert np.max(shares) == 1.0


@pytest.mark.parametrize("make", MAKERS)
def test_the_engine_reads_nu_gamma_and_the_applied_forces_of_the_numpy_constraints(make):
    """The generated DAE's constraints and its ``b`` hold what the numpy constraints and the DAE's applied forces
    give: ``Phi`` and ``Phi_q`` row for row, ``nu``, ``Q`` (gravity, torque motors, dampers) and ``gamma``."""
    mechanism = make()
    dae = MechanismDAE(mechanism)
    constraints = dae.constraints
    engine = reduced_engine(dae)
    q, qdot = random_state(mechanism, 5)
    t = 0.37
    jacobian, phi, _ = engine.constraint_states(np.array([t]), q[None], qdot[None])
    assert np.max(np.abs(phi[0] - constraints.residual(q, t))) <= 1e-14
    assert np.max(np.abs(jacobian[0] - constraints.jacobian(q))) <= 1e-14
    assert np.max(np.abs(engine.nu - constraints.velocity_rhs())) <= 1e-14
    assert np.max(np.abs(engine.applied(q[None], qdot[None])[0] - dae.applied(qdot, q))) <= 1e-13
    _, b = engine.compiled.matrices(q, qdot, engine.params)
    gamma = b[0, constraints.size:]
    assert np.max(np.abs(gamma - constraints.acceleration_rhs(q, qdot))) <= 1e-12


@pytest.mark.parametrize("make", MAKERS)
def test_a_state_satisfies_the_equations_it_solves(make):
    """At a state the partition computes: the constraints hold, the coordinate is the one asked for, the
    velocities satisfy ``Phi_q qdot = nu`` and the accelerations are the DAE's (solved here by numpy, with
    its own reactions) at that pose and velocity."""
    mechanism = make()
    dae = MechanismDAE(mechanism)
    coordinates = JointCoordinates(mechanism, dae.constraints)
    q = assemble(mechanism).q
    which = int(np.argmax(coordinates.speed_shares(q, np.linalg.svd(dae.constraints.jacobian(q))[2][-1])))
    partition = Partition(dae, coordinates, which, q, 0.0, sketch_size(mechanism))
    s0 = coordinates.value(q, which)
    scale = sketch_size(mechanism) if coordinates.forms[which] == "angle" else 1.0
    state = partition.state(0.01, s0 + 0.02 / scale, 1.5)
    constraints = dae.constraints
    assert np.max(np.abs(constraints.residual(state.q, 0.01))) <= 1e-13
    assert coordinates.value(state.q, which) == pytest.approx(s0 + 0.02 / scale, abs=1e-13)
    assert np.max(np.abs(constraints.jacobian(state.q) @ state.qdot - constraints.velocity_rhs())) <= 1e-12
    assert float(coordinates.gradient(state.q, which) @ state.qdot) == pytest.approx(1.5, abs=1e-12)
    solved = dae.solve(state.q, state.qdot)
    assert np.max(np.abs(state.qddot - solved.qddot)) <= 1e-8 * max(1.0, float(np.max(np.abs(solved.qddot))))
    assert state.shares[which] == pytest.approx(partition.share(state))


def test_a_run_evaluates_no_numpy_constraint_per_step(monkeypatch):
    """The numpy constraints are called as often for a run of 4 s as for one of 1 s (assembly, the first
    coordinate's choice): none of it is per step or per sample."""
    calls = {"residual": 0, "jacobian": 0, "acceleration_rhs": 0}
    for name in calls:
        original = getattr(Constraints, name)

        def counted(self, *args, _name=name, _original=original, **kwargs):
            calls[_name] += 1
            return _original(self, *args, **kwargs)

        monkeypatch.setattr(Constraints, name, counted)
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    counts = []
    for t_end in (1.0, 4.0):
        for name in calls:
            calls[name] = 0
        run = simulate_reduced(mechanism, t_end, 101, coordinate="guide")  # it switches: a new partition
        assert run.switches and run.run.n_rhs > 1000
        counts.append(dict(calls))
    assert counts[0] == counts[1]
    assert counts[0]["acceleration_rhs"] == 0
