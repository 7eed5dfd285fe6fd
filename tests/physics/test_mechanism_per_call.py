"""The per-mechanism cache of a run's fixed pieces (physics/mechanism/prepared.py, issue 24).

* Every cached piece equals what a run built for itself before the cache: the DAE's mass diagonal and gravity,
  ``nu``, the parameter vector, the weights, the names and the named points.
* The key is the mechanism's content: an equal description shares the entry, any other number (a body's mass,
  a motor's speed, g) or a list changed in place gets its own, and its run comes out different.
* A run on a warm cache is bit-identical to one on a cleared cache, for every formulation; the integrators write
  the time slot of their own copy, never the cached vector; the cached arrays are read-only.
* A massless body: assembly still works from the cache, a run is refused as before, on every call.
* A run's condition and a tree formulation's reaction rows are computed when first read, and then equal bit for
  bit what the eager code computes from the run's own samples; a pickle or a copy computes them first.
"""

from __future__ import annotations

import dataclasses
import pickle

import numpy as np
import pytest

from physics.errors import LinkageError
from physics.mechanism import MECHANISM_PRESETS, assemble, engine
from physics.mechanism.assembly import assembled_with_jacobian, sketch_size
from physics.mechanism.constraints import Constraints, _Frame
from physics.mechanism.description import Mechanism
from physics.mechanism.joint_coordinates import JointCoordinates
from physics.mechanism.numeric_dae import MechanismDAE
from physics.mechanism.parameters import parameter_vector, structure_key
from physics.mechanism.prepared import clear_prepared, prepared
from physics.mechanism.run_table import body_points, coordinate_names
from physics.mechanism.simulate import project_velocity, simulate_mechanism
from physics.mechanism.topology import analyse
from physics.mechanism.tree_coordinates import tree_state
from physics.simulate.trajectory import OnRequest

METHODS = ("dae", "lagrange", "newton_euler")


def _fields(run) -> dict:
    return {field.name: getattr(run, field.name) for field in dataclasses.fields(run)}


def _assert_identical(first, second) -> None:
    for name, value in _fields(first).items():
        other = getattr(second, name)
        if isinstance(value, np.ndarray):
            assert value.shape == other.shape and np.array_equal(value, other, equal_nan=True), name
        else:
            assert value == other, name


@pytest.mark.parametrize("name", ["slider-crank", "crank-rocker", "jansen-leg", "geared-five-bar"])
def test_cached_pieces_equal_the_uncached_computation(name):
    mechanism = MECHANISM_PRESETS[name]()
    pieces = prepared(mechanism)
    dae = MechanismDAE(mechanism)
    np.testing.assert_array_equal(pieces.dae.mass_diagonal, dae.mass_diagonal)
    np.testing.assert_array_equal(pieces.dae.gravity, dae.gravity)
    np.testing.assert_array_equal(pieces.velocity_rhs, Constraints(mechanism).velocity_rhs())
    np.testing.assert_array_equal(pieces.parameters_at(1.25), parameter_vector(mechanism, t=1.25))
    size = sketch_size(mechanism)
    assert pieces.sketch_size == size
    bodies = len(mechanism.bodies)
    np.testing.assert_array_equal(pieces.assembly_weights, np.tile([1.0, 1.0, 1.0 / size], bodies))
    np.testing.assert_array_equal(pieces.projection_weights, np.concatenate(
        [np.tile([1.0, 1.0, 1.0 / size**2], bodies), 1.0 / dae.mass_diagonal]))
    assert pieces.structure_key == structure_key(mechanism)
    assert pieces.coordinate_names == coordinate_names(mechanism)
    assert pieces.body_points == body_points(mechanism)
    assert pieces.row_names == tuple(f"{row.joint}: {row.meaning}" for row in dae.constraints.rows)
    q = assemble(mechanism).q
    np.testing.assert_array_equal(pieces.constraints.jacobian(q), Constraints(mechanism).jacobian(q))


def test_equal_descriptions_share_an_entry_and_other_numbers_do_not():
    mechanism = MECHANISM_PRESETS["crank-rocker"]()
    again = MECHANISM_PRESETS["crank-rocker"]()
    assert again is not mechanism and prepared(again) is prepared(mechanism)
    heavier = mechanism.model_copy(update={"bodies": [mechanism.bodies[0].model_copy(
        update={"mass": 2.0 * mechanism.bodies[0].mass}), *mechanism.bodies[1:]]})
    faster = mechanism.model_copy(update={"drivers": [mechanism.drivers[0].model_copy(
        update={"speed": 2.0 * mechanism.drivers[0].speed})]})
    weaker = mechanism.model_copy(update={"g": 1.62})
    for other in (heavier, faster, weaker):
        assert prepared(other) is not prepared(mechanism)
    assert prepared(heavier).dae.mass_diagonal[0] == 2.0 * prepared(mechanism).dae.mass_diagonal[0]
    assert prepared(faster).velocity_rhs.tolist() != prepared(mechanism).velocity_rhs.tolist()
    assert prepared(weaker).parameters[-2] == 1.62
    runs = {key: simulate_mechanism(item, 0.5, 11, method="dae", integrate=True)
            for key, item in (("base", mechanism), ("heavier", heavier), ("faster", faster), ("weaker", weaker))}
    for key in ("heavier", "faster", "weaker"):
        assert not np.array_equal(runs[key].reaction_rows, runs["base"].reaction_rows), key


