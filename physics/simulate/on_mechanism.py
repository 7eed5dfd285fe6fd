"""A chain's run on the general mechanism engine: the chain written as a mechanism, its Trajectory in the chain's
terms (issue 24, "one pipeline").

:func:`physics.simulate` runs every chain here, on the engine that runs every mechanism
(:mod:`physics.mechanism.engine`); there is no other route. The chain's own symbolic derivations
(:mod:`physics.derive`, loaded by :func:`physics.codegen.load_compiled`) remain as the independent formulas the
Equations tab shows and the tests check this route against. The chain is drawn hanging straight down
(:func:`physics.mechanism.chains.chain_mechanism` at ``theta = 0``; bars ``bar1..barn``, pins ``O``, ``J1 ..
J(n-1)`` and, for a pinned chain, ``H``; the chain's damping on every pin but ``H``), and its tree formulations
use absolute rotations (docs/mechanisms.md, "Absolute rotations"): a pin's tree coordinate is then the child's
own angle from the sketch, so the state integrated IS the chain's ``(theta, omega)``, permuted into the spanning
tree's order (the four-bar's ``(theta1, theta3, theta2)``, its closure ``J2``). What maps to what:

* ``newton_euler`` and ``lagrange``: the mechanism's formulation of that name in tree coordinates; ``dae``: the
  mechanism's DAE in tree coordinates (:mod:`physics.mechanism.tree_dae`), the chain's DAE integrating angles
  with every joint's multipliers; the reduced methods: the mechanism's reduced model as before
  (:mod:`physics.simulate.reduced_adapter`), its samples read by the mechanism's Lagrange system.
* The integration is the engine's (the same compiled kernels with dense output, scipy's solvers on the scipy
  back end), with the chain's stabilisation rule (an open chain has no constraint to hold) and the chain's sample
  times; a compiled RK45/DOP853 run and its samples are one buffer (:mod:`physics.codegen.mechanism_run`), any
  other run :func:`physics.mechanism.engine.integrate` then the same samples' functions.
* Every sample is solved by the mechanism's system (with the run's Baumgarte terms, as the chain's samples are):
  its reactions are the DAE's multipliers, or a tree formulation's by Newton's second law on every body in
  closed form (:mod:`physics.mechanism.tree_reactions`); pin ``O`` and ``J1 .. J(n-1)`` are the chain's joint
  reactions ``R_k`` (the force ON bar k+1 BY bar k), pin ``H`` the tip's. The condition is the solved system's:
  the kernel's estimate for an open chain, the 2-norm condition number of the matrix solved for a pinned one, as
  the chain's run reports it. Positions, energies, the traced point and the tip's velocity are the generic
  observables of :mod:`physics.codegen.mechanism_observables` (points reached from ``O`` along the bars, as the
  chain's own kinematics places them; the same to rounding).
* Failures are the chain's: a status and the chain's sentence (no mechanism name), never an exception midway.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np

    from ..model import Chain, Settings
    from .trajectory import Trajectory

__all__ = ["simulate_on_mechanism"]


def simulate_on_mechanism(chain: Chain, theta0: np.ndarray, omega0: np.ndarray, settings: Settings,
                          t_start: float) -> Trajectory:
    """:func:`physics.simulate` of a checked request (valid start, assembled, output size allowed) on the
    mechanism engine: the same Trajectory, fields and shapes, status and sentences."""
    # the route's module: loaded at a process's first run, not by ``import physics``
    from .mechanism_route import simulate_on_mechanism as run  # noqa: PLC0415

    return run(chain, theta0, omega0, settings, t_start)
