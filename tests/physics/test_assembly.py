"""Closed-loop position and velocity analysis: closure, branches, ranges, Grashof classes, singular positions."""

import math

import numpy as np
import pytest

from physics.errors import LinkageError
from physics.loop_closure import (
    DEAD_CENTRE_EVENTS,
    assemble,
    count_dead_centres,
    dead_centre_metrics,
    driving_range,
    elbow_of,
    grashof,
    loop_condition,
    loop_jacobian,
    loop_residual,
    loop_singular_values,
    project_velocity,
    tip_position,
)

SEED_L = np.array([1.0, 1.0, 2.0])
SEED_THETA0 = np.array([math.pi - math.pi / 30, math.pi / 2, 0.0])
SEED_PIN = tip_position(SEED_L, SEED_THETA0)


def random_four_bar(rng):
    """Lengths and a pin at the tip of a random configuration, so the loop can close."""
    L = rng.uniform(0.5, 2.5, 3)
    return L, tip_position(L, rng.uniform(-math.pi, math.pi, 3))


def test_loop_jacobian_is_the_derivative_of_the_tip():
    rng = np.random.default_rng(1)
    for n in (2, 3, 5):
        L, theta = rng.uniform(0.3, 2.0, n), rng.uniform(-3, 3, n)
        h = 1e-6
        numeric = np.stack(
            [(tip_position(L, theta + h * e) - tip_position(L, theta - h * e)) / (2 * h) for e in np.eye(n)], axis=1
        )
        np.testing.assert_allclose(loop_jacobian(L, theta), numeric, atol=1e-9)


def test_seed_start_is_closed_and_assembles_back():
    """The seed's own start (elbow +1, the documented default) comes back from its driving angle."""
    assert np.allclose(loop_residual(SEED_L, SEED_THETA0, SEED_PIN), 0.0)
    theta = assemble(SEED_L, SEED_PIN, SEED_THETA0[:1])
    np.testing.assert_allclose(theta, SEED_THETA0, atol=1e-12)
    other = assemble(SEED_L, SEED_PIN, SEED_THETA0[:1], elbow=-1)
    assert np.max(np.abs(loop_residual(SEED_L, other, SEED_PIN))) < 1e-12
    assert abs(other[1] - SEED_THETA0[1]) > 0.5  # the mirror branch is a different configuration


@pytest.mark.parametrize("n", [2, 3, 4, 6])
def test_assembly_closes_the_loop_and_keeps_the_driving_angles(n):
    rng = np.random.default_rng(n)
    for _ in range(20):
        L = rng.uniform(0.5, 2.0, n)
        theta_true = rng.uniform(-math.pi, math.pi, n)
        pin = tip_position(L, theta_true)
        theta = assemble(L, pin, theta_true[: n - 2], theta_prev=theta_true)
        assert np.max(np.abs(loop_residual(L, theta, pin))) < 1e-12
        np.testing.assert_array_equal(theta[: n - 2], theta_true[: n - 2])
        # the branch nearest theta_prev is the one theta_true lies on
        np.testing.assert_allclose(theta, theta_true, atol=1e-9)


def test_unwrapping_follows_theta_prev():
    prev = SEED_THETA0 + np.array([0.0, 4 * math.pi, -2 * math.pi])
    theta = assemble(SEED_L, SEED_PIN, prev[:1], theta_prev=prev)
    np.testing.assert_allclose(theta, prev, atol=1e-12)


def sweep(L, pin, lo, hi, elbow, samples=4001):
    """Drive theta1 across [lo, hi], each step assembled from the previous configuration.

    The sweep starts mid-range on the requested branch and walks out to both ends: at an end the two
    branches coincide, so a sweep started there would not know which one it follows.
    """
    theta1 = np.linspace(lo, hi, samples)
    mid = samples // 2
    theta = {mid: assemble(L, pin, theta1[mid : mid + 1], elbow=elbow)}
    for k in list(range(mid + 1, samples)) + list(range(mid - 1, -1, -1)):
        previous = theta[k - 1] if k > mid else theta[k + 1]
        theta[k] = assemble(L, pin, theta1[k : k + 1], theta_prev=previous)
    return theta1, np.array([theta[k] for k in range(samples)])