def test_a_list_changed_in_place_is_another_mechanism():
    """A frozen model's lists can still be changed in place: the content key sees it (an id() key would not)."""
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    before = prepared(mechanism)
    run_before = simulate_mechanism(mechanism, 0.5, 11, method="lagrange", integrate=True)
    mechanism.bodies[0] = mechanism.bodies[0].model_copy(update={"mass": 3.0 * mechanism.bodies[0].mass})
    after = prepared(mechanism)
    assert after is not before
    np.testing.assert_array_equal(after.dae.mass_diagonal, MechanismDAE(mechanism).mass_diagonal)
    run_after = simulate_mechanism(mechanism, 0.5, 11, method="lagrange", integrate=True)
    assert not np.array_equal(run_after.reaction_rows, run_before.reaction_rows)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("stabilization", ["projection", "baumgarte"])
def test_a_warm_run_is_bit_identical_to_a_cold_one(method, stabilization):
    mechanism = MECHANISM_PRESETS["crank-rocker"]()
    clear_prepared()
    cold = simulate_mechanism(mechanism, 1.0, 21, method=method, stabilization=stabilization, integrate=True,
                              integrator="RK45", rtol=1e-8, atol=1e-8)
    warm = simulate_mechanism(mechanism, 1.0, 21, method=method, stabilization=stabilization, integrate=True,
                              integrator="RK45", rtol=1e-8, atol=1e-8)
    _assert_identical(cold, warm)
    driven_cold = simulate_mechanism(MECHANISM_PRESETS["jansen-leg"](), 0.5, 11, method=method)
    clear_prepared()
    driven_warm = simulate_mechanism(MECHANISM_PRESETS["jansen-leg"](), 0.5, 11, method=method)
    _assert_identical(driven_cold, driven_warm)


def test_runs_never_write_into_the_cached_pieces():
    mechanism = MECHANISM_PRESETS["crank-rocker"]()
    pieces = prepared(mechanism)
    saved = {name: np.array(getattr(pieces, name)) for name in
             ("parameters", "velocity_rhs", "assembly_weights", "projection_weights")}
    for method in METHODS:
        simulate_mechanism(mechanism, 0.5, 11, method=method, t_start=3.0, integrate=True)
    for name, value in saved.items():
        np.testing.assert_array_equal(getattr(pieces, name), value)
    assert pieces.parameters[-1] == 0.0  # the time slot: each run writes its own copy's
    for array in (pieces.parameters, pieces.dae.mass_diagonal, pieces.velocity_rhs, pieces.projection_weights):
        with pytest.raises(ValueError):
            array[0] = 1.0


def test_tree_state_from_the_cache_equals_one_from_fresh_pieces():
    mechanism = MECHANISM_PRESETS["watt-six-bar"]()
    q = assemble(mechanism).q
    qdot = np.random.default_rng(3).normal(size=q.size)
    coordinates, topology = JointCoordinates(mechanism, Constraints(mechanism)), analyse(mechanism)
    expected = []
    for body in topology.parent:
        joint, _ = topology.parent[body]
        which = coordinates.index(joint)
        sign = -1.0 if coordinates.forms[which] == "angle" and body == coordinates.ends[which][0] else 1.0
        expected.append((sign * coordinates.value(q, which), sign * coordinates.rate(q, qdot, which)))
    values, rates = tree_state(mechanism, q, qdot)
    np.testing.assert_array_equal(values, [v for v, _ in expected])
    np.testing.assert_array_equal(rates, [r for _, r in expected])


def test_a_massless_body_is_assembled_but_its_run_refused_every_time():
    mechanism = MECHANISM_PRESETS["crank-rocker"]()
    massless = mechanism.model_copy(update={"bodies": [mechanism.bodies[0].model_copy(update={"mass": 0.0}),
                                                        *mechanism.bodies[1:]]})
    np.testing.assert_array_equal(assemble(massless).q, assemble(mechanism).q)
    with pytest.raises(LinkageError) as direct:
        MechanismDAE(massless)
    for _ in range(2):
        with pytest.raises(LinkageError) as refused:
            simulate_mechanism(massless, 0.5, 11)
        assert str(refused.value) == str(direct.value)


