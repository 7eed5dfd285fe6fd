"""The chain's own formulas as the oracle of a chain's run: a run takes one route (the chain written as a
mechanism on the general engine, physics/simulate/mechanism_route.py), and the tests check what it reports at
every sample against what the chain's independent derivations give at the same state.

The chain's derivations (physics/derive, loaded by :func:`physics.load_compiled`) write the same physics in the
chain's own terms: its bar order, its parameter vector, its own unknowns (the pinned four-bar's Lagrange system
closes the loop at the tip, where the mechanism's tree closes it at ``J2``). Evaluated at a sample's state, with
the run's Baumgarte gains, they give the angular accelerations, the DAE's joint reactions and the tip's reaction
the route solved for; the joint reactions of the tree formulations follow from those accelerations by Newton's
law per bar (:func:`physics.chain_reactions.reactions_from_motion`), positions and energies from the chain's
kinematics. The two computations sum the same terms in another order, so they agree to rounding:
:data:`ROUNDING` 1e-11 relative (to 1 + the largest value), where a wrong equation, reaction row or sign is off
by order one.

The condition column: for an open chain of two bars or more the run reports the solve's estimate, which the
chain's system gives too (the same matrix up to rounding); a pinned chain's run reports the 2-norm condition
number of the mechanism's matrix, another matrix than the chain's, so there only its shape and finiteness are
checked.
"""

from __future__ import annotations

import numpy as np

from physics import load_compiled
from physics.chain_reactions import reactions_from_motion
from physics.kinematics import energies, joint_positions, point_on_bar, tip_velocity
from physics.model import FORMULATION_NAMES, TracePoint
from physics.simulate.chain_prepared import stabilization_gains
from physics.simulate.chain_system import chain_system

ROUNDING = 1e-11


def relative(mine, theirs) -> float:
    """``max |mine - theirs| / (1 + max |theirs|)``; the shapes must agree."""
    mine, theirs = np.asarray(mine, dtype=float), np.asarray(theirs, dtype=float)
    assert mine.shape == theirs.shape, (mine.shape, theirs.shape)
    if theirs.size == 0:
        return 0.0
    return float(np.max(np.abs(mine - theirs)) / (1.0 + np.max(np.abs(theirs))))


def formulation_of(method: str) -> str:
    """The derived system that reads a run's samples: the method's own; the reduced methods' the pinned Lagrange
    system (physics/simulate/reduced_adapter.py)."""
    return method if method in FORMULATION_NAMES else "lagrange"


def chain_solution(chain, settings, theta, omega) -> dict[str, np.ndarray]:
    """The chain's own compiled system for the run's formulation, solved at states ``(K, n)`` with the chain's
    parameters, damping and the run's Baumgarte gains: ``theta_ddot (K, n)``, ``reactions (K, n, 2)`` (the
    DAE's; ``(K, 0, 2)`` otherwise), ``tip_reaction (K, 2)`` (a pinned chain's, where its system solves for it,
    else absent) and the solve's condition estimate ``cond (K,)``."""
    compiled = load_compiled(formulation_of(settings.method), chain.n, chain.pinned)
    alpha, beta, _ = stabilization_gains(chain, settings)
    theta, omega = np.ascontiguousarray(theta), np.ascontiguousarray(omega)
    x, cond = compiled.solve_full_batch(theta, omega, chain.params(damping=settings.damping), alpha, beta)
    solution = {"theta_ddot": x[:, compiled.theta_ddot_index], "cond": cond,
                "reactions": (x[:, compiled.reaction_index] if compiled.reaction_index.size
                              else np.zeros((len(x), 0, 2)))}
    if chain.pinned and compiled.tip_reaction_index.size:
        solution["tip_reaction"] = x[:, compiled.tip_reaction_index]
    return solution


def route_accelerations(chain, settings, theta, omega) -> np.ndarray:
    """The angular accelerations the run's own system (the chain written as a mechanism) solves for at states
    ``(K, n)`` of the chain, in the chain's bar order."""
    system = chain_system(chain, formulation_of(settings.method), settings.damping)
    alpha, beta, _ = stabilization_gains(chain, settings)
    x, _ = system.compiled.solve_full_batch(system.coordinates(theta), system.coordinates(omega), system.params,
                                            alpha, beta)
    return x[:, system.theta_ddot_index]


def chain_tip(chain):
    """The point a run traces when its settings name none: the last bar's far end."""
    return TracePoint(bar=chain.n, along=float(chain.array("L")[-1]))


def assert_run_follows_chain_formulas(chain, settings, run, tolerance: float = ROUNDING) -> None:
    """At every sample of ``run``: the route's accelerations, the DAE's reactions, the tip's reaction, the joint
    reactions, positions, energies, the pin's drift and (an open chain) the condition estimate equal the chain's
    own formulas at the sample's state within ``tolerance``; every field has the chain's shape."""
    n, samples = chain.n, len(run.t)
    assert run.theta.shape == run.omega.shape == (samples, n)
    assert samples > 0
    theta, omega = run.theta, run.omega
    chain_side = chain_solution(chain, settings, theta, omega)
    theta_ddot = chain_side["theta_ddot"]
    assert relative(route_accelerations(chain, settings, theta, omega), theta_ddot) <= tolerance
    L, d, m, _inertia = (chain.array(name) for name in ("L", "d", "m", "I"))
    tip_reaction = None
    if chain.pinned:
        assert run.tip_reaction.shape == (samples, 2)
        if "tip_reaction" in chain_side:
            assert relative(run.tip_reaction, chain_side["tip_reaction"]) <= tolerance, "tip_reaction"
        tip_reaction = chain_side.get("tip_reaction", run.tip_reaction)
    else:
        assert run.tip_reaction.shape == (samples, 0)
    expected_joint_reactions = reactions_from_motion(L, d, m, chain.g, theta, omega, theta_ddot, tip_reaction)
    assert relative(run.joint_reactions, expected_joint_reactions) <= tolerance, "joint_reactions"
    assert relative(run.reactions, chain_side["reactions"]) <= tolerance, "reactions"
    joints = joint_positions(L, theta)
    assert relative(run.joints, joints) <= tolerance, "joints"
    assert relative(run.tip_xy, joints[:, -1, :]) <= tolerance, "tip_xy"
    trace = settings.trace or chain_tip(chain)
    traced = point_on_bar(L, theta, trace.bar, trace.along, trace.across)
    assert relative(run.trace_xy, traced) <= tolerance, "trace_xy"
    kinetic, potential, energy = energies(chain.params(damping=settings.damping), theta, omega)
    for name, expected in (("kinetic", kinetic), ("potential", potential), ("energy", energy)):
        assert relative(getattr(run, name), expected) <= tolerance, name
    if chain.pinned:
        assert relative(run.constraint_xy, joints[:, -1, :] - np.asarray(chain.pin)) <= tolerance
        assert relative(run.constraint_velocity, tip_velocity(L, theta, omega)) <= tolerance
    else:
        assert run.constraint_xy.shape == run.constraint_velocity.shape == (samples, 0)
    assert run.condition.shape == (samples,)
    if chain.pinned or n == 1:
        assert np.all(np.isfinite(run.condition))
    else:
        assert relative(run.condition, chain_side["cond"]) <= tolerance, "condition"
