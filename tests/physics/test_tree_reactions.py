"""A tree formulation's reactions in closed form (physics/mechanism/tree_reactions.py): for an open tree of pins,
with speed and torque motors and dampers on its pins, the backward recursion gives every reaction row the QR of
``Phi_q^T`` gives (engine.body_reactions) and the maximal DAE's multipliers, at random assembled states and random
numbers; so do loops of pins (the cut pins and motors from a small system first: random four-bars with and
without motors, two loops, every preset of pins with loops on its own runs, poses a little off closure), a
near-singular small system falls back to the QR, a slider or a gear keeps the QR, and a run of pins reads no
Jacobian for its reactions."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from physics.mechanism import engine, tree_reactions
from physics.mechanism.assembly import _rank, assemble
from physics.mechanism.constraints import Constraints
from physics.mechanism.description import Body, Driver, Mechanism, Revolute
from physics.mechanism.joints.prismatic import Prismatic
from physics.mechanism.numeric_dae import MechanismDAE
from physics.mechanism.prepared import prepared
from physics.mechanism.presets import MECHANISM_PRESETS
from physics.mechanism.simulate import simulate_mechanism
from physics.mechanism.tree_coordinates import tree_state
from physics.mechanism.tree_reactions import LoopReactions

RELATIVE = 1e-12
STATES = 6


def _body(rng, name: str, x: float, y: float) -> Body:
    """A bar from (x, y) with a second point and a centre of mass drawn at random."""
    far = (x + rng.uniform(0.3, 1.0), y - rng.uniform(0.3, 1.0))
    return Body(name=name, points={"P": (x, y), "D": far, "E": (x + rng.uniform(-0.5, 0.5), y + rng.uniform(-0.5, 0.5))},
                mass=float(rng.uniform(0.2, 3.0)), com=(x + rng.uniform(-0.2, 0.6), y + rng.uniform(-0.6, 0.2)),
                inertia=float(rng.uniform(0.01, 0.5)))


def _pin(rng, name: str, child: str, parent_point: str) -> Revolute:
    """A pin between the child's point P and ``parent_point``, its sides in random order, randomly damped."""
    ends = [f"{child}.P", parent_point]
    if rng.random() < 0.5:
        ends.reverse()
    return Revolute(name=name, a=ends[0], b=ends[1], damping=float(rng.choice([0.0, rng.uniform(0.0, 2.0)])))


def random_chain(rng, n: int, motors: bool = False) -> Mechanism:
    """An n-bar chain hanging from the ground's O, random numbers (and, with ``motors``, a speed motor on one pin
    and a torque motor on another where there is one)."""
    bodies, joints = [], []
    x, y = 0.0, 0.0
    for k in range(1, n + 1):
        body = _body(rng, f"bar{k}", x, y)
        bodies.append(body)
        joints.append(_pin(rng, f"J{k}", body.name, "ground.O" if k == 1 else f"bar{k - 1}.D"))
        x, y = body.points["D"]
    drivers = []
    if motors:
        drivers.append(Driver(joint=f"J{rng.integers(1, n + 1)}", speed=float(rng.uniform(-3, 3))))
        free = [joint.name for joint in joints if joint.name != drivers[0].joint]
        if free:
            drivers.append(Driver(joint=str(rng.choice(free)), torque=float(rng.uniform(-5, 5))))
    return Mechanism(name=f"chain of {n}", g=float(rng.uniform(1.0, 12.0)), ground={"O": (0.0, 0.0)},
                     bodies=bodies, joints=joints, drivers=drivers)


def random_tree(rng, slider: bool = False) -> Mechanism:
    """A branched open tree of six bodies (two hang from the ground, the others from a random earlier body's D or
    E), speed motors on two pins and a torque motor on a third; with ``slider`` the last body slides on a guide of
    the body before it instead of hanging from a pin."""
    bodies, joints = [], []
    for k in range(1, 7):
        if k <= 2:
            parent, where = "ground", ("O" if k == 1 else "H")
            x, y = (0.0, 0.0) if k == 1 else (1.0, 0.5)
        else:
            parent_body = bodies[int(rng.integers(0, k - 1))]
            where = str(rng.choice(["D", "E"]))
            parent = parent_body.name
            x, y = parent_body.points[where]
        body = _body(rng, f"b{k}", x, y)
        bodies.append(body)
        if slider and k == 6:
            bodies[-1] = body
            joints.append(Prismatic(name=f"J{k}", body=body.name, point="P", on=bodies[4].name, through="D",
                                    direction=(float(rng.uniform(0.2, 1.0)), float(rng.uniform(-1.0, 1.0))),
                                    damping=float(rng.uniform(0.0, 1.0))))
            continue
        joints.append(_pin(rng, f"J{k}", body.name, f"{parent}.{where}"))
    speeds = rng.choice([f"J{k}" for k in range(1, 6)], size=3, replace=False)
    drivers = [Driver(joint=str(speeds[0]), speed=float(rng.uniform(-3, 3))),
               Driver(joint=str(speeds[1]), speed=float(rng.uniform(-3, 3))),
               Driver(joint=str(speeds[2]), torque=float(rng.uniform(-5, 5)))]
    return Mechanism(name="tree", g=float(rng.uniform(1.0, 12.0)), ground={"O": (0.0, 0.0), "H": (1.0, 0.5)},
                     bodies=bodies, joints=joints, drivers=drivers)


