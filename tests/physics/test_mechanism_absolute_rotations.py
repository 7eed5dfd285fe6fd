"""Absolute rotations for the tree formulations (``rotations="absolute"``, physics/mechanism/tree_coordinates.py):
a pin's tree coordinate is the child body's own rotation from the sketch, not its rotation relative to its parent.

A chain written as a mechanism sketched hanging straight down (:func:`physics.mechanism.chains.chain_mechanism`
with ``theta_sketch = 0``) then integrates exactly the chain engine's state, its absolute angles from the
downward vertical. Checked against independent numbers: the chain engine's own derived formulations (the chain
formulas of docs/physics.md, physics/derive), its own run (physics.simulate), and the mechanism's maximal DAE on
random general mechanisms. The relative rotations (the default) keep their keys and their code.
"""

from __future__ import annotations

import numpy as np
import pytest

from physics import Settings, get_preset, load_compiled, simulate
from physics.errors import LinkageError
from physics.loop_closure import tip_position
from physics.mechanism import MECHANISM_PRESETS, engine, tree_dae
from physics.mechanism.chains import chain_mechanism, chain_quantities, chain_state
from physics.mechanism.numeric_dae import MechanismDAE
from physics.mechanism.parameters import parameter_vector, structure_key
from physics.mechanism.prepared import prepared
from physics.mechanism.simulate import simulate_mechanism
from physics.mechanism.tree_coordinates import tree_state
from physics.model import Bar, Chain

from .test_mechanism_symbolic import RANDOM_SEEDS, _closure_rows_in_the_dae, random_mechanisms

ABSOLUTE = "absolute"
CHAIN_AGREEMENT = 1e-12  # relative to the largest value: the same equations in the same coordinates
AGREEMENT = 1e-10  # relative: the same equations in other coordinates (as tests/physics/test_mechanism_lagrange.py)
METHODS = ("lagrange", "newton_euler", "tree_dae")


def _relative(mine: np.ndarray, theirs: np.ndarray) -> float:
    mine, theirs = np.ravel(mine), np.ravel(theirs)
    assert mine.shape == theirs.shape
    return float(np.max(np.abs(mine - theirs), initial=0.0) / (1.0 + np.max(np.abs(theirs), initial=0.0)))


def random_chain(rng: np.random.Generator, n: int, pinned: bool) -> tuple[Chain, np.ndarray, np.ndarray]:
    """A chain of ``n`` bars with random numbers and a random state ``(theta, omega)`` on its constraints: a
    pinned chain's tip is pinned where ``theta`` puts it, and ``omega`` keeps it there."""
    L = rng.uniform(0.3, 2.0, n)
    bars = [Bar(L=L[k], d=L[k] * rng.uniform(0.1, 0.9), m=rng.uniform(0.2, 3.0), I=rng.uniform(0.01, 1.0))
            for k in range(n)]
    theta, omega = rng.uniform(-np.pi, np.pi, n), rng.normal(size=n)
    pin = None
    if pinned:
        pin = tuple(float(v) for v in tip_position(L, theta))
        tip_rate = np.vstack([L * np.cos(theta), L * np.sin(theta)])  # d tip / d theta
        omega = omega - np.linalg.pinv(tip_rate) @ (tip_rate @ omega)
    return Chain(bars=bars, g=rng.uniform(0.5, 10.0), pin=pin), theta, omega


def tree_order(mechanism) -> list[int]:
    """The bars in the tree coordinates' order (the spanning tree's, breadth-first from the ground): the chain's
    own order for an open chain; the four-bar's tip pin H reaches bar 3 from the ground before J1 reaches bar 2,
    so its coordinates are (theta1, theta3, theta2) and its closure is J2."""
    return [int(body.removeprefix("bar")) - 1 for body in prepared(mechanism).topology.parent]


def _solve(mechanism, method: str, s: np.ndarray, sd: np.ndarray):
    """The formulation's own solve at the tree state: its coordinates' accelerations and its multipliers."""
    compiled = (tree_dae.compiled_tree_dae(mechanism, rotations=ABSOLUTE) if method == "tree_dae"
                else engine.compiled_system(mechanism, method, rotations=ABSOLUTE))
    full, _ = compiled.solve_full(s, sd, parameter_vector(mechanism))
    return full[compiled.theta_ddot_index], full[compiled.multiplier_index]


CHAINS = [(n, False) for n in range(1, 5)] + [(3, True)]  # open chains of 1 to 4 bars; the four-bar


