"""A chain's compiled system for one method, the chain written as a mechanism on the general engine (the one
route :func:`physics.simulate` takes): the boundary for callers that run the generated code themselves (the seed
report's ode45 replay, the ensemble's batched RK4, the free-body diagrams, ``accelerations``) rather than through
:func:`physics.simulate`.

Why one function: the chain written as a mechanism (:func:`physics.simulate.mechanism_route.chain_route`) has
the chain's absolute angles as coordinates, in the spanning tree's order (the four-bar's ``(theta1, theta3,
theta2)``), and the mechanism's parameter vector; a caller of :func:`chain_system` gets the state, the parameters
and the reading of the solution that go with them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..codegen.cache import CompiledSystem
from ..errors import LinkageError
from ..model import FORMULATION_NAMES, Chain, Settings
from .trajectory import Trajectory

if TYPE_CHECKING:  # the route's module: loaded at the first system, not by ``import physics``
    from .mechanism_route import ChainAsMechanism

__all__ = ["ChainSystem", "chain_system"]


@dataclass(frozen=True)
class ChainSystem:
    """A chain's compiled system for one method, and how to talk to it in the chain's terms.

    * ``compiled``: the generated system; its states are ``(s, s_dot)`` in the system's coordinate order.
    * ``params``: the parameter vector to pass with it (this object's own array: an integrator writes a
      mechanism's time slot into it, so never share it between runs that overlap).
    * ``order`` / ``inverse``: system coordinate ``k`` is the angle of bar ``order[k]`` (0-based); the chain's bar
      ``j`` is system coordinate ``inverse[j]``.
    * ``theta_ddot_index`` (n,): where bar ``j``'s angular acceleration is among the solved unknowns ``x``.
    * ``reaction_index`` (n, 2): where the joint reactions ``R_k`` (ON bar k+1 BY bar k or the ground) are in
      ``x``, for a method that solves for them (the DAE); ``(0, 2)`` otherwise.
    * ``tip_reaction_index`` (2,): where a pinned chain's tip reaction (ON the last bar BY the ground at the pin)
      is in ``x`` when the system solves for it; empty otherwise (an open chain, or a tree formulation, whose
      loop is closed at another joint: :meth:`tip_reactions` gives it from the bodies).
    * ``route``: the chain written as a mechanism.
    * ``method``, ``damping``: what it was made for.
    """

    method: str
    damping: float
    compiled: CompiledSystem
    params: np.ndarray
    order: np.ndarray
    inverse: np.ndarray
    theta_ddot_index: np.ndarray
    reaction_index: np.ndarray
    tip_reaction_index: np.ndarray
    route: ChainAsMechanism

    @property
    def layout(self) -> np.ndarray:
        """The integrators' layout of the system (``integration_layout``), as :func:`physics.simulate` passes it."""
        return self.compiled.integration_layout

    def coordinates(self, values: np.ndarray) -> np.ndarray:
        """Per-bar values in the chain's order ``(..., n)`` into the system's order (a C-contiguous copy)."""
        return np.ascontiguousarray(np.asarray(values, dtype=float)[..., self.order])

    def bars(self, values: np.ndarray) -> np.ndarray:
        """Per-coordinate values in the system's order ``(..., n)`` back into the chain's bar order (a copy)."""
        return np.ascontiguousarray(np.asarray(values, dtype=float)[..., self.inverse])

    def state(self, theta: np.ndarray, omega: np.ndarray) -> np.ndarray:
        """The system's state ``y = [s, s_dot]`` of the chain's ``(theta, omega)``: shape ``(..., 2 n)``."""
        return np.concatenate([self.coordinates(theta), self.coordinates(omega)], axis=-1)

    def solve(self, theta: np.ndarray, omega: np.ndarray, alpha: float = 0.0, beta: float = 0.0
              ) -> tuple[np.ndarray, float]:
        """The system solved at one state of the chain: all unknowns ``x`` (read them with the indices above) and
        the kernel's condition estimate (its pivot ratio)."""
        return self.compiled.solve_full(self.coordinates(theta), self.coordinates(omega), self.params, alpha, beta)

    def trajectory(self, chain: Chain, settings: Settings, t: np.ndarray, y: np.ndarray, alpha: float = 0.0,
                   beta: float = 0.0) -> Trajectory:
        """The chain's Trajectory (status OK, no counts) of samples ``y (T, 2 n)`` in the system's order at times
        ``t``, as :func:`physics.simulate` builds it on this route: every reaction, the condition, positions,
        energies and the traced point."""
        from .mechanism_route import chain_trajectory  # noqa: PLC0415  (loaded at the first system)

        n = chain.n
        y = np.asarray(y, dtype=float)
        return chain_trajectory(chain, settings, self.route, self.params, t, self.bars(y[:, :n]),
                                self.bars(y[:, n:]), alpha, beta)

    def tip_reactions(self, chain: Chain, theta: np.ndarray, omega: np.ndarray) -> np.ndarray:
        """A pinned chain's tip reaction (ON the last bar BY the ground) at states ``(K, n)`` of the chain: shape
        ``(K, 2)``. Read off the unknowns where the system solves for it; else (a tree formulation) by Newton's law on every body, as the run's samples give it (:meth:`trajectory`)."""
        theta, omega = np.atleast_2d(theta), np.atleast_2d(omega)
        if not chain.pinned:
            raise LinkageError("tip reaction: the chain is open (no pin at its tip)")
        if self.tip_reaction_index.size:
            x, _ = self.compiled.solve_full_batch(self.coordinates(theta), self.coordinates(omega), self.params)
            return x[:, self.tip_reaction_index]
        settings = Settings(method=self.method, damping=self.damping)
        return self.trajectory(chain, settings, np.zeros(len(theta)), self.state(theta, omega)).tip_reaction


def chain_system(chain: Chain, method: str, damping: float = 0.0, t_start: float = 0.0) -> ChainSystem:
    """``chain``'s compiled system for ``method`` (a derived formulation: newton_euler, lagrange, dae) with joint
    damping ``damping``: the chain written as a mechanism on the general engine, as :func:`physics.simulate` runs
    it (``t_start``: its parameter vector's time slot; a chain has no motor, so nothing depends on it)."""
    if method not in FORMULATION_NAMES:
        raise LinkageError(f"method = {method!r}: a chain's compiled system is one of {', '.join(FORMULATION_NAMES)}")
    n = chain.n
    from .mechanism_route import chain_route  # noqa: PLC0415  (the route's module: loaded at the first system)
    route = chain_route(chain, method, damping)
    compiled = route.compiled
    theta_ddot_index = compiled.theta_ddot_index[route.inverse]
    if route.own_reactions:  # the DAE: every joint's reaction is among its multipliers, in the mechanism's rows
        multipliers = compiled.multiplier_index
        reaction_index = multipliers[route.joint_rows].reshape(n, 2)
        tip_reaction_index = multipliers[route.tip_rows]
    else:
        reaction_index = np.zeros((0, 2), dtype=np.int64)
        tip_reaction_index = np.zeros(0, dtype=np.int64)
    return ChainSystem(method, float(damping), compiled, route.parameters_at(t_start), route.order,
                       route.inverse, theta_ddot_index, reaction_index, tip_reaction_index, route)