def closed_loop(rng, motors: bool = False) -> Mechanism:
    """A three-bar chain whose tip is pinned to the ground (the pin's sides in random order): a four-bar, one
    loop; with ``motors`` a slow speed motor on a random pin (mobility 0: slow, so the random states' times
    keep it near the sketch, where the loop closes) and a torque motor on another."""
    chain = random_chain(rng, 3)
    tip = chain.bodies[-1].points["D"]
    ends = ["bar3.D", "ground.H"]
    if rng.random() < 0.5:
        ends.reverse()
    joints = [*chain.joints, Revolute(name="H", a=ends[0], b=ends[1])]
    drivers = []
    if motors:
        speed, torque = rng.choice([joint.name for joint in joints], size=2, replace=False)
        drivers = [Driver(joint=str(speed), speed=float(rng.uniform(-0.1, 0.1))),
                   Driver(joint=str(torque), torque=float(rng.uniform(-5, 5)))]
    return chain.model_copy(update={"ground": {"O": (0.0, 0.0), "H": tip}, "joints": joints, "drivers": drivers})


def two_loops(rng) -> Mechanism:
    """A five-bar chain with its tip and the end of its third bar pinned to the ground: two loops, mobility 1,
    a torque motor on one pin."""
    chain = random_chain(rng, 5)
    ground = {"O": (0.0, 0.0), "H": chain.bodies[-1].points["D"], "K": chain.bodies[2].points["D"]}
    pins = [Revolute(name="H", a="ground.H", b="bar5.D"), Revolute(name="K", a="bar3.D", b="ground.K")]
    return chain.model_copy(update={"ground": ground, "joints": [*chain.joints, *pins],
                                    "drivers": [Driver(joint="J2", torque=float(rng.uniform(-5, 5)))]})


def _states(rng, mechanism: Mechanism):
    """Random assembled states: poses assembled from the sketch turned at random, velocities projected onto the
    joints' (``Phi_q qdot = nu``), and the DAE's accelerations and multipliers at each."""
    dae = MechanismDAE(mechanism)
    constraints = dae.constraints
    poses, rates, accelerations, multipliers = [], [], [], []
    for _ in range(STATES):
        t = float(rng.uniform(0.0, 2.0))
        guess = constraints.sketch_pose() + rng.normal(scale=0.4, size=constraints.size)
        q = assemble(mechanism, guess, t).q
        jacobian = constraints.jacobian(q)
        v = rng.normal(size=constraints.size)
        qdot = v - jacobian.T @ np.linalg.solve(jacobian @ jacobian.T, jacobian @ v - constraints.velocity_rhs())
        solution = dae.solve(q, qdot)
        poses.append(q)
        rates.append(qdot)
        accelerations.append(solution.qddot)
        multipliers.append(solution.reactions)
    count = len(poses)
    solved = engine.Samples(np.array(poses), np.array(rates), np.array(accelerations), np.zeros((count, 0)),
                            np.zeros(count), np.ones(count), np.zeros((count, 0, 0)))
    return dae, solved, np.array(multipliers)


def _assert_close(found: np.ndarray, expected: np.ndarray) -> None:
    scale = np.max(np.abs(expected), axis=1, keepdims=True)
    assert np.all(np.abs(found - expected) <= RELATIVE * scale), np.max(np.abs(found - expected) / scale)


def _closed_form(mechanism: Mechanism):
    return prepared(mechanism).tree_reactions


CHAINS = [(n, motors) for n in range(1, 6) for motors in (False, True)]


@pytest.mark.parametrize(("n", "motors"), CHAINS)
def test_chains_closed_form_equals_the_qr_and_the_dae(n, motors):
    rng = np.random.default_rng(100 * n + motors)
    for _ in range(3):
        mechanism = random_chain(rng, n, motors)
        closed_form = _closed_form(mechanism)
        assert closed_form is not None
        assert closed_form.motor_rows.size == (1 if motors else 0)
        dae, solved, multipliers = _states(rng, mechanism)
        fast = engine.body_reactions(dae, solved, closed_form=closed_form)
        _assert_close(fast, engine.body_reactions(dae, solved))
        _assert_close(fast, multipliers)


