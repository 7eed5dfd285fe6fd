"""The three formulations of any mechanism agree, each derived on its own: Lagrange and Newton–Euler on a
spanning tree against the maximal-coordinate DAE, at random assembled states of every mechanism preset and of random valid mechanisms (open and closed chains,
slider-cranks of random proportions, driven crank-rockers and Jansen legs at random speeds): every body's angular
acceleration and every multiplier of the joints they close by constraints (cut joints, motors), within 1e-10; and
every reaction row of every joint, the tree's own joints included (Newton's second law on each tree formulation's
own accelerations, physics/mechanism/engine.py), in the DAE's layout and signs, within 1e-10. The tree
formulations run as the engine runs them: generated once per structure, compiled, numbers as parameters.
"""

from __future__ import annotations

import numpy as np
import pytest

from physics import Bar, Chain
from physics.loop_closure import tip_position
from physics.mechanism import MECHANISM_PRESETS, analyse, assemble, engine
from physics.mechanism.chains import chain_mechanism
from physics.mechanism.numeric_dae import MechanismDAE
from physics.mechanism.parameters import parameter_vector
from physics.mechanism.presets import crank_rocker, jansen_leg, slider_crank
from physics.mechanism.simulate import project_velocity
from physics.mechanism.tree_coordinates import tree_state

STATES = 12


# Issue 16: accelerations and every multiplier within 1e-10 relative (measured: 1e-14 at worst, the Jansen leg)
AGREEMENT = 1e-10


def assert_three_way_agreement(mechanism, formulation: str, rng: np.random.Generator, states: int = STATES) -> None:
    """At ``states`` random assembled states: the tree formulation's generated code (compiled once per
    structure, its numbers a parameter vector) maps its tree coordinates back onto the pose, and gives every
    body's accelerations and every reaction row of the numeric DAE."""
    dae = MechanismDAE(mechanism)
    compiled = engine.compiled_system(mechanism, formulation)
    params = parameter_vector(mechanism)
    checked = 0
    for _ in range(states):
        guess = dae.constraints.sketch_pose() + rng.normal(scale=0.05, size=dae.constraints.size)
        q = assemble(mechanism, guess).q
        qdot = project_velocity(dae, q, rng.normal(size=dae.constraints.size))
        s, sd = tree_state(mechanism, q, qdot)
        solved = engine.samples(compiled, params, np.zeros(1), s[None, :], sd[None, :])
        assert np.allclose(solved.q[0], q, atol=1e-12) and np.allclose(solved.qdot[0], qdot, atol=1e-10)
        dae_solution = dae.solve(q, qdot)
        qddot, reactions = engine.instant(mechanism, formulation, q, qdot)
        scale = 1.0 + np.max(np.abs(dae_solution.qddot))
        assert np.max(np.abs(qddot - dae_solution.qddot)) <= AGREEMENT * scale
        assert reaction_disagreement(reactions, dae_solution.reactions) <= AGREEMENT, (
            dae.constraints.rows[int(np.argmax(np.abs(reactions - dae_solution.reactions)))])
        checked += 1
    assert checked == states


def reaction_disagreement(mine: np.ndarray, theirs: np.ndarray) -> float:
    """The largest difference of any reaction row, relative to 1 + the largest reaction."""
    assert mine.shape == theirs.shape
    return float(np.max(np.abs(mine - theirs)) / (1.0 + np.max(np.abs(theirs))))


@pytest.mark.parametrize("formulation", ["lagrange", "newton_euler"])
@pytest.mark.parametrize("name", sorted(MECHANISM_PRESETS))
def test_tree_formulations_match_the_dae_at_random_states(name, formulation):
    assert_three_way_agreement(MECHANISM_PRESETS[name](), formulation, np.random.default_rng(sum(map(ord, name))))


def random_mechanism(rng: np.random.Generator, kind: str):
    """A random valid mechanism of ``kind``: an open chain of 1 to 5 bars, a chain of 3 or 4 bars whose tip is
    pinned where a random pose puts it (a four-bar, a five-bar of two degrees of freedom), a slider-crank of
    random proportions, or a driven crank-rocker or Jansen leg at a random motor speed and crank angle."""
    if kind in ("open chain", "closed chain"):
        n = int(rng.integers(1, 6)) if kind == "open chain" else int(rng.integers(3, 5))
        L = rng.uniform(0.3, 2.0, n)
        sketch = rng.uniform(-np.pi, np.pi, n)
        bars = [Bar(L=L[k], d=L[k] * rng.uniform(0.1, 0.9), m=rng.uniform(0.2, 3.0), I=rng.uniform(0.01, 1.0))
                for k in range(n)]
        pin = tuple(float(v) for v in tip_position(L, sketch)) if kind == "closed chain" else None
        return chain_mechanism(Chain(bars=bars, g=rng.uniform(0.5, 10.0), pin=pin), sketch)
    if kind == "slider-crank":
        crank = rng.uniform(0.02, 0.1)
        return slider_crank(crank=crank, rod=crank * rng.uniform(2.5, 5.0), angle_deg=rng.uniform(10.0, 170.0))
    if kind == "crank-rocker":
        return crank_rocker(speed=rng.uniform(0.5, 10.0))
    return jansen_leg(speed=rng.uniform(0.5, 6.0), crank_angle_deg=rng.uniform(0.0, 360.0))


