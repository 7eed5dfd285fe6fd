"""Every rest position of a chain: where it can stay at rest, whether it is stable, and its potential energy.

A chain at rest stays at rest exactly where the potential energy ``V = sum m_i g y_Gi`` is stationary (on the
loop's manifold for a closed chain); it is stable where V has a strict minimum there.

* Open chain: ``dV/dtheta_i = w_i sin(theta_i)`` with ``w_i = g (m_i d_i + L_i * mass of the bars beyond i)``
  depends on one angle each, so the rest positions are every bar straight down or straight up (2^n of them)
  and only all-down is stable (the Hessian is ``diag(w_i cos theta_i)``).
* Closed chain (one degree of freedom for the four-bar): V is sampled along the whole loop (both assembly
  branches, :func:`physics.loop_closure.driving_range`), and each local minimum and maximum of the samples is
  refined and classified by :func:`physics.equilibrium.stationary_point` (Newton on the Lagrange conditions).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from .equilibrium import stationary_point
from .errors import LinkageError
from .loop_closure import assemble, driving_range
from .model import Chain

# Samples of V along each assembly branch of a closed loop: enough that neighbouring stationary points (a
# minimum next to a maximum) fall in different samples for the presets; each is then refined by Newton.
LOOP_SAMPLES = 4001
# Two refined points closer than this (radians, every angle) are one rest position found twice.
SAME_POINT = 1e-7
# An open chain with more bars than this has too many rest positions (2^n) to list usefully.
MAX_LISTED_LINKS = 8


@dataclass(frozen=True)
class RestPosition:
    """``theta`` (n,) in radians, ``potential`` V there, ``stable`` (a strict minimum of V)."""

    theta: np.ndarray
    potential: float
    stable: bool

    def as_dict(self) -> dict:
        return {"theta_deg": [math.degrees(v) for v in self.theta], "theta": [float(v) for v in self.theta],
                "stable": self.stable, "potential": self.potential}


def _wrap(theta: np.ndarray) -> np.ndarray:
    """Angles in (-pi, pi]."""
    return -np.remainder(-np.asarray(theta, dtype=float) + math.pi, 2 * math.pi) + math.pi


def _weights(chain: Chain) -> np.ndarray:
    L, d, m = (chain.array(f) for f in "Ldm")
    beyond = np.concatenate([np.cumsum(m[::-1])[::-1][1:], [0.0]])
    return chain.g * (m * d + L * beyond)


def open_chain_rest_positions(chain: Chain) -> list[RestPosition]:
    """Every bar straight down (0) or up (pi): 2^n positions, the stable one first."""
    if chain.n > MAX_LISTED_LINKS:
        raise LinkageError(f"links = {chain.n}: an open chain of n bars has 2^n rest positions; listed for "
                           f"1 <= links <= {MAX_LISTED_LINKS}")
    weights = _weights(chain)
    positions = []
    for ups in itertools.product((0.0, math.pi), repeat=chain.n):
        theta = np.array(ups)
        hessian = weights * np.cos(theta)
        positions.append(RestPosition(theta, float(-np.sum(weights * np.cos(theta))), bool(np.all(hessian > 0))))
    return sorted(positions, key=lambda p: p.potential)


def closed_chain_rest_positions(chain: Chain, samples: int = LOOP_SAMPLES) -> list[RestPosition]:
    """The stationary points of V around a four-bar's loop, lowest first."""
    if chain.n != 3:
        raise LinkageError(f"links = {chain.n}: rest positions of closed chains are found for four-bars (3 bars)")
    L, d, m = (chain.array(f) for f in "Ldm")
    pin = np.asarray(chain.pin, dtype=float)
    weights = _weights(chain)
    found: list[RestPosition] = []
    for lo, hi in driving_range(L, pin):
        full_turn = hi - lo >= 2 * math.pi - 1e-12
        theta1 = np.linspace(lo, hi, samples, endpoint=not full_turn)
        for elbow in (1, -1):
            rows = []
            for t1 in theta1:
                try:
                    rows.append(assemble(L, pin, [t1], elbow=elbow))
                except LinkageError:
                    rows.append(np.full(3, np.nan))
            curve = np.array(rows)
            V = -np.sum(weights * np.cos(curve), axis=1)
            for k in _local_extrema(V, periodic=full_turn):
                try:
                    eq = stationary_point(L, d, m, chain.g, pin, curve[k])
                except LinkageError:
                    continue
                if np.max(np.abs(eq.projected_gradient)) > 1e-9 * max(np.sum(np.abs(weights)), 1e-300):
                    continue
                theta = _wrap(eq.theta)
                if any(np.max(np.abs(_wrap(theta - p.theta))) < SAME_POINT for p in found):
                    continue
                found.append(RestPosition(theta, eq.potential, eq.is_minimum))
    return sorted(found, key=lambda p: p.potential)


def _local_extrema(V: np.ndarray, periodic: bool) -> list[int]:
    """Indices of strict local minima and maxima of the finite samples (ends included as candidates when the
    curve is not periodic: a branch ends where it meets the other one, so an extremum may sit there)."""
    index = []
    n = V.size
    for k in range(n):
        if not np.isfinite(V[k]):
            continue
        left = V[k - 1] if (k > 0 or periodic) else np.nan
        right = V[(k + 1) % n] if (k + 1 < n or periodic) else np.nan
        neighbours = [v for v in (left, right) if np.isfinite(v)]
        if neighbours and (all(V[k] < v for v in neighbours) or all(V[k] > v for v in neighbours)):
            index.append(k)
    return index


def rest_positions(chain: Chain) -> list[RestPosition]:
    """Every rest position of the chain, lowest potential energy first."""
    return closed_chain_rest_positions(chain) if chain.pinned else open_chain_rest_positions(chain)
