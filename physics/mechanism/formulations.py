"""The three formulations of a mechanism as the integrator sees them: a state, its accelerations (with the
Baumgarte terms when asked), a projection onto the constraints, and a sample (pose, velocities, reactions).

* ``dae``: maximal coordinates ``(q, qdot)``, 3 per body (:mod:`physics.mechanism.dae`); between samples its
  accelerations come from the same augmented system solved through its structure (the mass matrix is
  diagonal, so the multipliers solve ``Phi_q M^-1 Phi_q^T lambda = gamma - Phi_q M^-1 Q``).
* ``lagrange`` and ``newton_euler``: the tree coordinates ``(s, sd)``, one per tree joint
  (:mod:`physics.mechanism.lagrange`, :mod:`physics.mechanism.newton_euler`), their closures as constraints.

Each gives its own reactions at the samples: the DAE's multipliers, or the tree formulation's multipliers and
Newton's second law on its own accelerations (:mod:`physics.mechanism.reactions`). Stabilisation as for the
chains (docs/physics.md, "Closed loops"): ``baumgarte`` replaces the closures' ``Phi'' = gamma`` by
``Phi'' + 2 alpha Phi' + beta^2 Phi = 0``; ``projection`` moves the state back onto ``Phi = 0`` and
``Phi' = 0`` by least-change Gauss-Newton steps after every accepted step.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg.lapack import dgesv

from ..errors import LinkageError
from .assembly import ASSEMBLY_TOLERANCE, sketch_size
from .dae import MechanismDAE
from .tree import tree_state

METHODS = ("dae", "lagrange", "newton_euler")
STABILIZATIONS = ("none", "baumgarte", "projection")
PROJECTION_ITERATIONS = 8


class DaeFormulation:
    """Maximal coordinates: ``y = (q, qdot)``."""

    name = "dae"

    def __init__(self, dae: MechanismDAE, alpha: float, beta: float) -> None:
        self.dae = dae
        self.size = dae.constraints.size
        self.inverse_mass = 1.0 / dae.mass_diagonal
        self.velocity_target = dae.constraints.velocity_rhs()
        self.tolerance = ASSEMBLY_TOLERANCE * sketch_size(dae.mechanism)
        scale = sketch_size(dae.mechanism)
        self.weights = np.tile([1.0, 1.0, 1.0 / scale**2], len(dae.mechanism.bodies))  # as assembly weighs steps
        self._parameters = np.array([0.0, alpha, beta])
        self._native: tuple | None = None  # (augmented system, closures), machine code compiled on first use

    def start(self, q: np.ndarray, qdot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return q, qdot

    def accelerations(self, t: float, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        """From the DAE's machine code (compiled when first needed), Baumgarte terms included."""
        self._parameters[0] = t
        return solve(*self._compiled()[0](x, v, self._parameters))[: self.size]

    def _compiled(self):
        if self._native is None:
            from .dae_native import compile_dae  # noqa: PLC0415  (sympy and llvmlite only when a run integrates)

            self._native = compile_dae(self.dae.mechanism)
        return self._native

    def project(self, t: float, x: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Least-change Gauss-Newton onto ``Phi(q, t) = 0`` (rotations weighed by the sketch's size, as assembly
        does), then the velocity nearest in kinetic energy with ``Phi_q qdot = nu``."""
        closures = self._compiled()[1]
        time = np.array([t])
        for _ in range(PROJECTION_ITERATIONS):
            jacobian, gap = closures(x, (), time)
            if gap.size == 0 or np.max(np.abs(gap)) <= self.tolerance:
                break
            weighted = jacobian * self.weights
            x = x - self.weights * (jacobian.T @ solve(weighted @ jacobian.T, gap))
        jacobian, _ = closures(x, (), time)
        if jacobian.shape[0]:
            weighted = jacobian * self.inverse_mass
            gap = jacobian @ v - self.velocity_target
            v = v - self.inverse_mass * (jacobian.T @ solve(weighted @ jacobian.T, gap))
        return x, v

    def sample_pose(self, t: float, x: np.ndarray) -> np.ndarray:
        """The pose ``q`` (x, y, phi per body) of state ``x``."""
        return np.array(x, dtype=float)

    def sample(self, t: float, x: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        solution = self.dae.solve(x, v)  # refuses a singular pose in one line
        return x, v, solution.reactions


class TreeFormulation:
    """Tree coordinates: ``y = (s, sd)``; ``tree`` is a :class:`~physics.mechanism.lagrange.TreeLagrange` or a
    :class:`~physics.mechanism.newton_euler.TreeNewtonEuler`."""

    def __init__(self, name: str, tree, dae: MechanismDAE, alpha: float, beta: float) -> None:
        self.name, self.tree, self.mechanism = name, tree, dae.mechanism
        self.alpha, self.beta = alpha, beta
        self.size = len(tree.coordinates)
        self.rows = len(tree.row_joints)
        self.velocity_target = np.asarray(tree.velocity_rhs, dtype=float).reshape(self.rows)
        self.tolerance = ASSEMBLY_TOLERANCE * sketch_size(dae.mechanism)
        self._parameters = np.array([0.0, alpha, beta])

    def _jacobian(self, s: np.ndarray) -> np.ndarray:
        return np.asarray(self.tree.constraint_jacobian(s), dtype=float).reshape(self.rows, self.size)

    def _residual(self, s: np.ndarray, t: float) -> np.ndarray:
        return np.asarray(self.tree.constraint(s, t), dtype=float).reshape(self.rows)

    def start(self, q: np.ndarray, qdot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return tree_state(self.mechanism, q, qdot)

    def _baumgarte(self, t: float, s: np.ndarray, sd: np.ndarray) -> np.ndarray:
        """What the closures' rows of the right-hand side lose: ``2 alpha Phi' + beta^2 Phi``."""
        jacobian = self._jacobian(s)
        return 2.0 * self.alpha * (jacobian @ sd - self.velocity_target) + self.beta**2 * self._residual(s, t)

    def _system(self, t: float, s: np.ndarray, sd: np.ndarray, stabilised: bool = True
                ) -> tuple[np.ndarray, np.ndarray]:
        """The formulation's own linear system in ``(sdd, multipliers)``, with the Baumgarte terms when
        ``stabilised`` (the samples report the reactions without them, as the DAE's samples do)."""
        if self.name == "newton_euler":
            matrix = np.atleast_2d(self.tree.matrix(s))
            rhs = np.array(self.tree.rhs(s, sd), dtype=float)
        else:
            mass = np.atleast_2d(self.tree.mass(s))
            jacobian = self._jacobian(s)
            k, rows = self.size, self.rows
            matrix = np.zeros((k + rows, k + rows))
            matrix[:k, :k], matrix[:k, k:], matrix[k:, :k] = mass, -jacobian.T, jacobian
            rhs = np.concatenate([np.ravel(self.tree.force(s, sd)),
                                  np.ravel(self.tree.gamma(s, sd)) if rows else np.zeros(0)])
        if stabilised and self.rows and (self.alpha or self.beta):
            rhs[self.size:] -= self._baumgarte(t, s, sd)
        return matrix, rhs

    def accelerations(self, t: float, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        """From the formulation's machine code (compiled when first needed), Baumgarte terms included."""
        self._parameters[0] = t
        matrix, rhs = self.tree.native()(x, v, self._parameters)
        return solve(matrix, rhs)[: self.size]

    def project(self, t: float, x: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if not self.rows:
            return x, v
        x = _least_change(lambda z: self._residual(z, t), self._jacobian, x, np.ones(self.size), self.tolerance)
        jacobian = self._jacobian(x)
        gap = jacobian @ v - self.velocity_target
        return x, v - jacobian.T @ np.linalg.solve(jacobian @ jacobian.T, gap)

    def sample_pose(self, t: float, x: np.ndarray) -> np.ndarray:
        """The pose ``q`` (x, y, phi per body) of tree coordinates ``x``."""
        zero = np.zeros(self.size)
        return np.asarray(self.tree.motion(x, zero, zero), dtype=float).reshape(-1, 9)[:, 0:3].ravel()

    def sample(self, t: float, x: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        matrix, rhs = self._system(t, x, v, stabilised=False)
        if 1.0 / np.linalg.cond(matrix) < 1e-13:
            raise LinkageError(f"{self.mechanism.name}: singular pose (a dead centre or a redundant constraint)")
        solution = np.linalg.solve(matrix, rhs)
        sdd, multipliers = solution[: self.size], solution[self.size :]
        motion = np.asarray(self.tree.motion(x, v, sdd), dtype=float).reshape(-1, 9)
        reactions = self.tree.reactions(x, v, sdd, multipliers)
        return motion[:, 0:3].ravel(), motion[:, 3:6].ravel(), reactions


def solve(matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """``matrix x = rhs`` by LAPACK's dgesv directly (numpy's wrapper costs four times the solve of a small
    system); LinkageError when the matrix is exactly singular."""
    _, _, x, info = dgesv(matrix, rhs)
    if info != 0:
        raise LinkageError("singular pose (a dead centre or a redundant constraint)")
    return x


def _least_change(residual, jacobian, x: np.ndarray, weights: np.ndarray, tolerance: float) -> np.ndarray:
    """Gauss-Newton steps of least (weighted) change onto ``residual = 0``: ``dx = -W J^T (J W J^T)^-1 Phi``."""
    for _ in range(PROJECTION_ITERATIONS):
        gap = residual(x)
        if gap.size == 0 or np.max(np.abs(gap)) <= tolerance:
            break
        matrix = jacobian(x)
        weighted = matrix * weights
        x = x - weights * (matrix.T @ np.linalg.solve(weighted @ matrix.T, gap))
    return x


def formulation(method: str, dae: MechanismDAE, alpha: float, beta: float) -> DaeFormulation | TreeFormulation:
    """The formulation called ``method`` (one of :data:`METHODS`) of the mechanism of ``dae``."""
    if method == "dae":
        return DaeFormulation(dae, alpha, beta)
    if method == "lagrange":
        from .lagrange import derive_tree_lagrange  # noqa: PLC0415  (sympy only when asked for)

        return TreeFormulation(method, derive_tree_lagrange(dae.mechanism), dae, alpha, beta)
    from .newton_euler import derive_tree_newton_euler  # noqa: PLC0415  (sympy only when asked for)

    return TreeFormulation(method, derive_tree_newton_euler(dae.mechanism), dae, alpha, beta)
