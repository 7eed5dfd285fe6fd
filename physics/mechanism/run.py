"""The samples of a mechanism's run, whichever model produced them (:mod:`.simulate`, :mod:`.reduced`)."""

from __future__ import annotations

import io
import json
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class MechanismRun:
    """Samples of a run (up to where it stopped, if it did: ``status``, ``message``): ``t (T,)``, ``q, qdot (T, 3 B)``, ``reactions (T, rows)``, ``kinetic, potential
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
    # the integrator that produced the samples (physics.registry.INTEGRATORS), "position analysis" when the
    # motors fix every body and nothing is integrated
    integrator: str = "DOP853"
    # how the run ended (physics.status.Status, as a chain's Trajectory): 0 ok, < 0 stopped midway, with the
    # samples up to the stop and ``message`` the sentence that names why and the fix
    status: int = 0
    message: str = "ok"

    @property
    def success(self) -> bool:
        return self.status == 0

    @property
    def n_steps(self) -> int:
        """Accepted integration steps (a chain Trajectory's name for ``steps``)."""
        return self.steps

    @property
    def n_rhs(self) -> int:
        """Right-hand sides evaluated (a chain Trajectory's name for ``evaluations``)."""
        return self.evaluations

    @property
    def energy(self) -> np.ndarray:
        return self.kinetic + self.potential

    def __repr__(self) -> str:
        """One line for a notebook or a log, not every array (those stay on the attributes)."""
        span = f"{float(self.t[0]):g}..{float(self.t[-1]):g} s" if self.t.size else "none"
        how = (f"integrator={self.integrator!r}, stabilization={self.stabilization!r}, steps={self.steps}"
               if self.integrated else "position analysis")
        if self.status != 0:
            how += f", status={self.status}"
        return (f"MechanismRun(method={self.method!r}, bodies={self.q.shape[1] // 3 if self.q.ndim == 2 else 0}, "
                f"samples={self.t.shape[0]}, t={span}, {how})")


def run_columns(run: MechanismRun) -> dict[str, np.ndarray]:
    """The columns of a run's table, in order: ``t``, the traced point, the energies, the largest constraint
    residual and every reaction row as ``lambda[JOINT: row]`` (the names scripts read; docs/mechanisms.md)."""
    columns = {"t": run.t, "trace_x": run.trace_xy[:, 0], "trace_y": run.trace_xy[:, 1], "kinetic": run.kinetic,
               "potential": run.potential, "energy": run.energy, "constraint_residual": run.residual}
    for k, name in enumerate(run.row_names):
        columns[f"lambda[{name}]"] = run.reactions[:, k]
    return columns


def run_table(run: MechanismRun, fmt: str = "csv") -> bytes:
    """The run as CSV (``fmt = "csv"``) or as JSON with the same names as keys of arrays (``"json"``; a missing
    traced point, NaN in the CSV, is ``null``): the one writer of a mechanism's samples, for ``mechanism``,
    ``simulate`` and the app's downloads."""
    columns = run_columns(run)
    if fmt == "json":
        document = {name: [float(v) if np.isfinite(v) else None for v in values] for name, values in columns.items()}
        return (json.dumps(document, allow_nan=False) + "\n").encode("utf-8")
    buffer = io.StringIO()
    buffer.write(",".join(f'"{name}"' if "," in name or ":" in name else name for name in columns) + "\n")
    np.savetxt(buffer, np.column_stack(list(columns.values())), delimiter=",", fmt="%.17g")
    return buffer.getvalue().encode("utf-8")