@pytest.mark.parametrize(("n", "pinned"), CHAINS)
def test_the_tree_coordinates_of_a_chain_hanging_down_are_its_angles(n, pinned):
    """With absolute rotations, the tree state of the chain's mechanism sketched hanging straight down is the
    chain's ``(theta, omega)`` bit for bit (the four-bar's in its tree's order); with relative ones an open
    chain's is the differences of neighbours."""
    rng = np.random.default_rng(100 + n + 10 * pinned)
    for _ in range(5):
        chain, theta, omega = random_chain(rng, n, pinned)
        mechanism = chain_mechanism(chain, np.zeros(n))
        order = tree_order(mechanism)
        assert order == ([0, 2, 1] if pinned else list(range(n)))
        q, qdot = chain_state(chain, np.zeros(n), theta, omega)
        s, sd = tree_state(mechanism, q, qdot, rotations=ABSOLUTE)
        assert np.array_equal(s, theta[order]) and np.array_equal(sd, omega[order])
        if not pinned:
            relative, relative_rate = tree_state(mechanism, q, qdot)
            np.testing.assert_allclose(relative, np.diff(theta, prepend=0.0), rtol=0, atol=1e-15)
            np.testing.assert_allclose(relative_rate, np.diff(omega, prepend=0.0), rtol=0, atol=1e-15)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize(("n", "pinned"), CHAINS)
def test_every_tree_formulation_in_absolute_rotations_equals_the_chains_own(n, pinned, method):
    """At random states and random numbers (one compiled structure for every set of numbers): the angular
    accelerations of the tree formulation with absolute rotations equal the chain engine's own formulation's
    (the tree DAE: the chain's DAE) to 1e-12 of their largest; its multipliers equal the chain DAE's reactions
    of the same joints (the tree DAE: every joint's, pins O, J1.. and the tip's H; Lagrange and Newton-Euler on
    the four-bar: their one closure, J2, the force ON bar 3 BY bar 2). The chain's own Lagrange and Newton-Euler
    close the tip instead (H): their multipliers are checked against Newton's law below."""
    rng = np.random.default_rng(2000 + 10 * n + pinned + 100 * METHODS.index(method))
    chain_system = load_compiled("dae" if method == "tree_dae" else method, n, pinned)
    chain_dae = load_compiled("dae", n, pinned)
    for _ in range(4):
        chain, theta, omega = random_chain(rng, n, pinned)
        mechanism = chain_mechanism(chain, np.zeros(n))
        order = tree_order(mechanism)
        q, qdot = chain_state(chain, np.zeros(n), theta, omega)
        s, sd = tree_state(mechanism, q, qdot, rotations=ABSOLUTE)
        accelerations, multipliers = _solve(mechanism, method, s, sd)
        chain_full, _ = chain_system.solve_full(theta, omega, chain.params())
        expected = chain_full[chain_system.theta_ddot_index][order]
        assert _relative(accelerations, expected) < CHAIN_AGREEMENT
        dae_full, _ = chain_dae.solve_full(theta, omega, chain.params())
        pins = dae_full[chain_dae.reaction_index]  # (n, 2): O, J1 .. J(n-1)
        if method == "tree_dae":
            expected_rows = np.concatenate([pins.ravel(), dae_full[chain_dae.tip_reaction_index]])
        else:
            expected_rows = pins[2] if pinned else np.zeros(0)
        assert multipliers.shape == expected_rows.shape
        assert _relative(multipliers, expected_rows) < CHAIN_AGREEMENT


@pytest.mark.parametrize("method", ["lagrange", "newton_euler"])
@pytest.mark.parametrize(("n", "pinned"), [(3, False), (3, True)])
def test_newtons_law_on_the_absolute_accelerations_gives_the_chains_reactions(n, pinned, method):
    """Every pin's reaction of a tree formulation run in absolute rotations (Newton's second law on its
    accelerations, :func:`physics.mechanism.engine.instant`) equals the chain DAE's reactions, and the tip's the
    chain's own formulation's multiplier (the chain's Lagrange and Newton-Euler close the tip)."""
    rng = np.random.default_rng(3000 + pinned)
    chain_dae = load_compiled("dae", n, pinned)
    chain_own = load_compiled(method, n, pinned)
    for _ in range(3):
        chain, theta, omega = random_chain(rng, n, pinned)
        mechanism = chain_mechanism(chain, np.zeros(n))
        q, qdot = chain_state(chain, np.zeros(n), theta, omega)
        qddot, reactions = engine.instant(mechanism, method, q, qdot, rotations=ABSOLUTE)
        dae_full, _ = chain_dae.solve_full(theta, omega, chain.params())
        assert _relative(qddot[2::3], dae_full[chain_dae.theta_ddot_index]) < CHAIN_AGREEMENT
        assert _relative(reactions[: 2 * n], dae_full[chain_dae.reaction_index].ravel()) < CHAIN_AGREEMENT
        own_full, _ = chain_own.solve_full(theta, omega, chain.params())
        assert _relative(reactions[2 * n :], own_full[chain_own.tip_reaction_index]) < CHAIN_AGREEMENT


