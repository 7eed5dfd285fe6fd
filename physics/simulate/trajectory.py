"""Trajectory: what a simulation returns, sampled at the requested times, and its table form for CSV/JSON."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..status import Status


@dataclass
class Trajectory:
    """Samples along axis 0. Shapes: t (T,), theta/omega (T, n), joints (T, n+1, 2), tip_xy/trace_xy (T, 2),
    energies (T,), reactions (T, n, 2) for dae else (T, 0, 2), tip_reaction (T, 2) for pinned chains else
    (T, 0), constraint_xy / constraint_velocity (T, 2) for pinned chains else (T, 0), condition (T,)."""

    method: str
    integrator: str
    t: np.ndarray
    theta: np.ndarray
    omega: np.ndarray
    joints: np.ndarray
    tip_xy: np.ndarray
    trace_xy: np.ndarray
    kinetic: np.ndarray
    potential: np.ndarray
    energy: np.ndarray
    reactions: np.ndarray
    tip_reaction: np.ndarray
    constraint_xy: np.ndarray
    constraint_velocity: np.ndarray
    condition: np.ndarray
    status: int = Status.OK  # a Status value (0 ok, < 0 failed midway)
    message: str = ""
    n_steps: int = 0
    n_rhs: int = 0
    stats: dict = field(default_factory=dict)
    # (T, n, 2) for every method: from the accelerations by Newton's law per bar (physics/reactions.py),
    # equal to the DAE's own ``reactions`` where it has them; not part of the CSV/JSON columns.
    joint_reactions: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 2)))
    trace_is_explicit: bool = False  # open chains list trace_x/y only when a point other than the tip was asked

    @property
    def success(self) -> bool:
        return self.status == Status.OK

    def __repr__(self) -> str:
        """One line for a notebook or a log (the dataclass's own repr printed every array: 48,777 characters
        for 201 samples); the arrays stay on the attributes and in :meth:`columns`."""
        try:
            status = Status(self.status).name.lower()
        except ValueError:
            status = str(self.status)
        extra = f", message={self.message!r}" if self.message and status != "ok" else ""
        return (f"Trajectory(method={self.method!r}, integrator={self.integrator!r}, links={self.n}, "
                f"samples={self.t.shape[0]}, t={time_span(self.t)}, status={status}{extra})")

    @property
    def n(self) -> int:
        return self.theta.shape[1]

    def energy_drift(self) -> float:
        """max |E(t) - E(0)| / max(|E(0)|, scale), scale = the largest of |T|, |V| seen (so E(0) = 0 is fine)."""
        if self.energy.size == 0:
            return 0.0
        scale = max(abs(self.energy[0]), np.max(np.abs(self.kinetic)), np.max(np.abs(self.potential)), 1e-300)
        return float(np.max(np.abs(self.energy - self.energy[0])) / scale)

    def columns(self) -> dict[str, np.ndarray]:
        """Named 1-D columns: the CSV header and the JSON keys (the CLI contract).

        ``t, theta1..n, omega1..n, tip_x, tip_y, kinetic, potential, energy``, then ``R0x, R0y, ...`` for dae,
        then for a pinned chain ``RHx, RHy, constraint_x, constraint_y, constraint_vx, constraint_vy`` and
        ``trace_x, trace_y`` (the traced point; open chains add it only when a trace point was given)."""
        n = self.n
        cols = {"t": self.t}
        for i in range(n):
            cols[f"theta{i + 1}"] = self.theta[:, i]
        for i in range(n):
            cols[f"omega{i + 1}"] = self.omega[:, i]
        cols["tip_x"] = self.tip_xy[:, 0]
        cols["tip_y"] = self.tip_xy[:, 1]
        cols["kinetic"] = self.kinetic
        cols["potential"] = self.potential
        cols["energy"] = self.energy
        for k in range(self.reactions.shape[1]):
            cols[f"R{k}x"] = self.reactions[:, k, 0]
            cols[f"R{k}y"] = self.reactions[:, k, 1]
        if self.tip_reaction.shape[1] == 2:
            cols["RHx"] = self.tip_reaction[:, 0]
            cols["RHy"] = self.tip_reaction[:, 1]
        if self.constraint_xy.shape[1] == 2:
            cols["constraint_x"] = self.constraint_xy[:, 0]
            cols["constraint_y"] = self.constraint_xy[:, 1]
            cols["constraint_vx"] = self.constraint_velocity[:, 0]
            cols["constraint_vy"] = self.constraint_velocity[:, 1]
        if self.trace_is_explicit or self.constraint_xy.shape[1] == 2:
            cols["trace_x"] = self.trace_xy[:, 0]
            cols["trace_y"] = self.trace_xy[:, 1]
        return cols


def time_span(t: np.ndarray) -> str:
    """``0..20 s`` for the reprs of run results; ``none`` when there are no samples."""
    return f"{float(t[0]):g}..{float(t[-1]):g} s" if t.size else "none"
