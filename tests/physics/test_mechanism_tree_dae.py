"""The DAE in tree coordinates (physics/mechanism/tree_dae.py): the maximal DAE's system solved at every tree
state, integrated in the spanning tree's joint coordinates as the seed's DAE integrates a chain's joint angles.

Checked against independent numbers: the chain engine's own DAE run (physics.simulate, the chain formulas of
docs/physics.md integrated in absolute angles), the tree Lagrange and Newton–Euler formulations of the same
mechanism (derived on their own), and the mechanism's maximal-coordinate DAE run.
"""

from __future__ import annotations

import zlib

import numpy as np
import pytest

from physics import Settings, get_preset, simulate
from physics.codegen import cache
from physics.errors import LinkageError
from physics.mechanism import MECHANISM_PRESETS, engine, tree_dae
from physics.mechanism.chains import chain_mechanism, chain_quantities, chain_state
from physics.mechanism.constraints import Constraints
from physics.mechanism.description import Mechanism
from physics.mechanism.numeric_dae import MechanismDAE
from physics.mechanism.parameters import parameter_vector
from physics.mechanism.simulate import simulate_mechanism

from .test_mechanism_symbolic import RANDOM_SEEDS, _closure_rows_in_the_dae, random_mechanisms, renumbered

AGREEMENT = 1e-10  # relative, at one state: the same equations solved three ways (measured: about 1e-14)
TREE_METHODS = ("lagrange", "newton_euler")


def _relative(mine: np.ndarray, theirs: np.ndarray) -> float:
    return float(np.max(np.abs(mine - theirs), initial=0.0) / (1.0 + np.max(np.abs(theirs), initial=0.0)))


# ------------------------------------------------------------------------------------ a chain, run both ways


@pytest.mark.parametrize("name", ["triple-a", "double", "four-bar"])
def test_a_chain_as_a_mechanism_in_tree_coordinates_follows_the_chain_engines_dae(name):
    """Ten seconds of the chain preset (the four-bar: the triple pendulum with its tip pinned), DOP853 at
    rtol = atol = 1e-12, through the chain engine's DAE and through the chain written as a mechanism run in tree
    coordinates: the angles, rates, energy and every reaction (the tip's too) agree to about 1e-10.

    Not to rounding: the two runs integrate different variables (the chain its absolute angles, the tree the
    relative ones), so their step-size control and their errors differ; each run's own error at 1e-12 over ten
    seconds of the chaotic triple pendulum is of this size (measured: angles 6e-11, rates 1.5e-10, energy 2e-11,
    reactions 2e-11 of their largest)."""
    preset = get_preset(name)
    chain = preset.chain
    mechanism = chain_mechanism(chain, preset.theta0)
    _, qdot0 = chain_state(chain, preset.theta0, preset.theta0, preset.omega0)
    run = simulate_mechanism(mechanism, 10.0, 101, qdot0=qdot0, method="dae", rtol=1e-12, atol=1e-12,
                             coordinates="tree")
    settings = Settings(method="dae", integrator="DOP853", rtol=1e-12, atol=1e-12, t_end=10.0, samples=101)
    chain_run = simulate(chain, preset.theta0, preset.omega0, settings)
    assert run.status == 0 and chain_run.status == 0
    assert run.method == "dae" and run.integrated
    np.testing.assert_allclose(run.t, chain_run.t, rtol=0, atol=1e-14)
    theta, omega, reactions, tip = chain_quantities(chain, preset.theta0, run)
    np.testing.assert_allclose(theta, chain_run.theta, rtol=0, atol=3e-10)
    np.testing.assert_allclose(omega, chain_run.omega, rtol=0, atol=5e-10)
    np.testing.assert_allclose(run.energy, chain_run.energy, rtol=0, atol=1e-10)
    n = chain.n
    scale = float(np.max(np.abs(chain_run.reactions)))
    # the pins O, J1 .. J(n-1) are the chain's joints 0 .. n-1 (force ON bar k+1 BY bar k), then the tip's H
    joints = ("O", *(f"J{k}" for k in range(1, n)), *(("H",) if chain.pin is not None else ()))
    assert run.row_names == tuple(f"{joint}: {axis} gap" for joint in joints for axis in ("x", "y"))
    np.testing.assert_allclose(reactions, chain_run.reactions, rtol=0, atol=1e-10 * scale)
    assert tip.shape == chain_run.tip_reaction.shape
    np.testing.assert_allclose(tip, chain_run.tip_reaction, rtol=0, atol=1e-10 * scale)
    if chain.pin is not None:
        assert np.max(run.residual) < 1e-12  # the tip held on its pin by projection in tree coordinates


# ------------------------------------------------------------------- three ways at random tree states


def mechanisms() -> list[tuple[str, Mechanism]]:
    preset = get_preset("four-bar")
    return [(name, make()) for name, make in sorted(MECHANISM_PRESETS.items())] + [
        ("four-bar chain", chain_mechanism(preset.chain, preset.theta0))] + [
        (f"random {seed}", mechanism) for seed, mechanism in zip(RANDOM_SEEDS, random_mechanisms())]