@pytest.mark.parametrize("seed", RANDOM_SEEDS)
def test_a_random_general_mechanism_agrees_three_ways_in_absolute_rotations(seed):
    """The random valid mechanisms of tests/physics/test_mechanism_symbolic.py (sliders on moving guides, guides
    hanging from sliders, dampers on every joint, speed and torque motors, one or two closures) at random tree
    states and times, in absolute rotations: each tree formulation's generated code maps its coordinates back
    onto a pose whose tree coordinates are the state again, and gives every body's accelerations of the numeric
    maximal DAE at that pose (1e-10 relative, as for relative rotations) and its closures' multipliers; the tree
    DAE gives every reaction row of it, and the same coordinates' accelerations as Lagrange."""
    mechanism = random_mechanisms()[seed]
    rng = np.random.default_rng(4000 + seed)
    dae = MechanismDAE(mechanism)
    rows_of = _closure_rows_in_the_dae(mechanism, dae.constraints)
    systems = {method: engine.compiled_system(mechanism, method, rotations=ABSOLUTE)
               for method in ("lagrange", "newton_euler")}
    systems["tree_dae"] = tree_dae.compiled_tree_dae(mechanism, rotations=ABSOLUTE)
    n = systems["lagrange"].n
    checked = 0
    for _ in range(6):
        t = float(rng.uniform(0.0, 3.0))
        s, sd = rng.normal(scale=0.7, size=n), rng.normal(size=n)
        params = parameter_vector(mechanism, t)
        answers = {}
        for method, system in systems.items():
            solved = engine.samples(system, params, np.array([t]), s[None, :], sd[None, :])
            answers[method] = solved
        if not all(solved.kernel_condition[0] < 1e8 for solved in answers.values()):
            continue
        q, qdot = answers["lagrange"].q[0], answers["lagrange"].qdot[0]
        back = tree_state(mechanism, q, qdot, rotations=ABSOLUTE)
        assert _relative(back[0], s) < 1e-12 and _relative(back[1], sd) < 1e-12
        expected = dae.solve(q, qdot)
        for method, solved in answers.items():
            assert _relative(solved.q[0], q) < 1e-12 and _relative(solved.qdot[0], qdot) < 1e-12, method
            assert _relative(solved.qddot[0], expected.qddot) < AGREEMENT, method
            rows = expected.reactions if method == "tree_dae" else expected.reactions[rows_of]
            assert _relative(solved.multipliers[0], rows) < AGREEMENT, method
        full = {method: systems[method].solve_full(s, sd, params)[0] for method in ("lagrange", "tree_dae")}
        assert _relative(full["tree_dae"][systems["tree_dae"].theta_ddot_index],
                         full["lagrange"][systems["lagrange"].theta_ddot_index]) < AGREEMENT
        checked += 1
    assert checked >= 2


def test_the_random_mechanisms_have_sliders_and_motors_and_the_conventions_differ_on_them():
    """The cases above hold what the brief names, and absolute rotations are not the relative ones renamed."""
    sliders = speed = torque = differ = 0
    for mechanism in random_mechanisms():
        sliders += sum(joint.kind == "prismatic" for joint in mechanism.joints)
        speed += sum(driver.speed is not None for driver in mechanism.drivers)
        torque += sum(driver.torque is not None for driver in mechanism.drivers)
        q = MechanismDAE(mechanism).constraints.sketch_pose() + 0.3
        qdot = np.ones_like(q)
        differ += not np.allclose(tree_state(mechanism, q, qdot)[0], tree_state(mechanism, q, qdot,
                                                                                   rotations=ABSOLUTE)[0])
    assert sliders >= 3 and speed >= 1 and torque >= 1 and differ >= 4


