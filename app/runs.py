"""What the player keeps and hands out: run descriptions, stored runs, frames, and samples from trajectories.

Plain data and pure functions (no thread, no viser): :class:`~app.player.Player` drives them, the frame view
and the read-outs read them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, ClassVar

import numpy as np

from physics import Chain, Settings, energies, joint_positions
from physics.kinematics import point_on_bar

from .buffers import TrajectoryRing

FIRST_CHUNK_SECONDS = 0.25  # short first chunk after a restart, so the first new pose comes quickly


@dataclass
class RunSpec:
    """What one run simulates: a validated chain, settings (``t_end``/``samples`` are set per chunk), a label.

    The player reaches the run's model only through the members below, which a general mechanism's run
    (:class:`app.mechanism_runs.MechanismSpec`) implements too: the ring's layout and fields, the state's field
    names, a chunk's samples, a sample from kinematics alone, and the simulating function (None: the player's
    injected ``physics.simulate``)."""

    label: str
    chain: Chain
    settings: Settings

    state_fields: ClassVar[tuple[str, str]] = ("theta", "omega")  # the ring's fields a chunk continues from
    simulate: ClassVar[Callable | None] = None  # None: the player's own (physics.simulate, injected for tests)

    @property
    def n(self) -> int:
        return self.chain.n

    @property
    def pinned(self) -> bool:
        return self.chain.pinned

    @property
    def work_n(self) -> int:
        """The chain length the player's chunk budget is scaled for (app/player.py, next_chunk_seconds)."""
        return self.n

    @property
    def layout(self) -> tuple:
        """Runs with equal layouts can share a ring (a parameter change keeps the history)."""
        return ("chain", self.n, self.pinned)

    def new_ring(self, capacity: int, dt: float) -> TrajectoryRing:
        return TrajectoryRing(self.n, self.pinned, capacity, dt)

    def com_ratio(self) -> np.ndarray:
        return com_ratio(self.chain)

    def chunk(self, traj) -> dict[str, np.ndarray]:
        return chunk_dict(traj, self.n, self.pinned)

    def still_sample(self, t0: float, theta0: np.ndarray, omega0: np.ndarray) -> dict[str, np.ndarray]:
        return kinematic_sample(self, t0, theta0, omega0)


@dataclass
class Run:
    spec: RunSpec
    ring: TrajectoryRing
    com_ratio: np.ndarray  # d / L per bar (0 where L = 0): centre of mass between its joints
    failed: str | None = None  # message of a failed chunk: no samples will follow the last stored one
    chunk_seconds: float = FIRST_CHUNK_SECONDS
    compute_seconds: float = 0.0  # CPU time spent simulating (for the status line)
    simulated_seconds: float = 0.0
    step_cap: int | None = None  # integrator steps one call may take (app/player.py, CHUNK_STEP_CAP); None: the first


@dataclass
class RunFrame:
    label: str
    index: int  # logical ring index of the sample at or before the displayed time
    joints: np.ndarray  # (n+1, 2), interpolated to the displayed time
    com: np.ndarray  # (n, 2)


@dataclass
class Frame:
    t: float
    runs: list[RunFrame]
    restarted: bool = False  # first frame after a restart (the latency probe)
    request_time: float | None = None
    counter: int = 0


@dataclass
class Restart:
    specs: list[RunSpec]
    t0: float
    starts: list[tuple[np.ndarray, np.ndarray]]
    keep_history: bool
    requested_at: float
    play: bool | None = None


def com_ratio(chain) -> np.ndarray:
    L = np.array([b.L for b in chain.bars], dtype=float)
    d = np.array([b.d for b in chain.bars], dtype=float)
    return np.divide(d, L, out=np.zeros_like(d), where=L > 0)


def chunk_dict(traj, n: int, pinned: bool) -> dict[str, np.ndarray]:
    """The ring's fields from a physics Trajectory (joint reactions for every method: physics/chain_reactions.py)."""
    out = {
        "t": traj.t,
        "theta": traj.theta,
        "omega": traj.omega,
        "joints": traj.joints,
        "trace_xy": traj.trace_xy,
        "kinetic": traj.kinetic,
        "potential": traj.potential,
        "energy": traj.energy,
    }
    if traj.joint_reactions.shape[1:] == (n, 2):  # every method's (physics/chain_reactions.py)
        out["reactions"] = traj.joint_reactions
    if pinned:
        if traj.constraint_xy.shape[1:] == (2,):
            out["constraint_xy"] = traj.constraint_xy
        if traj.tip_reaction.shape[1:] == (2,):
            out["tip_reaction"] = traj.tip_reaction
    return out


def kinematic_sample(spec: RunSpec, t0: float, theta0: np.ndarray, omega0: np.ndarray) -> dict[str, np.ndarray]:
    """One sample from positions and velocities alone (no dynamics): what a failed start looks like."""
    chain = spec.chain
    L = np.array([b.L for b in chain.bars], dtype=float)
    theta = np.where(np.isfinite(theta0), theta0, 0.0)
    omega = np.where(np.isfinite(omega0), omega0, 0.0)
    kinetic, potential, total = energies(chain.params(), theta, omega)
    trace = spec.settings.trace
    if trace is not None:
        trace_xy = point_on_bar(L, theta, trace.bar, trace.along, trace.across)
    else:
        trace_xy = joint_positions(L, theta)[-1]
    return {
        "t": np.array([t0]),
        "theta": theta[None, :],
        "omega": omega[None, :],
        "joints": joint_positions(L, theta)[None],
        "trace_xy": np.asarray(trace_xy)[None, :],
        "kinetic": np.array([kinetic]),
        "potential": np.array([potential]),
        "energy": np.array([total]),
    }


def finite_prefix(chunk: dict[str, np.ndarray], fields: tuple[str, str] = ("theta", "omega")) -> int:
    """Number of leading samples whose state (the two ``fields``) is finite."""
    x_name, v_name = fields
    ok = np.all(np.isfinite(chunk[x_name]), axis=1) & np.all(np.isfinite(chunk[v_name]), axis=1)
    bad = np.flatnonzero(~ok)
    return int(bad[0]) if bad.size else len(ok)