def test_a_remembered_assembly_equals_a_fresh_one_and_is_the_callers_own():
    mechanism = MECHANISM_PRESETS["jansen-leg"]()
    clear_prepared()
    first = assemble(mechanism, None, 0.3)  # the sketch is rough: Newton steps
    assert first.newton_steps > 0
    first.q[:] = 0.0  # the caller's copy: the remembered pose is not changed
    again = assemble(mechanism, None, 0.3)
    clear_prepared()
    fresh = assemble(mechanism, None, 0.3)
    np.testing.assert_array_equal(again.q, fresh.q)
    assert (again.residual, again.newton_steps, again.mobility) == (fresh.residual, fresh.newton_steps, fresh.mobility)
    other_time = assemble(mechanism, None, 0.6)  # another start is another key
    assert not np.array_equal(other_time.q, fresh.q)
    np.testing.assert_array_equal(assemble(mechanism, fresh.q, 0.6).q, assemble(mechanism, fresh.q, 0.6).q)


def test_a_refusal_is_never_remembered():
    """An over-constrained loop and a body the ground cannot reach: refused with the same line on every call,
    and nothing kept for their starts."""
    document = MECHANISM_PRESETS["crank-rocker"]().model_dump()
    document["drivers"] = []
    rocker = next(body for body in document["bodies"] if body["name"] == "rocker")
    document["bodies"].append({**rocker, "name": "rocker2"})
    document["joints"] += [{"kind": "revolute", "name": "O4b", "a": "ground.O4", "b": "rocker2.O4"},
                           {"kind": "revolute", "name": "Bb", "a": "coupler.B", "b": "rocker2.B"}]
    over = Mechanism.model_validate(document)
    loose = MECHANISM_PRESETS["slider-crank"]().model_dump()
    loose["bodies"].append({"name": "loose", "points": {"X": [1.0, 1.0]}, "mass": 1.0, "inertia": 0.1})
    disconnected = Mechanism.model_validate(loose)
    for mechanism, fragment in ((over, "over-constrained"), (disconnected, "not connected to the ground")):
        messages = set()
        for _ in range(2):
            with pytest.raises(LinkageError, match=fragment) as refused:
                assemble(mechanism)
            messages.add(str(refused.value))
        assert len(messages) == 1 and not prepared(mechanism).assemblies


@pytest.mark.parametrize("name", ["geared-five-bar", "jansen-leg", "slider-crank"])
def test_the_batched_jacobian_is_each_poses_own(name):
    """Every sample's Phi_q of one batched evaluation equals its own evaluation, entry for entry (the entries go
    into ``out`` through a flat view; a gear's rows reach a body twice, so entries are summed, not set)."""
    mechanism = MECHANISM_PRESETS[name]()
    constraints = Constraints(mechanism)
    q = assemble(mechanism).q + np.random.default_rng(5).normal(scale=0.1, size=(7, 3 * len(mechanism.bodies)))
    batched = constraints.jacobian(q)
    for k, pose in enumerate(q):
        np.testing.assert_array_equal(batched[k], constraints.jacobian(pose))
    with pytest.raises(ValueError, match="C-contiguous"):
        constraints._groups[0].gradient(_Frame(q[0]), np.zeros((constraints.size + 3, len(constraints.rows))).T)


def test_a_change_in_place_after_preparing_does_not_reach_the_kept_pieces():
    """The pieces are built from a private copy: the joint coordinates, built on first use, are the description's
    as it was when it was prepared, not as the caller's object reads later."""
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    clear_prepared()
    pieces = prepared(mechanism)
    original = MECHANISM_PRESETS["slider-crank"]()
    mechanism.bodies[0] = mechanism.bodies[0].model_copy(
        update={"points": {name: (x + 0.05, y) for name, (x, y) in mechanism.bodies[0].points.items()}})
    assert pieces.constraints.mechanism == original != mechanism
    q = assemble(original).q
    expected = JointCoordinates(original, Constraints(original))
    for which in range(len(expected.names)):
        assert pieces.joint_coordinates.value(q, which) == expected.value(q, which)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_a_non_finite_guess_is_refused_not_assembled_to_nan(bad):
    """NaN compares false, so Newton's loop and the residual check were both skipped and a NaN pose came back
    as assembled; it is refused in one line naming the argument."""
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    guess = assemble(mechanism).q.copy()
    guess[1] = bad
    with pytest.raises(LinkageError, match="q_guess: expected .* finite numbers"):
        assemble(mechanism, guess)


