"""A chain's reduced one-degree-of-freedom model behind the common ``simulate`` interface: the general reduced
model of :mod:`physics.mechanism.reduced`, run on the chain written as a mechanism.

A pinned three-bar chain (a four-bar) has mobility 1. It is drawn as a mechanism at its start angles
(:func:`physics.mechanism.chains.chain_mechanism`: bars ``bar1..bar3``, pins ``O``, ``J1``, ``J2`` and the tip's
``H``; the chain's damping on ``O``, ``J1``, ``J2`` as the chain's Rayleigh function has it) and integrated in one
joint coordinate on the compiled engine. ``method = "reduced"`` switches the coordinate before each dead centre
(generalized coordinate partitioning); ``"reduced_fixed"`` keeps joint ``O``, whose coordinate is theta1, and
stops with a clear message at its first dead centre, so the failure can be shown. The samples come back in the
chain's terms: absolute angles and rates from the body angles, and the Trajectory (energies, tip reaction, joint
reactions, condition) that the mechanism route makes from them with the pinned Lagrange system (through
:func:`physics.simulate.chain_system.chain_system`), as for every other method.

``stats``: ``n_switches`` and ``switch_times`` (the coordinate switches) and ``independent_index`` (T,): the
joint integrated at each sample, numbered in the chain's joint order (:data:`CHAIN_JOINTS`: 0 is ``O``, the
ground pivot, whose coordinate is theta1; 1 and 2 the bar-to-bar joints, relative angles; 3 the tip's pin,
whose coordinate is theta3; -1 for a run stopped at its start). docs/closed-loops.md, section 5.
"""

from __future__ import annotations

import numpy as np

from ..errors import LinkageError
from ..mechanism.chains import chain_mechanism, chain_state
from ..mechanism.reduced import DEAD_CENTRE_SHARE, DeadCentre, ReducedStop, reduced_run
from ..registry import METHODS
from ..status import Status
from .chain_system import chain_system

# The joints of a four-bar written as a mechanism, in the order ``independent_index`` numbers them.
CHAIN_JOINTS = ("O", "J1", "J2", "H")
# The joint reduced_fixed keeps: the ground pivot, whose coordinate is the crank angle theta1.
FIXED_JOINT = "O"
# The speed share below which the four-bar's coordinate is switched (physics.mechanism.reduced.SWITCH_SHARE is
# 0.1): the dependent angles then move at most 2.5 times faster than the coordinate, so the integrator's error
# in it grows at most that much in them. Measured on the seed four-bar from 7 starts over 20 s (rtol = atol =
# 1e-8, 1e-10, 1e-12): at 0.1 the angles came out 4.6, 2.5 and 6.8 times further from a 1e-14 reference than the
# absolute-angle model's at the same tolerances, at 0.4 as close (2.1, 0.6, 0.8 times), for as many switches and
# right-hand sides.
CHAIN_SWITCH_SHARE = 0.4


