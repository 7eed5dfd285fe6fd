"""The samples of a mechanism's run, whichever model produced them (:mod:`.simulate`, :mod:`.reduced`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class MechanismRun:
    """Samples of a run: ``t (T,)``, ``q, qdot (T, 3 B)``, ``reactions (T, rows)``, ``kinetic, potential
    (T,)``, ``residual (T,)`` (largest constraint residual), ``trace_xy (T, 2)`` (the traced point, if any),
    ``condition (T,)`` (how near each pose is to a singular one)."""

    t: np.ndarray
    q: np.ndarray
    qdot: np.ndarray
    reactions: np.ndarray
    kinetic: np.ndarray
    potential: np.ndarray
    residual: np.ndarray
    trace_xy: np.ndarray
    row_names: tuple[str, ...]
    method: str = "dae"  # the formulation integrated and whose reactions these are
    stabilization: str = "projection"
    integrated: bool = True  # False: every sample by position analysis (the motors fix every body)
    steps: int = 0  # accepted integration steps
    evaluations: int = 0  # right-hand sides evaluated
    # (T,) condition of the constraint Jacobian at each sample (physics/mechanism/singularity.py); empty for
    # the reduced model's runs, whose positions come from position analysis
    condition: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def energy(self) -> np.ndarray:
        return self.kinetic + self.potential