# A run's condition and a tree formulation's reaction rows are computed when first read (physics.simulate.
# trajectory.OnRequest): until then the run holds the computation; reading gives exactly the arrays the eager
# code computed from the same samples (engine._conditions, engine.body_reactions), bit for bit.


def _spied_run(monkeypatch, mechanism, method, **options):
    """A run, and the Samples its engine solved (the eager computations' input)."""
    seen = []
    original = engine.samples

    def spy(*args, **kwargs):
        seen.append(original(*args, **kwargs))
        return seen[-1]

    monkeypatch.setattr(engine, "samples", spy)
    run = simulate_mechanism(mechanism, 2.0, 41, method=method, integrator="RK45", rtol=1e-7, atol=1e-7, **options)
    (solved,) = seen
    return run, engine._first(solved, run.t.size)


@pytest.mark.parametrize("kept_bytes", [engine.KEPT_JACOBIAN_BYTES, 0])  # the DAE's Jacobians kept, evaluated again
@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", ["slider-crank", "geared-five-bar", "jansen-leg"])
def test_condition_and_reactions_on_request_equal_the_eager_computation(monkeypatch, name, method, kept_bytes):
    monkeypatch.setattr(engine, "KEPT_JACOBIAN_BYTES", kept_bytes)
    mechanism = MECHANISM_PRESETS[name]()
    run, solved = _spied_run(monkeypatch, mechanism, method)
    assert isinstance(run.__dict__["_condition_value"], OnRequest)  # nothing computed by the run itself
    assert isinstance(run.__dict__["_reaction_rows_value"], OnRequest) == (method != "dae")
    constraints = prepared(mechanism).dae.constraints
    eager_condition = engine._conditions(constraints, solved, method != "dae")
    eager_reactions = (solved.multipliers if method == "dae"  # the closed form where the run takes it (loops)
                       else engine.body_reactions(prepared(mechanism).dae, solved,
                                                  closed_form=prepared(mechanism).tree_reactions,
                                                  multipliers=engine._loop_multipliers(
                                                      prepared(mechanism).tree_reactions, solved)))
    assert run.condition.shape == run.t.shape and np.array_equal(run.condition, eager_condition)
    assert run.reaction_rows.shape == (run.t.size, len(run.row_names))
    assert np.array_equal(run.reaction_rows, eager_reactions)
    assert run.condition is run.condition  # computed once, then kept
    assert not isinstance(run.__dict__["_condition_value"], OnRequest)


def test_fields_on_request_survive_pickling_and_copies():
    run = simulate_mechanism(MECHANISM_PRESETS["crank-rocker"](), 1.0, 21, method="lagrange", integrator="RK45",
                             rtol=1e-7, atol=1e-7)
    reference = simulate_mechanism(MECHANISM_PRESETS["crank-rocker"](), 1.0, 21, method="lagrange",
                                   integrator="RK45", rtol=1e-7, atol=1e-7)
    copied = dataclasses.replace(run)  # reads every field: the ones on request are computed here
    _assert_identical(copied, reference)
    _assert_identical(pickle.loads(pickle.dumps(reference)), reference)
    fresh = simulate_mechanism(MECHANISM_PRESETS["crank-rocker"](), 1.0, 21, method="lagrange", integrator="RK45",
                               rtol=1e-7, atol=1e-7)
    unpickled = pickle.loads(pickle.dumps(fresh))  # pickled before either field was read
    assert np.array_equal(unpickled.condition, reference.condition)
    assert np.array_equal(unpickled.reaction_rows, reference.reaction_rows)


@pytest.mark.parametrize("name", ["slider-crank", "stephenson-six-bar", "jansen-leg"])
def test_a_start_already_on_the_velocity_constraints_is_returned_as_the_solve_would(name):
    mechanism = MECHANISM_PRESETS[name]()
    pieces = prepared(mechanism)
    assembled, jacobian = assembled_with_jacobian(mechanism, pieces, None, 0.0)
    inverse_mass = 1.0 / pieces.dae.mass_diagonal
    for qdot in (np.zeros_like(assembled.q), -np.zeros_like(assembled.q)):
        gap = jacobian @ qdot - pieces.velocity_rhs
        correction = np.linalg.lstsq((jacobian * inverse_mass) @ jacobian.T, gap, rcond=None)[0]
        solved = qdot - inverse_mass * (jacobian.T @ correction)  # the least-squares path, always taken before
        projected = project_velocity(pieces.dae, assembled.q, qdot, pieces.velocity_rhs, jacobian)
        assert np.array_equal(projected, solved) and np.array_equal(np.signbit(projected), np.signbit(solved))
        assert projected is not qdot