def test_sweep_of_the_whole_range_gives_two_continuous_branches_that_meet_at_the_ends():
    (lo, hi), = driving_range(SEED_L, SEED_PIN)
    step = (hi - lo) / 4000
    branches = [sweep(SEED_L, SEED_PIN, lo, hi, elbow)[1] for elbow in (1, -1)]
    for elbow, theta in zip((1, -1), branches):
        assert np.max(np.abs(loop_residual(SEED_L, theta, SEED_PIN))) < 1e-12
        jumps = np.max(np.abs(np.diff(theta[:, 1:], axis=0)), axis=1)
        # away from the ends the dependent angles move like theta1; at the ends (a square-root turning point)
        # a step moves them by at most ~ sqrt(step): either way far less than the gap between branches
        assert np.max(jumps[50:-50]) < 20 * step
        assert np.max(jumps) < 3 * math.sqrt(step)
        # no branch swap in the interior: the elbow sign never changes
        inner = theta[5:-5]
        assert all(elbow_of(a, b) == elbow for a, b in zip(inner[:, 1], inner[:, 2]))
    gap_mid = np.max(np.abs(branches[0][2000, 1:] - branches[1][2000, 1:]))
    assert gap_mid > 0.5
    for end in (0, -1):  # the two branches meet at the dead centres bounding the range
        difference = branches[0][end, 1:] - branches[1][end, 1:]
        assert np.max(np.abs(np.angle(np.exp(1j * difference)))) < 1e-4  # equal up to whole turns
        assert abs(dead_centre_metrics(branches[0][end])[0]) < 1e-6  # bars 2 and 3 collinear there


@pytest.mark.parametrize("side", ["low", "high"])
def test_unreachable_driving_angle_raises_naming_theta1_and_the_gap(side):
    (lo, hi), = driving_range(SEED_L, SEED_PIN)
    theta1 = lo - 0.05 if side == "low" else hi + 0.05
    joint1 = np.array([math.sin(theta1), -math.cos(theta1)])
    distance = np.hypot(*(SEED_PIN - joint1))
    expected_gap = abs(SEED_L[1] - SEED_L[2]) - distance  # seed: the pin comes too close to joint 1
    assert expected_gap > 0
    with pytest.raises(LinkageError) as info:
        assemble(SEED_L, SEED_PIN, [theta1])
    text = str(info.value)
    assert f"theta1={theta1:.6g}" in text
    assert "cannot close" in text and f"gap {expected_gap:.3g}" in text


def test_unreachable_beyond_reach_names_the_outer_gap():
    L, pin = np.array([1.0, 1.0, 1.0]), np.array([2.5, 0.0])
    with pytest.raises(LinkageError, match=r"theta1=-1\.5708.*reach at most L2\+L3 = 2: gap 1\.5"):
        assemble(L, pin, [-math.pi / 2])  # joint 1 at (-1, 0): 3.5 from the pin


def test_driving_range_matches_brute_force_over_random_four_bars():
    rng = np.random.default_rng(7)
    grid = np.linspace(-math.pi, math.pi, 721)
    seen_interval_counts = set()
    cases = [random_four_bar(rng) for _ in range(40)]
    cases.append((np.array([1.5, 1.0, 2.0]), np.array([0.0, -2.0])))  # both limits bite: two intervals
    for L, pin in cases:
        ranges = driving_range(L, pin)
        seen_interval_counts.add(len(ranges))
        joint1 = np.stack([L[0] * np.sin(grid), -L[0] * np.cos(grid)], axis=1)
        D = np.hypot(*(pin - joint1).T)
        closes = (D <= L[1] + L[2]) & (D >= abs(L[1] - L[2]))
        inside = np.zeros_like(closes)
        for lo, hi in ranges:
            assert -math.pi <= lo < hi <= lo + 2 * math.pi + 1e-12
            inside |= ((grid - lo) % (2 * math.pi) <= hi - lo)
        np.testing.assert_array_equal(inside, closes)
        for lo, hi in ranges:  # the ends assemble exactly (dead centres), just beyond does not
            for end in (lo, hi):
                assert np.max(np.abs(loop_residual(L, assemble(L, pin, [end]), pin))) < 1e-9
            if hi - lo < 2 * math.pi - 1e-9:
                for outside in (lo - 1e-6, hi + 1e-6):
                    with pytest.raises(LinkageError):
                        assemble(L, pin, [outside])
    assert {1, 2} <= seen_interval_counts


def test_seed_grashof_class_and_ground_length():
    report = grashof(SEED_L, SEED_PIN)
    ground = float(np.hypot(*SEED_PIN))
    assert report.ground_length == pytest.approx(ground, rel=1e-15)
    assert ground == pytest.approx(1.4936429777768898, rel=1e-12)
    # s + l = 1 + 2 = 3 > p + q = 1 + 1.4936: no link of the seed four-bar turns fully
    assert report.linkage_class == "non-Grashof (triple-rocker)"
    assert report.margin == pytest.approx(1.0 + ground - 3.0)
    assert report.as_dict()["class"] == report.linkage_class


