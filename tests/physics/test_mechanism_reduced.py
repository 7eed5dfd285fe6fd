"""The reduced model of a one-degree-of-freedom mechanism (physics/mechanism/reduced.py), checked against
physics it does not share: the maximal-coordinate DAE run, the chain's Lagrange formulation, energy, the
slider-crank's generalised mass in closed form, and finite differences of the joint coordinates."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from physics.chain_presets import get_preset
from physics.errors import LinkageError
from physics.mechanism import MECHANISM_PRESETS, Body, Driver, Mechanism, Prismatic, Revolute, assemble
from physics.mechanism.assembly import sketch_size
from physics.mechanism.chains import chain_mechanism
from physics.mechanism.joint_coordinates import JointCoordinates
from physics.mechanism.numeric_dae import MechanismDAE
from physics.mechanism.presets import bar, circle_intersection, pin
from physics.mechanism.reduced import SWITCH_SHARE, simulate_reduced
from physics.mechanism.reduced_partition import Partition
from physics.mechanism.simulate import simulate_mechanism
from physics.model import Bar, Chain

MOBILITY_ONE = ["slider-crank", "watt-six-bar", "stephenson-six-bar"]
EPS = np.finfo(float).eps


def quick_return() -> Mechanism:
    """A crank whose pin carries a block sliding along a swinging rocker (the quick-return mechanism): the guide
    turns and the block's centre of mass is off its sliding point, so every term of a travel's curvature
    counts (the presets' piston slides on the ground through its centre of mass, where they all vanish)."""
    o, q = (0.0, 0.0), (0.0, -0.25)
    a = (0.1 * math.cos(math.radians(60.0)), 0.1 * math.sin(math.radians(60.0)))
    along = np.subtract(a, q) / math.dist(a, q)
    end = (q[0] + 0.45 * along[0], q[1] + 0.45 * along[1])
    return Mechanism(
        name="quick-return", ground={"O": o, "Q": q},
        bodies=[bar("crank", ("O", o), ("A", a)), bar("rocker", ("Q", q), ("E", end)),
                Body(name="block", points={"A": a}, mass=0.2, com=(a[0] + 0.01, a[1] + 0.02), inertia=2e-4)],
        joints=[pin("O", "ground.O", "crank.O"), pin("A", "crank.A", "block.A"), pin("Q", "ground.Q", "rocker.Q"),
                Prismatic(name="slide", body="block", point="A", on="rocker", through="Q",
                          direction=(float(along[0]), float(along[1])))],
        trace="block.A",
    )


def driven_five_bar() -> Mechanism:
    """Two cranks joined by two links (two degrees of freedom), one crank turned by a motor: mobility 1 with a
    constraint that depends on time."""
    o1, o2 = (0.0, 0.0), (0.3, 0.0)
    a, b = (0.0, 0.1), (0.35, 0.12)
    c = circle_intersection(a, 0.25, b, 0.2, side=+1)
    return Mechanism(
        name="driven-five-bar", ground={"O1": o1, "O2": o2},
        bodies=[bar("crank", ("O1", o1), ("A", a)), bar("left", ("A", a), ("C", c)), bar("right", ("C", c), ("B", b)),
                bar("rocker", ("O2", o2), ("B", b))],
        joints=[pin("O1", "ground.O1", "crank.O1"), pin("A", "crank.A", "left.A"), pin("C", "left.C", "right.C"),
                pin("B", "right.B", "rocker.B"), pin("O2", "ground.O2", "rocker.O2")],
        drivers=[Driver(joint="O1", speed=3.0)],
        trace="left.C",
    )


def motored_damped_slider_crank() -> Mechanism:
    """The slider-crank with a torque motor on its crank and viscous damping in the rod's pins: applied forces
    that depend on the velocities."""
    preset = MECHANISM_PRESETS["slider-crank"]()
    joints = [joint.model_copy(update={"damping": 0.002}) if joint.name in ("A", "B") else joint
              for joint in preset.joints]
    return Mechanism.model_validate({**preset.model_dump(), "joints": [j.model_dump() for j in joints],
                                     "drivers": [{"joint": "O", "torque": 0.05}]})


def consistent_velocity(mechanism: Mechanism, q: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A random velocity that satisfies the constraints: along the null vector of their Jacobian."""
    jacobian = MechanismDAE(mechanism).constraints.jacobian(q)
    return rng.uniform(1.0, 3.0) * np.linalg.svd(jacobian)[2][-1]


def joint_speeds(mechanism: Mechanism, q: np.ndarray, qdot: np.ndarray) -> dict[str, float]:
    """Every joint's rate as a speed (a pin's relative angular rate times the sketch size, a slider's travel
    rate), written here from the poses: the test's own reading of the joints."""
    names = [body.name for body in mechanism.bodies]
    size = sketch_size(mechanism)

    def spin(body: str) -> float:
        return 0.0 if body == "ground" else float(qdot[3 * names.index(body) + 2])

    speeds = {}
    for joint in mechanism.joints:
        if isinstance(joint, Revolute):
            speeds[joint.name] = size * abs(spin(joint.b.split(".")[0]) - spin(joint.a.split(".")[0]))
        else:  # the presets' sliders run on the ground along a fixed direction, through their centre of mass
            k = names.index(joint.body)
            u = np.array(joint.direction) / np.hypot(*joint.direction)
            speeds[joint.name] = abs(float(u @ qdot[3 * k : 3 * k + 2]))
    return speeds


@pytest.mark.parametrize("make", [*(MECHANISM_PRESETS[name] for name in MOBILITY_ONE), quick_return])
def test_joint_coordinate_gradients_and_curvatures_match_finite_differences(make):
    mechanism = make()
    dae = MechanismDAE(mechanism)
    coordinates = JointCoordinates(mechanism, dae.constraints)
    rng = np.random.default_rng(7)
    q = assemble(mechanism).q + rng.normal(0.0, 0.05, dae.constraints.size)  # any pose: these are identities
    qdot = rng.normal(0.0, 1.0, dae.constraints.size)
    h = 1e-5
    for which in range(len(coordinates.names)):
        numeric = np.array([(coordinates.value(q + h * e, which) - coordinates.value(q - h * e, which)) / (2 * h)
                            for e in np.eye(q.size)])
        assert np.max(np.abs(coordinates.gradient(q, which) - numeric)) <= 1e-8
        # d^2 c / dt^2 along q + qdot t with qddot = 0 is qdot^T H qdot, and gamma_c is minus that
        second = (coordinates.value(q + h * qdot, which) - 2 * coordinates.value(q, which)
                  + coordinates.value(q - h * qdot, which)) / h**2
        assert coordinates.curvature(q, qdot, which) == pytest.approx(-second, abs=1e-4 * (1 + abs(second)))


@pytest.mark.slow  # numeric right-hand sides on both sides: a few seconds per preset
@pytest.mark.parametrize("name", MOBILITY_ONE)
def test_reduced_run_agrees_with_the_dae_run(name):
    mechanism = MECHANISM_PRESETS[name]()
    q0 = assemble(mechanism).q
    qdot0 = consistent_velocity(mechanism, q0, np.random.default_rng(11))
    options = dict(q0=q0, qdot0=qdot0, rtol=1e-12, atol=1e-12)
    reduced = simulate_reduced(mechanism, 3.0, 61, **options)
    dae = simulate_mechanism(mechanism, 3.0, 61, **options)
    run = reduced.run
    assert np.array_equal(run.t, dae.t)
    assert run.row_names == dae.row_names
    assert np.max(np.abs(run.q - dae.q)) <= 1e-7
    assert np.max(np.abs(run.qdot - dae.qdot)) <= 1e-7 * (1 + np.max(np.abs(dae.qdot)))
    force_scale = np.max(np.abs(dae.reaction_rows))
    assert np.max(np.abs(run.reaction_rows - dae.reaction_rows)) <= 1e-7 * force_scale
    assert np.nanmax(np.abs(run.trace_xy - dae.trace_xy)) <= 1e-7
    assert np.ptp(dae.q[:, 2]) > 0.5  # the crank really moved: agreement over a motion, not a pose


@pytest.mark.slow
@pytest.mark.parametrize(("make", "coordinate", "t_end"),
                         [(quick_return, "slide", 0.3), (quick_return, None, 2.0), (driven_five_bar, None, 2.0),
                          (motored_damped_slider_crank, None, 2.0)])
def test_a_moving_guide_and_a_motor_agree_with_the_dae_run(make, coordinate, t_end):
    """A slider on a turning guide (in its travel until just before that travel's first dead centre, at 0.34 s,
    so the travel's curvature is at work; and in the best joints), a motor on a two-degree-of-freedom
    five-bar (velocities ``B sdot + D`` with ``D`` from the motor), and a torque motor with damped pins."""
    mechanism = make()
    options = dict(rtol=1e-12, atol=1e-12)
    reduced = simulate_reduced(mechanism, t_end, 41, coordinate=coordinate, switching=coordinate is None, **options)
    dae = simulate_mechanism(mechanism, t_end, 41, **options)
    if coordinate is not None:
        assert set(reduced.coordinate) == {coordinate}
    assert np.max(np.abs(reduced.run.q - dae.q)) <= 1e-7
    assert np.max(np.abs(reduced.run.qdot - dae.qdot)) <= 1e-6 * (1 + np.max(np.abs(dae.qdot)))
    assert np.max(np.abs(reduced.run.reaction_rows - dae.reaction_rows)) <= 1e-5 * np.max(np.abs(dae.reaction_rows))
    assert np.max(reduced.run.residual) <= 20 * EPS * sketch_size(mechanism) * (1 + np.max(np.abs(dae.q)))
    assert np.ptp(dae.q[:, 2]) > 0.05  # the crank turned


@pytest.mark.slow
def test_a_run_from_t_start_continues_a_driven_run():
    """The motor's constraint depends on time: started at t_start = 0.5 s from the DAE run's state there, the
    reduced run follows the rest of the DAE run."""
    mechanism = driven_five_bar()
    options = dict(rtol=1e-12, atol=1e-12)
    dae = simulate_mechanism(mechanism, 1.5, 31, **options)
    later = simulate_reduced(mechanism, 1.0, 21, q0=dae.q[10], qdot0=dae.qdot[10], t_start=0.5, **options).run
    assert later.t == pytest.approx(dae.t[10:], abs=1e-15)
    assert np.max(np.abs(later.q - dae.q[10:])) <= 1e-7
    assert np.max(np.abs(later.qdot - dae.qdot[10:])) <= 1e-6 * (1 + np.max(np.abs(dae.qdot)))


@pytest.mark.slow  # 10 s of each preset
@pytest.mark.parametrize("name", MOBILITY_ONE)
def test_energy_is_conserved_over_ten_seconds(name):
    mechanism = MECHANISM_PRESETS[name]()
    reduced = simulate_reduced(mechanism, 10.0, 201, rtol=1e-12, atol=1e-12)
    run = reduced.run
    scale = max(abs(run.energy[0]), np.max(np.abs(run.potential - run.potential[0])))
    drift = np.max(np.abs(run.energy - run.energy[0])) / scale
    assert drift < 1e-8, drift
    assert np.ptp(run.potential) > 0.1 * scale  # it swung: the energy test is not of a mechanism at rest


@pytest.mark.parametrize("name", MOBILITY_ONE)
def test_constraints_hold_to_rounding_because_positions_come_from_position_analysis(name):
    mechanism = MECHANISM_PRESETS[name]()
    reduced = simulate_reduced(mechanism, 0.5, 11)
    run = reduced.run
    assert np.max(run.residual) <= 20 * EPS * sketch_size(mechanism)
    constraints = MechanismDAE(mechanism).constraints
    velocity_gap = max(np.max(np.abs(constraints.jacobian(q) @ qdot)) for q, qdot in zip(run.q, run.qdot))
    assert velocity_gap <= 1e-12 * (1 + np.max(np.abs(run.qdot)))
    assert np.ptp(run.q[:, 2]) > 0.1  # it moved


def slider_crank_generalised_mass(theta: float, crank: float = 0.05, rod: float = 0.2) -> float:
    """``m*(theta)`` of the preset slider-crank in its crank angle, derived by hand: crank about its pin
    ``m_c r^2 / 3``, the rod's centre-of-mass speed and spin, the piston's speed (uniform bars of 1 kg/m,
    piston 0.3 kg)."""
    m_crank, m_rod, m_piston = crank, rod, 0.3
    root = math.sqrt(rod**2 - (crank * math.sin(theta)) ** 2)
    x_rate = -crank * math.sin(theta) - crank**2 * math.sin(theta) * math.cos(theta) / root  # dx_B / dtheta
    a_rate = np.array([-crank * math.sin(theta), crank * math.cos(theta)])  # d(pin A) / dtheta
    centre_rate = 0.5 * (a_rate + np.array([x_rate, 0.0]))
    rod_angle_rate = -crank * math.cos(theta) / root  # beta = atan2(-r sin(theta), root)
    return (m_crank * crank**2 / 3 + m_rod * float(centre_rate @ centre_rate)
            + m_rod * rod**2 / 12 * rod_angle_rate**2 + m_piston * x_rate**2)


@pytest.mark.parametrize("joint", ["O", "guide"])
def test_slider_crank_generalised_mass_matches_its_closed_form(joint):
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    dae = MechanismDAE(mechanism)
    coordinates = JointCoordinates(mechanism, dae.constraints)
    q = assemble(mechanism).q
    partition = Partition(dae, coordinates, coordinates.index(joint), q, 0.0, sketch_size(mechanism))
    crank = [body.name for body in mechanism.bodies].index("crank")
    checked = 0
    for theta in np.radians(np.arange(60.0, 420.0, 2.0)):  # a full turn, one small step after the other
        crank_only = Partition(dae, coordinates, coordinates.index("O"), q, 0.0, sketch_size(mechanism))
        along = crank_only.state(0.0, theta - math.radians(60.0), 1.0)  # qdot = dq/dtheta
        q = along.q
        assert q[3 * crank + 2] == pytest.approx(theta - math.radians(60.0), abs=1e-12)
        expected = slider_crank_generalised_mass(theta)
        if joint == "guide":
            if abs(math.sin(theta)) < 0.3:
                continue  # the piston's travel is no coordinate near its dead centres (tested below)
            x_rate = float(coordinates.gradient(q, coordinates.index("guide")) @ along.qdot)
            expected /= x_rate**2  # m* in the travel x: m*_theta / (dx/dtheta)^2
        partition.reset(q, 0.0)
        state = partition.state(0.0, coordinates.value(q, partition.which), 0.0)
        assert np.max(np.abs(state.q - q)) <= 1e-14
        assert state.generalised_mass == pytest.approx(expected, rel=1e-12)
        checked += 1
    assert checked > 100


@pytest.mark.slow
def test_switching_carries_the_slider_crank_through_the_piston_dead_centre():
    """Started in the piston's travel, which stands still at each dead centre: the run switches before the
    first one, at the share the test reads off the DAE run itself, and the motion stays the DAE's."""
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    options = dict(rtol=1e-12, atol=1e-12)
    reduced = simulate_reduced(mechanism, 3.0, 601, coordinate="guide", **options)
    dae = simulate_mechanism(mechanism, 3.0, 601, **options)
    assert reduced.switches, "no coordinate switch"
    first = reduced.switches[0]
    assert first.from_joint == "guide" and first.to_joint != "guide"
    assert first.share == pytest.approx(SWITCH_SHARE, rel=1e-6)
    # the piston's dead centre: its velocity changes sign (after the start from rest)
    piston = [body.name for body in mechanism.bodies].index("piston")
    velocity = dae.qdot[:, 3 * piston]
    reversal = dae.t[1:][(np.sign(velocity[1:]) != np.sign(velocity[:-1])) & (dae.t[1:] > 0.05)][0]
    assert first.t < reversal < 3.0
    # the share of the travel in the DAE run, read with the test's own joint speeds, crosses SWITCH_SHARE there
    shares = []
    for q, qdot in zip(dae.q[1:], dae.qdot[1:]):  # after the start from rest, where every speed is zero
        speeds = joint_speeds(mechanism, q, qdot)
        shares.append(speeds["guide"] / max(speeds.values()))
    shares_array = np.array(shares)
    crossing = dae.t[2:][(shares_array[:-1] >= SWITCH_SHARE) & (shares_array[1:] < SWITCH_SHARE)][0]
    assert abs(first.t - crossing) <= dae.t[1] - dae.t[0]
    assert reduced.coordinate[0] == "guide" and reduced.coordinate[-1] != "guide"
    assert np.max(np.abs(reduced.run.q - dae.q)) <= 1e-7
    assert np.max(np.abs(reduced.run.qdot - dae.qdot)) <= 1e-6
    assert np.max(reduced.run.residual) <= 20 * EPS * sketch_size(mechanism)


def test_a_fixed_coordinate_is_refused_at_its_dead_centre():
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    with pytest.raises(LinkageError, match=r"joint 'guide' stopped being a valid coordinate at t = 0\.2") as caught:
        simulate_reduced(mechanism, 3.0, 31, coordinate="guide", switching=False)
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize(("name", "coordinate"), [*((name, None) for name in MOBILITY_ONE), ("slider-crank", "guide")])
def test_the_coordinate_in_use_always_keeps_its_share(name, coordinate):
    """At every sample the joint integrated moves at least SWITCH_SHARE times as fast as the fastest joint,
    read with the test's own joint speeds (started in the piston's travel: before and after its switch)."""
    mechanism = MECHANISM_PRESETS[name]()
    reduced = simulate_reduced(mechanism, 2.0, 201, rtol=1e-8, atol=1e-8, coordinate=coordinate)
    if coordinate is not None:
        assert reduced.switches and reduced.coordinate[1] == coordinate
    for q, qdot, joint in zip(reduced.run.q[1:], reduced.run.qdot[1:], reduced.coordinate[1:]):
        speeds = joint_speeds(mechanism, q, qdot)
        assert speeds[joint] >= (1 - 1e-6) * SWITCH_SHARE * max(speeds.values())


@pytest.mark.slow
def test_the_seed_four_bar_as_a_mechanism_follows_the_chains_lagrange_run_through_its_dead_centres():
    """The seed four-bar's crank angle theta1 (joint O) reaches dead centres (docs/closed-loops.md); the general
    reduced model, in the joint it finds best, agrees with the chain's own Lagrange formulation (generated from
    the chain's equations, not from the mechanism's) through them."""
    from physics import Settings, simulate  # noqa: PLC0415
    from physics.loop_closure import count_dead_centres  # noqa: PLC0415

    preset = get_preset("four-bar")
    chain, theta0 = preset.chain, preset.theta0
    mechanism = chain_mechanism(chain, theta0)
    reduced = simulate_reduced(mechanism, 8.0, 81, rtol=1e-12, atol=1e-12)
    lagrange = simulate(chain, theta0, np.zeros(3), Settings(method="lagrange", t_end=8.0, samples=81, rtol=1e-12,
                                                             atol=1e-12))
    assert lagrange.success and count_dead_centres(lagrange.theta)["fold"] >= 1  # theta1's own dead centre
    theta = reduced.run.q[:, 2::3] + theta0
    assert np.max(np.abs(theta - lagrange.theta)) <= 1e-7
    crank_shares = []
    for q, qdot in zip(reduced.run.q[1:], reduced.run.qdot[1:]):
        speeds = joint_speeds(mechanism, q, qdot)
        crank_shares.append(speeds["O"] / max(speeds.values()))
    assert min(crank_shares) < SWITCH_SHARE  # theta1 alone could not have carried this run


def open_two_bar_chain() -> Mechanism:
    return chain_mechanism(Chain(bars=[Bar(), Bar()], g=9.81), [0.3, 0.6])


@pytest.mark.parametrize(
    ("make", "kwargs", "fragment"),
    [
        (MECHANISM_PRESETS["crank-rocker"], {},
         r"mobility 1 \(Grübler count 1\); driven by 1 motor; 0 free: its motors fix every body"),
        (MECHANISM_PRESETS["jansen-leg"], {}, "0 free"),
        (open_two_bar_chain, {}, r"mobility 2 \(Grübler count 2\); no motor; 2 free: the reduced model integrates one"),
        (MECHANISM_PRESETS["slider-crank"], {"t_end": math.nan}, "t_end = nan: allowed range 0 < t_end <= 1e4"),
        (MECHANISM_PRESETS["slider-crank"], {"t_end": -1.0}, "t_end = -1.0: .*allowed"),
        (MECHANISM_PRESETS["slider-crank"], {"samples": 1}, "samples = 1: allowed range 2 <= samples"),
        (MECHANISM_PRESETS["slider-crank"], {"t_start": math.inf}, "t_start = inf"),
        (MECHANISM_PRESETS["slider-crank"], {"rtol": 1e-16}, "rtol = 1e-16: .*allowed"),
        (MECHANISM_PRESETS["slider-crank"], {"q0": np.full(9, math.nan)}, "q0: expected 9 finite numbers"),
        (MECHANISM_PRESETS["slider-crank"], {"qdot0": np.zeros(4)}, r"qdot0: expected 9 finite numbers .*shape \(4,\)"),
        (MECHANISM_PRESETS["slider-crank"], {"qdot0": [0.0] * 8 + [math.inf]}, "qdot0: .*non-finite"),
        (MECHANISM_PRESETS["slider-crank"], {"q0": "pose"}, "q0: expected 9 finite numbers .*got a str"),
        (MECHANISM_PRESETS["slider-crank"], {"coordinate": "crank"}, "coordinate = 'crank': no joint"),
    ],
)
def test_bad_input_is_one_line(make, kwargs, fragment):
    arguments = {"t_end": 1.0, "samples": 11, **kwargs}
    with pytest.raises(LinkageError, match=fragment) as caught:
        simulate_reduced(make(), arguments.pop("t_end"), arguments.pop("samples"), **arguments)
    assert "\n" not in str(caught.value)


def test_simulate_mechanism_runs_the_reduced_model_by_name():
    """``method="reduced"`` is the reduced model's run, not a formulation's: it equals simulate_reduced's and
    says which model made it."""
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    by_name = simulate_mechanism(mechanism, 0.5, 26, method="reduced")
    direct = simulate_reduced(mechanism, 0.5, 26).run
    assert by_name.method == "reduced" and by_name.stabilization == "position analysis"
    assert np.array_equal(by_name.q, direct.q) and np.array_equal(by_name.reaction_rows, direct.reaction_rows)
    dae = simulate_mechanism(mechanism, 0.5, 26, method="dae")
    assert np.max(np.abs(by_name.q - dae.q)) < 1e-7


@pytest.mark.parametrize(("preset", "options", "fragment"), [
    ("crank-rocker", {}, "motors"),
    ("slider-crank", {"stabilization": "baumgarte"}, "does not apply to method 'reduced'"),
    ("slider-crank", {"integrate": False}, "does not apply to method 'reduced'"),
])
def test_the_reduced_model_refuses_what_does_not_apply_in_one_line(preset, options, fragment):
    with pytest.raises(LinkageError) as error:
        simulate_mechanism(MECHANISM_PRESETS[preset](), 0.5, 11, method="reduced", **options)
    assert fragment in str(error.value) and "\n" not in str(error.value)


def test_a_reduced_run_counts_the_steps_and_right_hand_sides_of_every_segment(monkeypatch):
    """The run's ``n_steps`` and ``n_rhs`` are what scipy reports for each segment it integrated, summed over
    the segments (read here off every solution scipy returned); started in the piston's travel, the run switches
    coordinates, so more than one segment counts."""
    import scipy.integrate  # noqa: PLC0415

    solutions = []
    solve_ivp = scipy.integrate.solve_ivp

    def recorded(*args, **kwargs):
        solution = solve_ivp(*args, **kwargs)
        solutions.append(solution)
        return solution

    monkeypatch.setattr(scipy.integrate, "solve_ivp", recorded)
    reduced = simulate_reduced(MECHANISM_PRESETS["slider-crank"](), 1.0, 101, rtol=1e-8, atol=1e-8,
                               coordinate="guide")
    assert reduced.switches and len(solutions) > 1
    assert reduced.run.n_steps == sum(solution.t.size - 1 for solution in solutions) > 0
    assert reduced.run.n_rhs == sum(solution.nfev for solution in solutions)
    assert reduced.run.n_rhs >= 12 * reduced.run.n_steps  # DOP853: twelve stages a step at the least


def test_both_commands_take_method_reduced():
    """The free slider-crank (no motor) integrated by the reduced model reports its steps and evaluations."""
    done = subprocess.run([sys.executable, "-m", "physics", "mechanism", "--preset", "slider-crank", "--t-end",
                           "0.5", "--samples", "11", "--method", "reduced", "--json"],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    run = json.loads(done.stdout)["run"]
    assert run["method"] == "reduced"
    direct = simulate_mechanism(MECHANISM_PRESETS["slider-crank"](), 0.5, 11, method="reduced")
    assert (run["steps"], run["evaluations"]) == (direct.n_steps, direct.n_rhs)
    assert run["steps"] > 0 and run["evaluations"] >= 12 * run["steps"]
    refused = subprocess.run([sys.executable, "-m", "physics", "mechanism", "--preset", "jansen-leg", "--t-end",
                              "0.5", "--method", "reduced"], capture_output=True, text=True, timeout=300)
    assert refused.returncode == 2 and len(refused.stderr.strip().splitlines()) == 1, refused.stderr


def test_a_chains_joint_damping_is_the_damping_of_its_mechanisms_pins():
    """``chain_mechanism(..., damping=c)`` damps pins O, J1, J2 by ``c`` (relative joint rates, the tip's pin
    undamped), the chain's Rayleigh function: the seed four-bar's reduced run as a mechanism follows the chain's
    own damped Lagrange run (generated from the chain's equations, docs/physics.md), which loses a third of its
    energy in 10 s."""
    from physics import Settings, simulate  # noqa: PLC0415

    preset = get_preset("four-bar")
    chain, theta0 = preset.chain, preset.theta0
    damping = 0.3
    mechanism = chain_mechanism(chain, theta0, damping=damping)
    assert [joint.damping for joint in mechanism.joints] == [damping, damping, damping, 0.0]
    reduced = simulate_reduced(mechanism, 10.0, 101, rtol=1e-11, atol=1e-11).run
    lagrange = simulate(chain, theta0, np.zeros(3), Settings(method="lagrange", t_end=10.0, samples=101, rtol=1e-11,
                                                             atol=1e-11, damping=damping))
    assert lagrange.success
    assert np.max(np.abs(reduced.q[:, 2::3] + theta0 - lagrange.theta)) <= 1e-8
    assert np.max(np.abs(reduced.qdot[:, 2::3] - lagrange.omega)) <= 1e-8
    assert lagrange.energy[0] - lagrange.energy[-1] > 0.3 * abs(lagrange.energy[0])  # the damping is at work
    undamped = simulate_reduced(chain_mechanism(chain, theta0), 10.0, 101, rtol=1e-11, atol=1e-11).run
    assert np.max(np.abs(undamped.q[:, 2::3] + theta0 - lagrange.theta)) > 1e-2  # and it is what the test sees


def test_a_pose_where_the_constraints_are_dependent_is_no_start_for_any_coordinate():
    """The change-point four-bar 1e-6 rad short of its singular pose (every link in line): the constraint Jacobian's
    condition is 3.5e6, above NEAR_SINGULAR_CONDITION, so the run stops at its start, SINGULAR, naming the pose;
    0.05 rad short (condition 70) it runs."""
    from physics.mechanism.reduced import ReducedStop  # noqa: PLC0415
    from physics.status import Status  # noqa: PLC0415
    from physics.studies.mechanism_stability import change_point_mechanism  # noqa: PLC0415

    near, _ = change_point_mechanism(1e-6)
    with pytest.raises(ReducedStop, match="singular pose at t = 0 s") as caught:
        simulate_reduced(near, 1.0, 11)
    assert caught.value.status == Status.SINGULAR and "\n" not in str(caught.value)
    far, _ = change_point_mechanism(0.05)
    assert simulate_reduced(far, 1.0, 11).run.status == Status.OK


def test_a_kept_coordinate_stopped_as_a_status_says_where_its_dead_centre_was():
    """With ``stop_as_status`` the run keeps its samples and reports the dead centre (joint, time, share), so a
    caller can word it (the chains' theta1)."""
    reduced = simulate_reduced(MECHANISM_PRESETS["slider-crank"](), 3.0, 31, coordinate="guide", switching=False,
                               stop_as_status=True)
    dead = reduced.dead_centre
    assert reduced.run.status < 0 and dead is not None and dead.joint == "guide"
    assert f"at t = {dead.t:.6g} s" in reduced.run.message and 0.2 < dead.t < 0.3
    assert dead.share < 2e-3 and reduced.run.t[-1] <= dead.t
    assert simulate_reduced(MECHANISM_PRESETS["slider-crank"](), 0.1, 11).dead_centre is None