def test_open_tree_with_speed_and_torque_motors_takes_the_closed_form():
    rng = np.random.default_rng(7)
    for _ in range(4):
        mechanism = random_tree(rng)
        closed_form = _closed_form(mechanism)
        assert closed_form is not None and closed_form.motor_rows.size == 2
        dae, solved, multipliers = _states(rng, mechanism)
        fast = engine.body_reactions(dae, solved, closed_form=closed_form)
        _assert_close(fast, engine.body_reactions(dae, solved))
        _assert_close(fast, multipliers)


LOOPS = {"four-bar": closed_loop, "four-bar with motors": lambda rng: closed_loop(rng, motors=True),
         "two loops": two_loops}


@pytest.mark.parametrize("make", list(LOOPS.values()), ids=list(LOOPS))
def test_loops_of_pins_closed_form_equals_the_qr_and_the_dae(make):
    rng = np.random.default_rng(23)
    for _ in range(4):
        mechanism = make(rng)
        closed_form = _closed_form(mechanism)
        assert isinstance(closed_form, LoopReactions)
        dae, solved, multipliers = _states(rng, mechanism)
        fast = engine.body_reactions(dae, solved, closed_form=closed_form)
        _assert_close(fast, engine.body_reactions(dae, solved))
        _assert_close(fast, multipliers)


def test_a_loop_off_its_closure_still_equals_the_qr():
    """The closed form reads each pin's two points where they are: at a pose whose pins are 1e-6 apart (not a
    run's, whose tree pins close exactly) it still solves ``Phi_q^T lambda = M qddot - Q`` as the QR does, for
    the accelerations the DAE gives there."""
    rng = np.random.default_rng(29)
    for make in LOOPS.values():
        mechanism = make(rng)
        dae, solved, _ = _states(rng, mechanism)
        moved = solved.q + rng.normal(scale=1e-6, size=solved.q.shape)
        answers = [dae.solve(q, qdot) for q, qdot in zip(moved, solved.qdot, strict=True)]
        off = dataclasses.replace(solved, q=moved, qddot=np.array([answer.qddot for answer in answers]))
        assert np.max(np.abs([dae.constraints.residual(q) for q in moved])) > 1e-7
        _assert_close(engine.body_reactions(dae, off, closed_form=_closed_form(mechanism)),
                      engine.body_reactions(dae, off))
        _assert_close(engine.body_reactions(dae, off), np.array([answer.reactions for answer in answers]))


def test_a_near_singular_small_system_falls_back_to_the_qr(monkeypatch):
    """A sample whose small system is near losing rank comes back NaN from the closed form and is answered by
    the QR: with the rank test made to refuse every sample, the answer is the QR's bit for bit; dependent
    columns give NaN."""
    rng = np.random.default_rng(31)
    mechanism = closed_loop(rng)
    dae, solved, _ = _states(rng, mechanism)
    monkeypatch.setattr(tree_reactions, "_LOOP_RANK_RATIO", 2.0)
    closed_form = _closed_form(mechanism)
    assert np.isnan(closed_form.solve(dae.mass_diagonal, dae.applied(solved.qdot, solved.q), solved.q,
                                      solved.qddot)).all()
    assert np.array_equal(engine.body_reactions(dae, solved, closed_form=closed_form),
                          engine.body_reactions(dae, solved))
    monkeypatch.undo()
    column = rng.normal(size=(3, 4))  # (N, T): three equations, four samples
    answer = tree_reactions._least_squares([column, 2.0 * column], rng.normal(size=(3, 4)))
    assert np.isnan(answer).all()
    independent = tree_reactions._least_squares([column, rng.normal(size=(3, 4))], rng.normal(size=(3, 4)))
    assert np.isfinite(independent).all()


@pytest.mark.parametrize("name", ["crank-rocker", "chebyshev-lambda", "watt-six-bar", "stephenson-six-bar",
                                  "jansen-leg"])