CASES = mechanisms()


def _tree_solution(mechanism: Mechanism, method: str, s, sd, params):
    """``(sdd, qddot, reactions, closure multipliers)`` of a tree formulation's generated system at ``(s, sd)``:
    every body's acceleration through its kinematics, every joint's reactions by Newton's law on them."""
    compiled = engine.compiled_system(mechanism, method)
    times = np.array([params[-1]])
    solved = engine.samples(compiled, params, times, s[None, :], sd[None, :])
    full, _ = compiled.solve_full(s, sd, params)
    reactions = engine.body_reactions(MechanismDAE(mechanism), solved)[0]
    return full[compiled.theta_ddot_index], solved.qddot[0], reactions, full[compiled.multiplier_index], solved


@pytest.mark.parametrize("label", [label for label, _ in CASES])
def test_three_ways_agree_at_random_tree_states(label):
    """At random tree states (s, sd) and random numbers (masses, points, guides, speeds, damping, g): the DAE in
    tree coordinates gives the tree Lagrange and Newton–Euler formulations' joint accelerations, every body's
    acceleration, every joint's reaction row (theirs by Newton's law on their accelerations) and the closures'
    multipliers; and the maximal DAE's accelerations and multipliers at the same pose, all within 1e-10."""
    mechanism = dict(CASES)[label]
    rng = np.random.default_rng(zlib.crc32(label.encode()))
    checked = 0
    for _ in range(3):
        numbers = renumbered(mechanism, rng)
        compiled = tree_dae.compiled_tree_dae(numbers)
        maximal = engine.compiled_system(numbers, "dae")
        n = compiled.n
        for _ in range(2):
            t = float(rng.uniform(0, 3))
            s, sd = rng.normal(scale=0.7, size=n), rng.normal(size=n)
            params = parameter_vector(numbers, t)
            full, condition = compiled.solve_full(s, sd, params)
            if not condition < 1e8:
                continue
            sdd = full[compiled.theta_ddot_index]
            reactions = full[compiled.multiplier_index]
            size = 3 * len(numbers.bodies)
            qddot = full[:size]
            for method in TREE_METHODS:
                their_sdd, their_qddot, their_reactions, closures, solved = _tree_solution(numbers, method, s, sd,
                                                                                           params)
                assert _relative(sdd, their_sdd) < AGREEMENT, method
                assert _relative(qddot, their_qddot) < AGREEMENT, method
                assert _relative(reactions, their_reactions) < AGREEMENT, method
                # the tree formulation's multipliers are its closures' (cut joints, then motors): the same rows
                rows_of = _closure_rows_in_the_dae(numbers, Constraints(numbers))
                assert closures.size == compiled.constraint_count == len(rows_of)
                assert sorted(rows_of) == list(np.asarray(compiled.module.CONSTRAINT_ROWS) - size)
                assert _relative(reactions[rows_of], closures) < AGREEMENT, method
            # the maximal DAE at the same pose and velocities
            q, qdot = solved.q[0], solved.qdot[0]
            maximal_full, _ = maximal.solve_full(q, qdot, params)
            assert _relative(qddot, maximal_full[maximal.theta_ddot_index]) < AGREEMENT
            assert _relative(reactions, maximal_full[maximal.multiplier_index]) < AGREEMENT
            # its own kinematics: the pose, and qddot = J sdd + bias
            jacobian, pose, bias = compiled.kinematics_states(s[None, :], sd[None, :], params)
            assert _relative(pose[0], q) < AGREEMENT
            assert _relative(jacobian[0] @ sdd + bias[0], qddot) < AGREEMENT
            checked += 1
    assert checked >= 3


def test_the_constraint_rows_are_the_closures_second_time_derivatives():
    """(A x - b)[constraint_rows[i]] = phi_i'' along a motion in tree coordinates (t advancing too) for any
    ``x`` whose bodies' accelerations are the motion's (``qddot = J sdd + bias``: what every solution holds, so
    Baumgarte's terms on these rows act on phi), and the generated Jacobian and rate are phi's: central
    differences on the slider-crank, the crank-rocker (its speed motor's row is held) and a random mechanism."""
    cases = (MECHANISM_PRESETS["slider-crank"](), MECHANISM_PRESETS["crank-rocker"](), random_mechanisms()[3])
    for mechanism in cases:
        compiled = tree_dae.compiled_tree_dae(mechanism)
        rng = np.random.default_rng(7)
        n = compiled.n
        s, sd, x = rng.normal(scale=0.5, size=n), rng.normal(size=n), rng.normal(size=compiled.n_unknowns)
        acceleration = x[compiled.theta_ddot_index]
        t = 0.4
        params = parameter_vector(mechanism, t)
        pose_jacobian, _, bias = compiled.kinematics_states(s[None, :], sd[None, :], params)
        x[: 3 * len(mechanism.bodies)] = pose_jacobian[0] @ acceleration + bias[0]
        rows = np.asarray(compiled.module.CONSTRAINT_ROWS)
        assert rows.size > 0
        A, b = compiled.matrix(s, sd, params)
        h = 1e-4

        def phi_at(position, time):
            moved = params.copy()
            moved[-1] = time
            return compiled.constraint_states(np.array([time]), position[None, :], np.zeros((1, n)), moved)[1][0]

        def along(step):
            return phi_at(s + sd * step + 0.5 * acceleration * step**2, t + step)

        np.testing.assert_allclose((A @ x - b)[rows], (along(h) - 2 * along(0.0) + along(-h)) / h**2, rtol=0,
                                   atol=1e-6)
        jacobian, _, rate = compiled.constraint_states(np.array([t]), s[None, :], sd[None, :], params)
        np.testing.assert_allclose(rate[0], (along(h) - along(-h)) / (2 * h), rtol=0, atol=1e-6)
        for j in range(n):
            step = np.zeros(n)
            step[j] = h
            np.testing.assert_allclose(jacobian[0][:, j], (phi_at(s + step, t) - phi_at(s - step, t)) / (2 * h),
                                       rtol=0, atol=1e-6)


