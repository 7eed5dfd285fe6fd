"""Free-body diagrams: the arrows on each bar satisfy its momentum balances, with the documented signs."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from physics import Settings, get_preset, load_compiled, simulate
from physics.fbd import free_bodies, free_body_at
from physics.loop_closure import project_velocity

BALANCE_TOLERANCE = 1e-10


def independent_com_accelerations(chain, theta, omega, alpha):
    """a_G by finite differences of the centres' positions along theta(t) = theta + omega t + alpha t^2 / 2
    (second central difference; exact to rounding for positions smooth in t, error O(h^2))."""
    L, d = chain.array("L"), chain.array("d")

    def centres(t):
        th = theta + omega * t + 0.5 * alpha * t**2
        e = np.stack([np.sin(th), -np.cos(th)], axis=1)
        joints = np.vstack([[0.0, 0.0], np.cumsum(L[:, None] * e, axis=0)])
        return joints[:-1] + d[:, None] * e

    h = 1e-4
    return (centres(h) - 2 * centres(0.0) + centres(-h)) / h**2


def states(name, count=4, seed=3):
    """The preset's start plus seeded random states (random angles and rates; a closed chain keeps its
    start angles and gets a velocity on the loop, so the pin reaction is exercised)."""
    preset = get_preset(name)
    rng = np.random.default_rng(seed)
    out = [(preset.theta0, preset.omega0)]
    for _ in range(count):
        if preset.chain.pinned:
            omega = project_velocity(preset.chain.array("L"), preset.theta0, rng.normal(size=3))
            out.append((preset.theta0, omega))
        else:
            out.append((rng.uniform(-math.pi, math.pi, 3), rng.normal(size=3)))
    return preset.chain, out


@pytest.mark.parametrize("name", ("triple-a", "four-bar"))
def test_each_bar_balances_force_and_moment(name):
    chain, cases = states(name)
    lagrange = load_compiled("lagrange", chain.n, chain.pinned)
    for theta, omega in cases:
        bodies = free_bodies(chain, theta, omega)
        assert [b.bar for b in bodies] == [1, 2, 3]
        # angular accelerations from another formulation: the DAE's reactions must balance them
        alpha, _ = lagrange.accel(np.asarray(theta, float), np.asarray(omega, float), chain.params())
        a_com = independent_com_accelerations(chain, np.asarray(theta, float), np.asarray(omega, float), alpha)
        for body in bodies:
            i = body.bar - 1
            scale = max(1.0, max(float(np.hypot(*f.force)) for f in body.forces))
            np.testing.assert_allclose(body.net_force(), body.mass * body.com_acceleration, rtol=0,
                                       atol=BALANCE_TOLERANCE * scale)
            moment_tolerance = BALANCE_TOLERANCE * scale
            assert body.net_moment_about_com() == pytest.approx(body.inertia * body.alpha, abs=moment_tolerance)
            assert body.alpha == pytest.approx(alpha[i], abs=1e-9)
            np.testing.assert_allclose(body.com_acceleration, a_com[i], atol=1e-6)  # finite differences: O(h^2)


def test_forces_follow_the_documented_signs():
    chain, _ = states("four-bar")
    bodies = free_bodies(chain, get_preset("four-bar").theta0, np.zeros(3))
    names = [[f.name.split(" ")[0] for f in b.forces] for b in bodies]
    assert names == [["gravity", "R0", "-R1"], ["gravity", "R1", "-R2"], ["gravity", "R2", "RH"]]
    # Newton's third law between neighbours: what bar 2 feels at J1 is minus what bar 1 feels there
    np.testing.assert_array_equal(bodies[0].forces[2].force, -bodies[1].forces[1].force)
    # open chain hanging at rest: the ground holds the total weight, the last bar carries no distal force
    hanging = free_bodies(get_preset("triple-a").chain, np.zeros(3), np.zeros(3))
    assert hanging[0].forces[1].force == pytest.approx([0.0, 3.0], abs=1e-12)
    assert len(hanging[2].forces) == 2


def test_joint_names_are_the_runs_point_names():
    """A diagram names its joints as a run names its points (one naming: O, J1 .., H), at the same places."""
    preset = get_preset("four-bar")
    run = simulate(preset.chain, preset.theta0, preset.omega0, Settings(t_end=0.1, samples=2))
    bodies = free_bodies(preset.chain, run.theta[0], run.omega[0])
    assert [b.end_names for b in bodies] == [("O", "J1"), ("J1", "J2"), ("J2", "H")]
    for body in bodies:
        for name, xy in zip(body.end_names, body.ends_xy, strict=True):
            assert name in run.point_names
            np.testing.assert_allclose(xy, run.point(name)[0], atol=1e-12)
        assert [f.point for f in body.forces[1:]] == list(body.end_names)[:len(body.forces) - 1]


def test_free_body_at_a_time_follows_the_run():
    preset = get_preset("triple-a")
    body = free_body_at(preset.chain, preset.theta0, preset.omega0, 2.5, 2)
    assert body.time == 2.5 and body.bar == 2
    assert body.theta != preset.theta0[1]  # it moved


def run_cli(*argv):
    return subprocess.run([sys.executable, "-m", "physics", *argv], capture_output=True, text=True, timeout=300)


def test_cli_writes_an_svg_and_prints_json(tmp_path):
    out = tmp_path / "fbd.svg"
    result = run_cli("fbd", "--preset", "triple-a", "--time", "2.5", "--bar", "2", "--out", str(out), "--json")
    assert result.returncode == 0, result.stderr
    document = json.loads(result.stdout)
    assert document["bar"] == 2 and document["time"] == 2.5 and len(document["forces"]) == 3
    balance = document["balance"]
    np.testing.assert_allclose(balance["net_force"], balance["mass_times_acceleration"], atol=1e-10)
    text = out.read_text()
    assert text.startswith("<svg") and text.count("marker-end") == 3 and "R1" in text


@pytest.mark.parametrize("args, fragment", [
    (("--bar", "4"), "--bar = 4: allowed range 1 <= bar <= 3"),
    (("--bar", "0"), "--bar = 0: allowed range 1 <= bar <= 3"),
    (("--time", "nan"), "--time = nan: allowed range 0 <= time"),
    (("--time", "-1"), "--time = -1.0: allowed range 0 <= time"),
    (("--time", "1e9"), "allowed range 0 <= time"),
])
def test_bad_input_is_one_line_naming_the_option(args, fragment):
    result = run_cli("fbd", "--preset", "triple-a", *args)
    assert result.returncode == 2
    assert len(result.stderr.strip().splitlines()) == 1 and fragment in result.stderr