def test_the_option_is_part_of_the_compiled_key_and_the_default_keeps_its_own():
    """Relative and absolute rotations never share generated code; the relative key is the one every cached
    mechanism has had; the DAE's maximal coordinates have one meaning (one key)."""
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    digest = structure_key(mechanism)
    for method in ("lagrange", "newton_euler"):
        assert engine._cache_key(mechanism, method) == f"{method.replace('_', '')}-mechanism-{digest}"
        assert engine._cache_key(mechanism, method, ABSOLUTE) != engine._cache_key(mechanism, method)
        assert engine.compiled_system(mechanism, method, rotations=ABSOLUTE) is not \
            engine.compiled_system(mechanism, method)
    assert engine._cache_key(mechanism, "dae", ABSOLUTE) == engine._cache_key(mechanism, "dae")
    assert tree_dae.compiled_tree_dae(mechanism, rotations=ABSOLUTE) is not tree_dae.compiled_tree_dae(mechanism)


def test_a_bad_or_inapplicable_rotations_is_refused_in_one_line():
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    with pytest.raises(LinkageError, match=r"^rotations = 'sideways': allowed values relative, absolute$"):
        simulate_mechanism(mechanism, 0.1, 3, method="lagrange", rotations="sideways")
    with pytest.raises(LinkageError, match=r"^rotations = 'absolute': applies to a run in tree coordinates only"):
        simulate_mechanism(mechanism, 0.1, 3, method="dae", rotations=ABSOLUTE)


# ------------------------------------------------------------------------------------------ a run of case C

CASE_C_METHODS = {"lagrange": ("lagrange", "maximal"), "newton_euler": ("newton_euler", "maximal"),
                  "tree_dae": ("dae", "tree")}


# the largest angle or rate difference allowed at 20 s, from rounding grown by the motion: case C is chaotic
# (measured 2e-8 at worst), the four-bar is not (measured 1.8e-11 at worst)
GROWN = {"triple-c": 1e-6, "four-bar": 1e-9}


@pytest.mark.parametrize("name", sorted(GROWN))
@pytest.mark.parametrize("method", sorted(CASE_C_METHODS))
def test_seed_case_c_and_the_four_bar_through_the_mechanism_engine_follow_the_chain_engine(method, name):
    """Seed case C (chaotic) and the four-bar, 20 s by RK45 at rtol = atol = 1e-6 (the seed's ode45 tolerances),
    through the chain engine (physics.simulate, the chain's own formulation) and through the chain written as a
    mechanism in absolute rotations (the tree DAE for the chain's DAE): both integrate the same state and take the
    same steps (case C, measured: 192 accepted, 1502 right-hand sides each). They differ by rounding (the two codes sum in other
    orders): 2e-16 at 1 s, at most 1e-14 at 5 s, then grown by the chaos to 4e-9 (Lagrange), 2e-8
    (Newton-Euler), 8e-9 (DAE) at 20 s. In relative rotations the same runs take 196 steps and end 3.3 rad
    apart, the integrator's tolerance grown by the same chaos. The four-bar (the seed's, its tip pinned, held by
    projection: on the closure J2 in the mechanism's tree, on the tip H in the chain's) likewise: 113 steps
    each, 2e-11 apart at 20 s (relative: 117 steps, 2e-3 apart)."""
    preset = get_preset(name)
    chain = preset.chain
    sketch = np.zeros(chain.n)
    mechanism = chain_mechanism(chain, sketch)
    q0, qdot0 = chain_state(chain, sketch, preset.theta0, preset.omega0)
    mechanism_method, coordinates = CASE_C_METHODS[method]
    settings = Settings(method="dae" if method == "tree_dae" else method, integrator="RK45", rtol=1e-6, atol=1e-6,
                        t_end=20.0, samples=201)
    run = simulate_mechanism(mechanism, 20.0, 201, q0=q0, qdot0=qdot0, method=mechanism_method,
                             coordinates=coordinates, integrator="RK45", rtol=1e-6, atol=1e-6, rotations=ABSOLUTE)
    chain_run = simulate(chain, preset.theta0, preset.omega0, settings)
    assert run.status == 0 and chain_run.status == 0
    theta, omega, _, _ = chain_quantities(chain, sketch, run)
    assert (run.n_steps, run.n_rhs) == (chain_run.n_steps, chain_run.n_rhs)
    early = run.t <= 5.0
    np.testing.assert_allclose(theta[early], chain_run.theta[early], rtol=0, atol=1e-13)
    np.testing.assert_allclose(omega[early], chain_run.omega[early], rtol=0, atol=1e-13)
    np.testing.assert_allclose(theta, chain_run.theta, rtol=0, atol=GROWN[name])
    np.testing.assert_allclose(omega, chain_run.omega, rtol=0, atol=GROWN[name])