# ------------------------------------------------------------------------- closed loops, run both ways


@pytest.mark.parametrize("name", ["slider-crank", "stephenson-six-bar", "geared-five-bar"])
@pytest.mark.parametrize("stabilization", ["projection", "baumgarte"])
def test_a_closed_loop_in_tree_coordinates_follows_the_maximal_dae(name, stabilization):
    """Two seconds of a closed-loop preset (the geared five-bar integrated, not by position analysis), DOP853 at
    1e-12: the DAE in tree coordinates and the maximal DAE agree on every pose, velocity and reaction row to
    1e-9 of their largest (measured at worst 1.5e-9 absolute on velocities of size 10: the two integrate different
    variables), and the loops stay closed."""
    mechanism = MECHANISM_PRESETS[name]()
    options = dict(method="dae", rtol=1e-12, atol=1e-12, integrate=True, stabilization=stabilization)
    run = simulate_mechanism(mechanism, 2.0, 41, coordinates="tree", **options)
    maximal = simulate_mechanism(mechanism, 2.0, 41, **options)
    assert run.status == 0 and maximal.status == 0
    assert run.row_names == maximal.row_names and run.coordinate_names == maximal.coordinate_names
    for mine, theirs in ((run.q, maximal.q), (run.qdot, maximal.qdot), (run.reaction_rows, maximal.reaction_rows),
                         (run.energy, maximal.energy)):
        assert _relative(mine, theirs) < 1e-9
    assert np.max(run.residual) < 1e-11


def test_a_driven_mechanism_in_tree_coordinates_is_position_analysis():
    """The Jansen leg's motor fixes every body: each sample by position analysis on the tree coordinates'
    closures, its reactions the DAE's own multipliers, equal to the maximal DAE's run."""
    mechanism = MECHANISM_PRESETS["jansen-leg"]()
    run = simulate_mechanism(mechanism, 1.0, 21, method="dae", coordinates="tree")
    maximal = simulate_mechanism(mechanism, 1.0, 21, method="dae")
    assert not run.integrated and run.status == 0
    assert _relative(run.q, maximal.q) < 1e-9 and _relative(run.reaction_rows, maximal.reaction_rows) < 1e-9


def test_coordinates_are_checked_in_one_line():
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    with pytest.raises(LinkageError, match="coordinates = 'joint': allowed values maximal, tree"):
        simulate_mechanism(mechanism, 0.1, 3, coordinates="joint")
    with pytest.raises(LinkageError, match="applies to method 'dae' only"):
        simulate_mechanism(mechanism, 0.1, 3, method="lagrange", coordinates="tree")


def test_editing_numbers_derives_and_compiles_nothing(monkeypatch):
    """Once the structure's DAE in tree coordinates is loaded, runs with other masses, inertias, points, g and
    motor speeds use the same system and the same machine code: nothing is derived, generated or compiled.
    The system's specialised functions (compiled once per structure from its second run on, in the background
    in normal use) are made here in the call, before the machine code is counted: they belong to the structure."""
    rng = np.random.default_rng(5)
    base = MECHANISM_PRESETS["slider-crank"]()
    monkeypatch.setattr(cache, "SPECIALISE_IN_BACKGROUND", False)
    for _ in range(2):
        simulate_mechanism(base, 0.05, 3, method="dae", coordinates="tree")
    loaded = tree_dae.compiled_tree_dae(base)
    machine_code = dict(loaded._functions)

    def refuse(*_args, **_kwargs):
        raise AssertionError("a number's edit derived or generated code")

    monkeypatch.setattr(cache, "_generate", refuse)
    for _ in range(3):
        edited = renumbered(base, rng)
        assert tree_dae.compiled_tree_dae(edited) is loaded
        run = simulate_mechanism(edited, 0.2, 5, method="dae", coordinates="tree")
        assert np.all(np.isfinite(run.q)) and np.max(run.residual) < 1e-9
    assert loaded._functions == machine_code  # no module compiled again