@pytest.mark.parametrize(
    "ground, L, expected, full_turn",
    [
        (3.0, (1.0, 3.5, 2.5), "Grashof (crank-rocker)", True),  # input shortest: the crank turns fully
        (3.0, (2.5, 3.5, 1.0), "Grashof (crank-rocker)", False),  # output shortest: bar 3 is the crank
        (1.0, (2.0, 3.0, 2.5), "Grashof (double-crank)", True),  # ground shortest
        (3.0, (2.5, 1.0, 3.5), "Grashof (double-rocker)", False),  # coupler shortest
        (2.0, (1.0, 2.0, 1.0), "change-point", True),  # s + l = p + q
        (2.0, (1.0, 1.2, 2.6), "non-Grashof (triple-rocker)", False),
    ],
)
def test_grashof_class_predicts_whether_bar_1_turns_fully(ground, L, expected, full_turn):
    pin = ground * np.array([math.sin(0.7), -math.cos(0.7)])  # any direction: only |pin| matters
    assert grashof(np.array(L), pin).linkage_class == expected
    ranges = driving_range(np.array(L), pin)
    turns = len(ranges) == 1 and ranges[0][1] - ranges[0][0] >= 2 * math.pi - 1e-9
    assert turns is full_turn


def test_grashof_and_range_reject_other_chains():
    with pytest.raises(LinkageError, match="four-bar"):
        grashof(np.ones(4), [1.0, 0.0])
    with pytest.raises(LinkageError, match="four-bar"):
        driving_range(np.ones(2), [1.0, 0.0])
    with pytest.raises(LinkageError, match="theta_driving"):
        assemble(SEED_L, SEED_PIN, [0.1, 0.2])


def test_project_velocity_from_driving_speed_and_minimum_norm():
    rng = np.random.default_rng(3)
    for _ in range(20):
        L, pin = random_four_bar(rng)
        (lo, hi), *_ = driving_range(L, pin)
        theta = assemble(L, pin, [lo + 0.3 * (hi - lo)])
        J = loop_jacobian(L, theta)
        omega = project_velocity(L, theta, [0.7])
        assert omega[0] == 0.7 and np.max(np.abs(J @ omega)) < 1e-12
        raw = rng.normal(size=3)
        projected = project_velocity(L, theta, raw)
        assert np.max(np.abs(J @ projected)) < 1e-12
        # minimum norm: the correction lies in the row space of J (orthogonal to the null space)
        assert abs(np.dot(raw - projected, projected)) < 1e-12
        np.testing.assert_allclose(project_velocity(L, theta, projected), projected, atol=1e-14)


def test_project_velocity_at_a_dead_centre_raises():
    (lo, _), = driving_range(SEED_L, SEED_PIN)
    theta = assemble(SEED_L, SEED_PIN, [lo])  # bars 2 and 3 collinear
    with pytest.raises(LinkageError, match="dead centre"):
        project_velocity(SEED_L, theta, [1.0])


def test_loop_condition_blows_up_only_when_every_bar_is_collinear():
    assert loop_condition(SEED_L, SEED_THETA0) < 10
    assert math.isinf(loop_condition(SEED_L, np.array([0.0, 0.0, 0.0])))  # hanging on one vertical line
    assert loop_condition(SEED_L, np.array([0.0, 0.0, math.pi])) > 1e15  # folded back (sin(pi) is 1e-16)
    near = loop_condition(SEED_L, np.array([0.0, 1e-7, math.pi]))
    assert 1e6 < near < math.inf
    # two bars collinear is a dead centre of one coordinate, not a singular loop
    assert loop_condition(SEED_L, np.array([1.0, 0.4, 0.4])) < 100
    batch = loop_condition(SEED_L, np.stack([SEED_THETA0, SEED_THETA0]))
    assert batch.shape == (2,)
    sv = loop_singular_values(SEED_L, SEED_THETA0)
    assert sv[0] >= sv[1] > 0


def test_dead_centre_metrics_and_counts():
    theta = np.array([0.3, 1.1, 1.1 + math.pi])  # bars 2 and 3 folded
    fold, straighten, parallel = dead_centre_metrics(theta)
    assert abs(fold) < 1e-15 and abs(straighten) > 0.1 and abs(parallel) > 0.1
    assert list(DEAD_CENTRE_EVENTS) == ["fold", "straighten", "parallel"]
    # theta3 sweeps past theta2 twice (sign changes of sin(theta3 - theta2)); the others never cross
    t = np.linspace(0, 1, 101)
    samples = np.stack([np.full_like(t, 0.3), np.full_like(t, 1.1), 1.1 - 0.5 + 4.0 * t], axis=1)
    counts = count_dead_centres(samples)
    assert counts["fold"] == 2  # at theta3 - theta2 = 0 and = pi
    assert counts["straighten"] == 0
