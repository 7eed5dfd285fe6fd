"""The reduced one-degree-of-freedom model of a four-bar behind the common ``simulate`` interface.

``method = "reduced"`` integrates one independent angle with generalized coordinate partitioning (it
re-picks the best-conditioned coordinate at dead centres); ``"reduced_fixed"`` keeps theta1 and stops with a
clear message at its first dead centre, so the failure can be shown. The open-chain mass matrix and forcing
come from the generated Lagrange code; the tip reaction reported at each sample from the pinned Lagrange system.
"""

from __future__ import annotations

import numpy as np

from ..codegen import load_compiled
from ..errors import LinkageError
from ..reduced import simulate_reduced
from ..registry import METHODS
from ..status import Status
from .build import build_trajectory


def _mass_and_forcing_from(compiled):
    def mass_and_forcing(theta, omega, params):
        return compiled.matrix(theta, omega, params)

    return mass_and_forcing


def simulate_reduced_trajectory(chain, theta0, omega0, settings, t_start: float):
    if not chain.pinned or chain.n != 3:
        raise LinkageError(
            f"method = {settings.method}: the reduced model is for one-degree-of-freedom loops (a four-bar: 3 bars "
            f"with the tip pinned); this chain has {chain.n} bars{' and a pinned tip' if chain.pinned else ' and a free tip'}"
        )
    open_chain = load_compiled("lagrange", 3, False)
    t_eval = np.linspace(0.0, settings.t_end, settings.samples)
    result = simulate_reduced(
        chain.array("L"), chain.array("d"), chain.array("m"), chain.array("I"), chain.g, np.asarray(chain.pin),
        theta0, settings.t_end, t_eval=t_eval, rtol=settings.rtol, atol=settings.atol,
        switching=METHODS[settings.method].switches_branch, mass_and_forcing=_mass_and_forcing_from(open_chain),
        omega0=omega0, damping=settings.damping, t_offset=t_start,
    )
    y = np.concatenate([result.theta, result.omega], axis=1)
    pinned = load_compiled("lagrange", 3, True)
    params = chain.params(damping=settings.damping)
    trajectory = build_trajectory(chain, settings, pinned, params, result.t + t_start, y)
    trajectory.status = Status(result.status)
    trajectory.message = result.message if result.status != Status.OK else "ok"
    trajectory.n_rhs = int(result.nfev)
    trajectory.stats = {
        "n_switches": int(result.n_switches),
        "switch_times": [float(t) for t in result.switch_times],
        "independent_index": result.independent_index,
    }
    return trajectory