KINDS = ("open chain", "closed chain", "slider-crank", "crank-rocker", "jansen-leg")


@pytest.mark.parametrize("formulation", ["lagrange", "newton_euler"])
@pytest.mark.parametrize("kind", KINDS)
def test_tree_formulations_match_the_dae_on_random_valid_mechanisms(kind, formulation):
    rng = np.random.default_rng(20261124 + KINDS.index(kind))
    for _ in range(4):
        assert_three_way_agreement(random_mechanism(rng, kind), formulation, rng, states=3)


@pytest.mark.parametrize("formulation", ["lagrange", "newton_euler"])
@pytest.mark.parametrize("name", ["slider-crank", "jansen-leg"])
def test_the_reaction_check_sees_any_single_wrong_row(name, formulation):
    """The agreement check above is not blind: a tree formulation's reactions with any one row off by 1e-8 of
    the largest reaction fail it, the tree's own joints' rows as much as the multipliers' rows."""
    mechanism = MECHANISM_PRESETS[name]()
    dae = MechanismDAE(mechanism)
    rng = np.random.default_rng(7)
    q = assemble(mechanism, dae.constraints.sketch_pose() + rng.normal(scale=0.05, size=dae.constraints.size)).q
    qdot = project_velocity(dae, q, rng.normal(size=dae.constraints.size))
    _, reactions = engine.instant(mechanism, formulation, q, qdot)
    theirs = dae.solve(q, qdot).reactions
    assert reaction_disagreement(reactions, theirs) <= AGREEMENT
    tree_joints = {joint for _body, (joint, _parent) in analyse(mechanism).parent.items()}
    tree_rows = [k for k, row in enumerate(dae.constraints.rows) if row.joint in tree_joints]
    assert tree_rows  # the tree's own joints are among the rows checked
    for k in range(len(reactions)):
        wrong = reactions.copy()
        wrong[k] += 1e-8 * (1.0 + np.max(np.abs(theirs)))
        assert reaction_disagreement(wrong, theirs) > AGREEMENT, dae.constraints.rows[k]


def _moving_guides():
    """A block sliding on a swinging arm (the slider's body is the tree child), and a rail hanging from a block
    pinned to the ground (the guide's carrier is the tree child): both ways a slider can sit in the tree."""
    from physics.mechanism import Mechanism  # noqa: PLC0415

    arm = {"ground": {"O": [0, 0]}, "bodies": [
        {"name": "arm", "mass": 1, "inertia": 0.1, "points": {"O": [0, 0], "T": [1, 0.2]}},
        {"name": "block", "mass": 0.5, "inertia": 0.01, "points": {"P": [0.5, 0.3], "Q": [0.6, 0.4]}}],
        "joints": [{"kind": "revolute", "name": "O", "a": "ground.O", "b": "arm.O", "damping": 0.05},
                   {"kind": "prismatic", "name": "S", "body": "block", "point": "P", "on": "arm", "through": "T",
                    "direction": [1, 0.3]}]}
    rail = {"ground": {"O": [0, 0]}, "bodies": [
        {"name": "block", "mass": 0.5, "inertia": 0.02, "points": {"O": [0, 0], "P": [0.1, 0.05]}},
        {"name": "rail", "mass": 1.2, "inertia": 0.2, "points": {"T": [0.3, 0.4], "E": [1.0, -0.3]}}],
        "joints": [{"kind": "revolute", "name": "O", "a": "ground.O", "b": "block.O"},
                   {"kind": "prismatic", "name": "S", "body": "block", "point": "P", "on": "rail", "through": "T",
                    "direction": [0.8, -0.6]}],
        "drivers": [{"joint": "O", "torque": 0.7}]}
    return [Mechanism.model_validate(arm), Mechanism.model_validate(rail)]


def _damped_torque_driven_crank_rocker():
    spec = crank_rocker().model_dump()
    spec["drivers"] = [{"joint": spec["drivers"][0]["joint"], "torque": 0.4}]
    for joint in spec["joints"]:
        joint["damping"] = 0.02
    from physics.mechanism import Mechanism  # noqa: PLC0415

    return Mechanism.model_validate(spec)


@pytest.mark.parametrize("formulation", ["lagrange", "newton_euler"])
def test_every_reaction_agrees_with_sliders_on_moving_guides_damping_and_torque_motors(formulation):
    """The tree joints' reactions where the slider's moment balance matters (its guide turns), with pin damping
    and a torque motor among the loads."""
    rng = np.random.default_rng(99)
    for mechanism in [*_moving_guides(), _damped_torque_driven_crank_rocker()]:
        assert_three_way_agreement(mechanism, formulation, rng, states=4)