def test_presets_with_loops_of_pins_take_the_closed_form_on_their_runs(name):
    """Every preset of pins with loops (driven or free, one to three loops): a tree formulation's run reads the
    closed form's reactions from its own multipliers of the cut joints and motors, equal to the QR's and to the
    small system's (no multipliers) from the same samples; the multipliers are the small system's answer."""
    mechanism = MECHANISM_PRESETS[name]()
    pieces = prepared(mechanism)
    closed_form = pieces.tree_reactions
    assert isinstance(closed_form, LoopReactions) and not pieces.full_rank_by_structure
    for method in ("newton_euler", "lagrange"):
        run = simulate_mechanism(mechanism, 0.5, 26, method=method, rotations="absolute")
        solved = engine.samples(engine.compiled_system(mechanism, method, rotations="absolute"),
                                pieces.parameters, run.t, *_tree_states(mechanism, run, "absolute"))
        assert solved.multipliers.shape == (run.t.size, closed_form.unknowns_to_rows.shape[0])
        small_system = engine.body_reactions(pieces.dae, solved, closed_form=closed_form)
        _assert_close(run.reaction_rows, engine.body_reactions(pieces.dae, solved))
        _assert_close(run.reaction_rows, small_system)
        _assert_close(solved.multipliers, small_system[:, _cut_and_motor_rows(mechanism)])


def _cut_and_motor_rows(mechanism: Mechanism) -> list[int]:
    """The rows of the cut joints (joint order) then of the speed motors (driver order): a tree formulation's
    multipliers."""
    pieces = prepared(mechanism)
    rows = pieces.constraints.rows
    cuts = {loop.cut_joint for loop in pieces.topology.loops}
    motors = [driver.joint for driver in mechanism.drivers if driver.speed is not None]
    found = [k for k, row in enumerate(rows) if row.joint in cuts and row.meaning != "driven angle"]
    return found + [next(k for k, row in enumerate(rows) if row.joint == joint and row.meaning == "driven angle")
                    for joint in motors]


@pytest.mark.parametrize("make", [lambda rng: random_tree(rng, slider=True),
                                  lambda rng: MECHANISM_PRESETS["geared-five-bar"](),
                                  lambda rng: MECHANISM_PRESETS["slider-crank"]()],
                         ids=["slider tree", "geared-five-bar", "slider-crank"])
def test_slider_and_gear_keep_the_qr(make):
    rng = np.random.default_rng(11)
    for _ in range(3):
        mechanism = make(rng)
        assert _closed_form(mechanism) is None
        dae, solved, multipliers = _states(rng, mechanism)
        _assert_close(engine.body_reactions(dae, solved), multipliers)


def test_a_run_of_pins_reads_no_jacobian_for_its_reactions(monkeypatch):
    """Observable: the reactions of a Newton-Euler run of a chain or a four-bar come without evaluating
    ``Phi_q`` (the QR's input), and equal the QR's answer from the same samples; a slider's still evaluate it."""
    evaluated = []
    original = Constraints.jacobian

    def counting(self, q):
        evaluated.append(np.shape(q))
        return original(self, q)

    monkeypatch.setattr(Constraints, "jacobian", counting)
    rng = np.random.default_rng(3)
    for mechanism, fast in ((random_chain(rng, 3, motors=True), True), (closed_loop(rng), True),
                            (MECHANISM_PRESETS["slider-crank"](), False)):
        run = simulate_mechanism(mechanism, 1.0, 21, method="newton_euler", integrator="RK45", rtol=1e-8,
                                 atol=1e-8)
        evaluated.clear()
        reactions = run.reaction_rows
        assert (evaluated == []) == fast
        assert reactions.shape == (run.t.size, len(run.row_names))
        dae = prepared(mechanism).dae
        accelerations = engine.samples(engine.compiled_system(mechanism, "newton_euler"),
                                       prepared(mechanism).parameters, run.t, *_tree_states(mechanism, run))
        _assert_close(reactions, engine.body_reactions(dae, accelerations))


def _tree_states(mechanism: Mechanism, run, rotations: str = "relative"):
    pairs = [tree_state(mechanism, q, qdot, rotations=rotations) for q, qdot in zip(run.q, run.qdot, strict=True)]
    return np.array([x for x, _ in pairs]), np.array([v for _, v in pairs])


def test_an_open_tree_of_pins_has_full_row_rank_at_random_poses():
    """What lets assembly skip the rank's SVD for an open tree of pins (Prepared.full_rank_by_structure): the
    numerical rank assembly would compute equals the number of rows at random poses and numbers; a slider tree
    and a loop are not claimed."""
    rng = np.random.default_rng(5)
    trees = [random_chain(rng, n, motors=True) for n in range(1, 6)] + [random_tree(rng) for _ in range(3)]
    for mechanism in trees:
        pieces = prepared(mechanism)
        assert pieces.full_rank_by_structure
        for _ in range(5):
            q = pieces.constraints.sketch_pose() + rng.normal(scale=2.0, size=pieces.constraints.size)
            jacobian = pieces.constraints.jacobian(q)
            assert _rank(jacobian) == jacobian.shape[0]
    assert not prepared(random_tree(rng, slider=True)).full_rank_by_structure
    assert not prepared(closed_loop(rng)).full_rank_by_structure
