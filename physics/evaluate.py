"""``accelerations``: the equations of motion evaluated at one state, in the CLI's JSON shape."""

from __future__ import annotations

import numpy as np

from .errors import LinkageError
from .kernels.constants import SINGULAR_PIVOT_RATIO
from .model import Chain, check_state
from .simulate.chain_system import chain_system


def accelerations(chain: Chain, theta, omega, method: str, damping: float = 0.0) -> dict:
    """``{"method", "links", "theta_ddot", ["joint_reactions"], ["tip_reaction"], "condition"}``.

    ``joint_reactions`` (dae only): entry k is the force ON bar k+1 BY the ground (k = 0) or by bar k.
    ``tip_reaction`` (pinned chains, every method): the force ON the last bar BY the ground at the tip.
    Raises LinkageError at a singular configuration instead of returning meaningless numbers.
    """
    theta, omega = check_state(chain.n, theta, omega)
    # the system physics.simulate integrates: the chain written as a mechanism
    system = chain_system(chain, method, damping)
    x, cond = system.solve(theta, omega)
    if not cond <= SINGULAR_PIVOT_RATIO or not np.all(np.isfinite(x)):
        raise LinkageError(
            f"singular configuration at theta = {np.round(theta, 6).tolist()}: the {method} system has pivot ratio "
            f"{cond:.3g} (limit {SINGULAR_PIVOT_RATIO:.0e}, condition number near its square); the links are lined up (a dead-centre or "
            f"change-point position) or a bar has no inertia"
        )
    result = {
        "method": method,
        "links": chain.n,
        "theta_ddot": [float(v) for v in x[system.theta_ddot_index]],
    }
    if system.reaction_index.size:
        result["joint_reactions"] = [[float(x[i]), float(x[j])] for i, j in system.reaction_index]
    if system.tip_reaction_index.size:
        result["tip_reaction"] = [float(v) for v in x[system.tip_reaction_index]]
    elif chain.pinned:  # a tree formulation on the mechanism engine closes the loop at another joint
        result["tip_reaction"] = [float(v) for v in system.tip_reactions(chain, theta, omega)[0]]
    result["condition"] = float(cond)
    return result
