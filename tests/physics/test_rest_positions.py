"""Rest positions for users: every one found is stationary, the stable ones are exactly the minima an
independent constrained minimisation reaches, and the command lists them."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest
from scipy.optimize import NonlinearConstraint, minimize

from physics import get_preset
from physics.rest_positions import rest_positions


def potential(chain, theta):
    """V = sum m_i g y_Gi, written out here from the joint positions (independent of the package)."""
    L, d, m = (chain.array(f) for f in "Ldm")
    y_joint = np.concatenate([[0.0], -np.cumsum(L * np.cos(theta))])
    y_com = y_joint[:-1] - d * np.cos(theta)
    return float(chain.g * np.sum(m * y_com))


def tip(chain, theta):
    L = chain.array("L")
    return np.array([np.sum(L * np.sin(theta)), -np.sum(L * np.cos(theta))])


def independent_minima(chain, starts=24, seed=11):
    """trust-constr from seeded random starts, the loop closure as a nonlinear equality constraint."""
    rng = np.random.default_rng(seed)
    pin = np.asarray(chain.pin)
    closure = NonlinearConstraint(lambda th: tip(chain, th) - pin, 0.0, 0.0)
    minima = []
    for _ in range(starts):
        result = minimize(lambda th: potential(chain, th), rng.uniform(-math.pi, math.pi, chain.n),
                          method="trust-constr", constraints=[closure],
                          options={"xtol": 1e-12, "gtol": 1e-10, "maxiter": 3000})
        if result.success and np.linalg.norm(tip(chain, result.x) - pin) < 1e-8:
            minima.append(result.x)
    return minima


def wrapped_distance(a, b):
    return float(np.max(np.abs(np.angle(np.exp(1j * (np.asarray(a) - np.asarray(b)))))))


@pytest.fixture(scope="module")
def four_bar():
    chain = get_preset("four-bar").chain
    return chain, rest_positions(chain)


@pytest.mark.slow  # an independent minimisation from many starts
@pytest.mark.filterwarnings("ignore:delta_grad == 0.0")
def test_four_bar_minima_match_an_independent_minimisation(four_bar):
    chain, positions = four_bar
    stable = [p for p in positions if p.stable]
    minima = independent_minima(chain)
    assert len(minima) >= 12  # most starts converge
    for x in minima:
        nearest = min(stable, key=lambda p: wrapped_distance(p.theta, x))
        assert wrapped_distance(nearest.theta, x) < 1e-5
        assert nearest.potential == pytest.approx(potential(chain, x), abs=1e-9)
    # every stable rest position is reached from some start
    for p in stable:
        assert any(wrapped_distance(p.theta, x) < 1e-5 for x in minima)
    assert len(stable) == 2


def test_four_bar_rest_positions_are_stationary_and_classified(four_bar):
    """On the loop, V is stationary at each listed position; moving along the loop raises V at the stable
    ones and lowers it at the unstable ones (a finite-difference check of the classification)."""
    chain, positions = four_bar
    L = chain.array("L")
    assert len(positions) == 4 and sum(not p.stable for p in positions) == 2
    for p in positions:
        assert np.linalg.norm(tip(chain, p.theta) - np.asarray(chain.pin)) < 1e-10
        J = np.array([L * np.cos(p.theta), L * np.sin(p.theta)])
        tangent = np.cross(J[0], J[1])
        tangent /= np.linalg.norm(tangent)
        for h in (1e-3, -1e-3):
            moved = p.theta + h * tangent
            # back onto the loop along the normal directions (Gauss-Newton on the closure)
            for _ in range(20):
                gap = tip(chain, moved) - np.asarray(chain.pin)
                Jm = np.array([L * np.cos(moved), L * np.sin(moved)])
                moved = moved - np.linalg.pinv(Jm) @ gap
            change = potential(chain, moved) - p.potential
            assert (change > 0) == p.stable, (p.theta, h, change)
            assert abs(change) < 1e-3  # quadratic: stationary, not merely low


def test_open_chain_rest_positions():
    chain = get_preset("triple-a").chain
    positions = rest_positions(chain)
    assert len(positions) == 8 and [p.stable for p in positions].count(True) == 1
    assert np.allclose(positions[0].theta, 0.0) and positions[0].stable
    assert positions[0].potential == pytest.approx(potential(chain, np.zeros(3)))
    top = positions[-1]
    assert np.allclose(top.theta, math.pi) and top.potential == pytest.approx(potential(chain, np.full(3, math.pi)))


def run_cli(*argv):
    return subprocess.run([sys.executable, "-m", "physics", *argv], capture_output=True, text=True, timeout=300)


def test_cli_lists_rest_positions_as_text_and_json():
    text = run_cli("equilibrium", "--preset", "four-bar")
    assert text.returncode == 0, text.stderr
    lines = text.stdout.strip().splitlines()
    assert "4 rest positions" in lines[0] and "theta1 (deg)" in lines[1]
    assert [line.split()[3] for line in lines[2:]] == ["yes", "yes", "no", "no"]
    document = json.loads(run_cli("equilibrium", "--preset", "four-bar", "--json").stdout)
    rests = document["rest_positions"]
    assert [r["stable"] for r in rests] == [True, True, False, False]
    assert rests[0]["theta_deg"] == pytest.approx(np.degrees(rests[0]["theta"]).tolist())


def test_cli_refuses_a_chain_too_long_to_list():
    result = run_cli("equilibrium", "--preset", "chain", "--links", "12")
    assert result.returncode == 2 and len(result.stderr.strip().splitlines()) == 1
    assert "links = 12" in result.stderr and "1 <= links <= 8" in result.stderr
