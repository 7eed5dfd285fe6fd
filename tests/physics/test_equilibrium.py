"""Static equilibrium of a pinned chain: stationary on the manifold, a minimum, and at rest it stays."""

import math

import numpy as np
import pytest

from physics import Bar, Chain, Settings, load_compiled, simulate
from physics.equilibrium import static_equilibrium, stationary_point, tip_reaction_at_rest
from physics.errors import LinkageError
from physics.kinematics import potential_energy
from physics.loop_closure import assemble, driving_range, loop_jacobian, tip_position

L = np.array([1.0, 1.0, 2.0])
D = np.array([0.5, 0.5, 0.5])
M = np.array([1.0, 1.0, 1.0])
I = np.array([0.2, 0.3, 0.4])
G = 1.0
THETA0 = np.array([math.pi - math.pi / 30, math.pi / 2, 0.0])
PIN = tip_position(L, THETA0)


def potential_along_the_loop(samples=20001):
    """V over the seed's whole configuration loop: theta1 across its range on both branches."""
    (lo, hi), = driving_range(L, PIN)
    theta1 = np.linspace(lo, hi, samples)
    thetas = np.array([assemble(L, PIN, [t], elbow=e) for e in (1, -1) for t in theta1])
    return thetas, potential_energy(L, D, M, G, thetas)


@pytest.fixture(scope="module")
def seed_equilibria():
    return [static_equilibrium(L, D, M, G, PIN, guess) for guess in (THETA0, np.zeros(3))]


def test_equilibrium_is_stationary_on_the_manifold_and_a_minimum(seed_equilibria):
    for eq in seed_equilibria:
        assert eq.closure < 1e-13
        # gradient of V orthogonal to the manifold: its projection on the tangent is zero
        assert np.max(np.abs(eq.projected_gradient)) < 1e-12
        weight = G * np.array([M[0] * D[0] + (M[1] + M[2]) * L[0], M[1] * D[1] + M[2] * L[1], M[2] * D[2]])
        grad = weight * np.sin(eq.theta)
        J = loop_jacobian(L, eq.theta)
        tangent = np.cross(J[0], J[1])  # the null vector of J for 3 angles
        assert abs(grad @ tangent) < 1e-12 * np.linalg.norm(grad) * np.linalg.norm(tangent)
        assert eq.is_minimum and np.all(eq.reduced_hessian_eigenvalues > 0)
        assert "a minimum" in eq.message


def test_equilibrium_is_lower_than_its_neighbours_on_the_loop(seed_equilibria):
    for eq in seed_equilibria:
        for delta in (-1e-3, 1e-3, -3e-2, 3e-2):
            neighbour = assemble(L, PIN, [eq.theta[0] + delta], theta_prev=eq.theta)
            assert potential_energy(L, D, M, G, neighbour) > eq.potential


def test_equilibria_match_the_minima_of_a_brute_force_scan(seed_equilibria):
    """An independent search: V sampled along the whole loop; its local minima are the equilibria found."""
    thetas, V = potential_along_the_loop()
    # the loop is the two branches joined at their ends: walk it as one closed curve
    half = V.size // 2
    curve_V = np.concatenate([V[:half], V[half:][::-1]])
    curve = np.concatenate([thetas[:half], thetas[half:][::-1]])
    is_min = (curve_V < np.roll(curve_V, 1)) & (curve_V < np.roll(curve_V, -1))
    minima = curve[is_min]
    assert len(minima) == 2  # the seed four-bar has two stable equilibria
    found = sorted(seed_equilibria, key=lambda eq: eq.potential)
    for eq, k in zip(found, np.argsort(curve_V[is_min])):
        difference = np.angle(np.exp(1j * (eq.theta - minima[k])))
        assert np.max(np.abs(difference)) < 2e-3  # grid spacing ~ 2.4e-4 in theta1, coarser in the others
        assert eq.potential <= curve_V[is_min][k] + 1e-12
    assert found[0].potential == pytest.approx(-3.5456854357921355, abs=1e-9)
    assert found[1].potential == pytest.approx(0.8827216322688352, abs=1e-9)


def test_maxima_of_the_scan_are_stationary_but_not_minima():
    thetas, V = potential_along_the_loop(4001)
    half = V.size // 2
    curve_V = np.concatenate([V[:half], V[half:][::-1]])
    curve = np.concatenate([thetas[:half], thetas[half:][::-1]])
    is_max = (curve_V > np.roll(curve_V, 1)) & (curve_V > np.roll(curve_V, -1))
    assert is_max.sum() == 2
    for theta in curve[is_max]:
        top = stationary_point(L, D, M, G, PIN, theta)
        assert np.max(np.abs(top.projected_gradient)) < 1e-12
        assert not top.is_minimum and top.reduced_hessian_eigenvalues[0] < 0
        assert "not a strict minimum" in top.message


def test_tip_reaction_balances_gravity(seed_equilibria):
    for eq in seed_equilibria:
        np.testing.assert_allclose(eq.tip_reaction, tip_reaction_at_rest(L, D, M, G, eq.theta), atol=1e-12)
        # at rest the open chain's forcing (gravity alone, from the generated Lagrange code) is balanced exactly by
        # the tip reaction: f + J^T R = 0
        _, f = load_compiled("lagrange", 3, False).matrix(eq.theta, np.zeros(3),
                                                          np.concatenate([L, D, M, I, [G], PIN, [0.0]]))
        np.testing.assert_allclose(f + loop_jacobian(L, eq.theta).T @ eq.tip_reaction, 0.0, atol=1e-12)


def test_linkage_assembled_at_equilibrium_stays_at_rest(seed_equilibria):
    chain = Chain(bars=[Bar(L=L[k], d=D[k], m=M[k], I=I[k]) for k in range(3)], g=G, pin=tuple(PIN))
    for eq in seed_equilibria:
        run = simulate(chain, eq.theta, np.zeros(3), Settings(method="reduced", t_end=20.0, samples=41))
        assert run.status == 0
        assert np.max(np.abs(run.theta - eq.theta)) < 1e-8
        assert np.max(np.abs(run.omega)) < 1e-8


def test_four_link_loop_equilibrium():
    rng = np.random.default_rng(5)
    L4, D4, M4 = np.array([1.0, 1.5, 1.2, 1.8]), np.array([0.4, 0.7, 0.5, 0.9]), np.array([1.0, 2.0, 1.5, 1.0])
    pin = tip_position(L4, np.array([1.0, 2.0, 0.5, -0.3]))
    eq = static_equilibrium(L4, D4, M4, 9.81, pin, [1.0, 2.0, 0.5, -0.3])
    assert eq.closure < 1e-12 and eq.projected_gradient.shape == (2,)
    assert np.max(np.abs(eq.projected_gradient)) < 1e-10
    assert eq.is_minimum
    for _ in range(20):  # neighbours on the 2-dimensional manifold lie higher
        driving = eq.theta[:2] + rng.normal(scale=1e-2, size=2)
        neighbour = assemble(L4, pin, driving, theta_prev=eq.theta)
        assert potential_energy(L4, D4, M4, 9.81, neighbour) > eq.potential


def test_bad_input():
    with pytest.raises(LinkageError, match="at least 3 bars"):
        static_equilibrium(L[:2], D[:2], M[:2], G, PIN, [0.0, 0.0])
    with pytest.raises(LinkageError, match="theta_guess"):
        static_equilibrium(L, D, M, G, PIN, [0.0, 0.0])
    with pytest.raises(LinkageError, match="no closed configuration"):
        static_equilibrium(L, D, M, G, np.array([10.0, 0.0]), THETA0)  # the pin is out of reach