def simulate_reduced_trajectory(chain, theta0, omega0, settings, t_start: float, build=None):
    """The reduced model's run of a four-bar as a chain's Trajectory. ``build(chain, settings, t, y)``: what
    reads its samples ``y = [theta, omega]`` (default the pinned Lagrange system,
    :func:`physics.simulate.chain_system.chain_system`)."""
    build = _trajectory if build is None else build
    if not chain.pinned or chain.n != 3:
        raise LinkageError(
            f"method = {settings.method}: the reduced model is for one-degree-of-freedom loops (a four-bar: 3 bars "
            f"with the tip pinned); this chain has {chain.n} bars{' and a pinned tip' if chain.pinned else ' and a free tip'}"
        )
    theta0 = np.asarray(theta0, dtype=float)
    mechanism = chain_mechanism(chain, theta0, damping=settings.damping)
    _, qdot0 = chain_state(chain, theta0, theta0, omega0)
    times = t_start + np.linspace(0.0, settings.t_end, settings.samples)
    switching = METHODS[settings.method].switches_branch
    try:
        reduced = reduced_run(mechanism, times, rtol=settings.rtol, atol=settings.atol, qdot0=qdot0,
                              coordinate=None if switching else FIXED_JOINT, switching=switching,
                              stop_as_status=True, switch_share=CHAIN_SWITCH_SHARE)
    except (LinkageError, np.linalg.LinAlgError) as stop:  # the start itself cannot be integrated (a singular
        # pose: the chain and its settings were checked before); the start is reported, as a chain's run does
        return _stopped_at_start(chain, settings, theta0, omega0, t_start, stop, mechanism.name, build)
    run = reduced.run
    theta = run.q[:, 2::3] + theta0  # body angles are measured from the sketch, drawn at theta0
    y = np.concatenate([theta, run.qdot[:, 2::3]], axis=1)
    trajectory = build(chain, settings, run.t, y)
    trajectory.status = Status(run.status)
    if run.status == Status.OK:
        trajectory.message = "ok"
    elif reduced.dead_centre is not None:
        trajectory.message = fixed_coordinate_message(reduced.dead_centre)
    else:
        trajectory.message = run.message.removeprefix(f"{mechanism.name}: ")  # the chain's runs name no mechanism
    trajectory.n_steps = int(run.n_steps)
    trajectory.n_rhs = int(run.n_rhs)
    trajectory.stats = {
        "n_switches": len(reduced.switches),
        "switch_times": [float(switch.t) for switch in reduced.switches],
        "independent_index": np.array([CHAIN_JOINTS.index(name) for name in reduced.coordinate], dtype=int),
    }
    return trajectory


def fixed_coordinate_message(dead_centre: DeadCentre) -> str:
    """The chain's sentence for the kept coordinate's dead centre, naming the fix (the switching method)."""
    # theta1 stands still while the loop moves where bars 2 and 3 are in line (the four-bar's "fold")
    named = "theta1" if dead_centre.joint == FIXED_JOINT else f"joint {dead_centre.joint!r}"
    why = "bars 2 and 3 became collinear" if dead_centre.joint == FIXED_JOINT else "it stood still"
    return (f"{named} stopped being a valid coordinate at t = {dead_centre.t:.6g} s: {why} (a dead centre: its speed "
            f"share fell to {dead_centre.share:.2g}, limit {DEAD_CENTRE_SHARE:g}); the fixed-coordinate reduced model "
            f"cannot continue past it, choose method 'reduced', which switches coordinates (generalized coordinate "
            f"partitioning)")


def _trajectory(chain, settings, t, y):
    """The samples read by the pinned Lagrange system (:func:`chain_system`): the chain written as a mechanism
    (its state in the spanning tree's order)."""
    system = chain_system(chain, "lagrange", settings.damping, float(t[0]) if len(t) else 0.0)
    n = chain.n
    return system.trajectory(chain, settings, t, system.state(y[:, :n], y[:, n:]))


def _stopped_at_start(chain, settings, theta0, omega0, t_start, stop: Exception, mechanism_name: str, build):
    """The start alone, with the reason: a stop of the model (its status), or a start that does not assemble as a
    mechanism of mobility 1 (every bar in line: the constraints are dependent, a singular pose)."""
    trajectory = build(chain, settings, np.array([t_start]), np.concatenate([theta0, omega0])[None, :])
    if isinstance(stop, ReducedStop):
        trajectory.status = Status(stop.status)
        trajectory.message = (fixed_coordinate_message(stop.dead_centre) if stop.dead_centre
                              else str(stop).removeprefix(f"{mechanism_name}: "))
    else:
        trajectory.status = Status.SINGULAR
        # the chain closes its loop (checked before) and its settings are valid: what assembly refuses here is
        # a pose whose constraints are dependent (its wording, for a mechanism, names a redundant joint)
        trajectory.message = (f"singular pose at t = {t_start:.6g} s: the loop's constraints are dependent there "
                              f"(its bars in line), so no joint is a coordinate the reduced model can start in")
    trajectory.stats = {"n_switches": 0, "switch_times": [], "independent_index": np.full(1, -1)}
    return trajectory
