"""Static equilibrium of a pinned chain: the potential energy's minimum on the constraint manifold.

A closed loop at rest stays at rest where gravity's generalized force is balanced by the tip reaction,
``grad V = J^T R``; equivalently the gradient of ``V = sum m_k g y_Gk`` has no component along the
manifold ``tip(theta) = pin``. This module finds such a point independently of any simulation (SLSQP with
the loop as equality constraint, then Newton on the Lagrange conditions to machine precision) and says
whether it is a minimum (stable) from the Hessian of the Lagrangian restricted to the manifold.
A damped simulation should settle there; that comparison is a test of the dynamics.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares, minimize

from .errors import LinkageError
from .kinematics import lever_arms, potential_energy
from .loop_closure import loop_jacobian, loop_residual

# Newton on the Lagrange conditions stops when the residual is this small relative to the weights m g L.
KKT_RTOL = 1e-14
KKT_MAX_ITER = 30

# Eigenvalues of the reduced Hessian above this (relative to m g L) count as positive: a strict minimum.
MINIMUM_RTOL = 1e-9


@dataclass(frozen=True)
class Equilibrium:
    """A stationary point of V on the loop's manifold.

    ``theta`` (n,); ``potential`` V there; ``projected_gradient`` (n-2,): the gradient of V along an orthonormal
    basis of the manifold's tangent space (zero at equilibrium); ``reduced_hessian_eigenvalues`` (n-2,): of the
    Lagrangian's Hessian on that tangent space (all positive: a minimum); ``tip_reaction`` (2,): the force ON
    bar n BY the ground at the pin that holds the chain at rest; ``closure``: ``|tip - pin|``.
    """

    theta: np.ndarray
    potential: float
    is_minimum: bool
    projected_gradient: np.ndarray
    reduced_hessian_eigenvalues: np.ndarray
    tip_reaction: np.ndarray
    closure: float
    message: str


def _tangent_basis(J: np.ndarray) -> np.ndarray:
    """Orthonormal basis ``(n, n-2)`` of the null space of the loop Jacobian ``J (2, n)``."""
    _, _, vt = np.linalg.svd(J)
    return vt[2:].T


def static_equilibrium(L, d, m, g, pin, theta_guess) -> Equilibrium:
    """The equilibrium of a pinned chain nearest (in the optimiser's sense) to ``theta_guess``.

    Parameters
    ----------
    L, d, m : (n,) lengths, centre-of-mass distances, masses (n >= 3: at least one degree of freedom).
    g : gravity; pin : (2,) ground point of the tip; theta_guess : (n,) start of the search (need not close
        the loop).

    Returns
    -------
    Equilibrium; ``is_minimum`` False flags a maximum, saddle or flat direction (the optimiser met a
    stationary point that is not stable, e.g. when started exactly on one, or g = 0).

    Raises
    ------
    LinkageError when the inputs have the wrong shape, or no closed configuration is found near the guess.
    """
    L, d, m = (np.asarray(v, dtype=float).reshape(-1) for v in (L, d, m))
    n = L.size
    if n < 3 or d.size != n or m.size != n:
        raise LinkageError(f"L, d, m: need one entry per bar and at least 3 bars, got {L.size}, {d.size}, {m.size}")
    pin = np.asarray(pin, dtype=float).reshape(2)
    theta_guess = np.asarray(theta_guess, dtype=float).reshape(-1)
    if theta_guess.size != n:
        raise LinkageError(f"theta_guess: expected {n} angles, got {theta_guess.size}")
    g = float(g)
    weight = g * (m @ lever_arms(L, d))  # V = -sum weight_i cos theta_i

    def gradient(theta):
        return weight * np.sin(theta)

    # Close the loop first (the trust-region least-squares solver copes with a guess where J loses rank,
    # e.g. all bars hanging), so SLSQP starts on the manifold with a full-rank constraint Jacobian.
    start = least_squares(lambda th: loop_residual(L, th, pin), theta_guess, jac=lambda th: loop_jacobian(L, th),
                          method="trf", xtol=1e-15, ftol=1e-15, gtol=1e-15).x
    size = float(np.sum(L)) + float(np.hypot(*pin))
    gap = float(np.hypot(*loop_residual(L, start, pin)))
    if not gap <= 1e-8 * size:
        raise LinkageError(
            f"no closed configuration found near theta_guess = {theta_guess.tolist()}: the tip stays {gap:.3g} "
            f"from the pin; check that the loop can close (physics.loop_closure.driving_range)"
        )
    result = minimize(
        lambda th: float(potential_energy(L, d, m, g, th)),
        start,
        jac=gradient,
        method="SLSQP",
        constraints=[
            {"type": "eq", "fun": lambda th: loop_residual(L, th, pin), "jac": lambda th: loop_jacobian(L, th)}
        ],
        options={"ftol": 1e-15, "maxiter": 500},
    )
    theta = np.array(result.x, dtype=float)
    if not (np.all(np.isfinite(theta)) and np.hypot(*loop_residual(L, theta, pin)) <= 1e-6 * size):
        theta = start  # SLSQP wandered off the loop; Newton below still finds the stationary point nearby

    return stationary_point(L, d, m, g, pin, theta, note=result.message)


def stationary_point(L, d, m, g, pin, theta_near, note: str = "") -> Equilibrium:
    """Newton's method on the Lagrange conditions ``grad V + J^T lam = 0``, ``tip = pin`` from ``theta_near``
    (which should close the loop and lie near a stationary point), then its classification.

    Converges to whichever stationary point is nearest, a maximum as readily as a minimum: that is what
    lets a test check the classification; :func:`static_equilibrium` feeds it SLSQP's minimiser.
    """
    L, d, m = (np.asarray(v, dtype=float).reshape(-1) for v in (L, d, m))
    n = L.size
    pin = np.asarray(pin, dtype=float).reshape(2)
    theta = np.asarray(theta_near, dtype=float).reshape(n).copy()
    g = float(g)
    weight = g * (m @ lever_arms(L, d))
    scale = max(float(np.sum(np.abs(weight))), 1e-300)  # size of gravity's torques
    size = float(np.sum(L)) + float(np.hypot(*pin))

    def gradient(theta):
        return weight * np.sin(theta)

    J = loop_jacobian(L, theta)
    lam = -np.linalg.lstsq(J.T, gradient(theta), rcond=None)[0]
    for _ in range(KKT_MAX_ITER):
        J = loop_jacobian(L, theta)
        residual = np.concatenate([gradient(theta) + J.T @ lam, loop_residual(L, theta, pin)])
        if np.max(np.abs(residual)) <= KKT_RTOL * scale:
            break
        H = _lagrangian_hessian(L, weight, theta, lam)
        K = np.block([[H, J.T], [J, np.zeros((2, 2))]])
        try:
            step = np.linalg.solve(K, -residual)
        except np.linalg.LinAlgError:
            break  # singular KKT matrix (a singular loop position): keep the last iterate
        theta = theta + step[:n]
        lam = lam + step[n:]

    closure = float(np.hypot(*loop_residual(L, theta, pin)))
    if not closure <= 1e-8 * size:
        raise LinkageError(
            f"the search for an equilibrium left the loop (the tip ends {closure:.3g} from the pin"
            f"{'; ' + note if note else ''}); try a guess nearer the expected rest position"
        )
    J = loop_jacobian(L, theta)
    Z = _tangent_basis(J)
    projected = Z.T @ gradient(theta)
    eigenvalues = np.linalg.eigvalsh(Z.T @ _lagrangian_hessian(L, weight, theta, lam) @ Z)
    is_minimum = bool(np.all(eigenvalues > MINIMUM_RTOL * scale))
    if is_minimum:
        kind = "a minimum (stable)"
    else:
        kind = "not a strict minimum (a maximum, saddle or neutral direction: not stable)"
    return Equilibrium(
        theta=theta,
        potential=float(potential_energy(L, d, m, g, theta)),
        is_minimum=is_minimum,
        projected_gradient=projected,
        reduced_hessian_eigenvalues=eigenvalues,
        tip_reaction=-lam,
        closure=closure,
        message=f"stationary point of V on the loop: {kind}; |projected gradient| = {np.max(np.abs(projected)):.2g}",
    )


def _lagrangian_hessian(L, weight, theta, lam) -> np.ndarray:
    """Hessian of ``V + lam . (tip - pin)``: all diagonal since each term depends on one angle."""
    return np.diag(weight * np.cos(theta) + lam[0] * (-L * np.sin(theta)) + lam[1] * (L * np.cos(theta)))


def tip_reaction_at_rest(L, d, m, g, theta) -> np.ndarray:
    """Least-squares tip reaction R with ``J^T R = grad V`` (exact at an equilibrium), shape (2,)."""
    L, d, m = (np.asarray(v, dtype=float) for v in (L, d, m))
    weight = float(g) * (m @ lever_arms(L, d))
    theta = np.asarray(theta, dtype=float)
    return np.linalg.lstsq(loop_jacobian(L, theta).T, weight * np.sin(theta), rcond=None)[0]

