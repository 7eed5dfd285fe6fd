"""A chain hosted as a mechanism, handed out in the chain's own contracts: its history, downloads and snapshot.

Why: a chain run as ``physics.mechanism.chains.chain_mechanism(chain, theta_sketch, damping)`` through
:class:`app.mechanism_runs.MechanismSpec` stores a mechanism's ring (``q``, ``qdot``: x, y, phi of every bar's
centre of mass; every named point; the reaction rows by name), while scripts read a chain's downloads (the
columns of :func:`app.export.columns`: ``theta1..n``, ``R0x..``, ``RHx``, ``constraint_x``, ``trace_x``) and its
snapshot (docs/app.md). :func:`chain_history` maps the one onto the other, so the chain's own writers
(:mod:`app.export`, :func:`app.readout.run_download`, :func:`app.readout.snapshot_document`) write both kinds
with the same code. Pure numpy on the player's stored samples: no viser, no thread.

What comes from where:

* ``theta, omega`` and the reactions are the run's own, read by :func:`physics.mechanism.chains.chain_quantities`
  (absolute angles = the sketch's plus each bar's turn; pin ``O``, ``J1 .. J(n-1)`` are the chain's ``R_k``, the
  force ON bar k+1 BY bar k; pin ``H`` the tip's), its rows picked by name from the spec's ``row_names``.
* ``joints``, the traced point and ``constraint_xy`` are the chain's kinematics of those angles
  (:func:`physics.kinematics.joint_positions`, ``point_on_bar``), as the chain's run defines them: points reached
  from ``O`` along the bars, and the tip's gap to the pin ``H`` (the whole loop's closure, not pin ``H``'s row
  alone). The bodies' drawn points agree with them to the pins' residual. The traced point is the session's
  :class:`~physics.TracePoint` (a coupler point off the bars' named points too), never the ring's ``trace_xy``.
* The energies are the run's own (kinetic + potential of the bodies' poses).
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

from physics.kinematics import joint_positions, point_on_bar
from physics.mechanism.chains import chain_quantities

from . import readout
from .divergence import REFERENCE_LABEL
from .overlays import energy_scale, relative_drift
from .parameters import METHOD_LABELS, SessionParameters

# What one chain-shaped sample of a snapshot's run holds (app/readout.py, RUN_SAMPLE_FIELDS)
SNAPSHOT_FIELDS = readout.RUN_SAMPLE_FIELDS


def pin_names(n: int, pinned: bool) -> list[str]:
    """The pins of :func:`~physics.mechanism.chains.chain_mechanism` in the chain's reaction order."""
    return ["O"] + [f"J{k}" for k in range(1, n)] + (["H"] if pinned else [])


def reaction_rows(row_names: tuple[str, ...] | list[str], n: int, pinned: bool) -> np.ndarray:
    """Indices of the rows ``x`` then ``y`` of every pin (``O``, ``J1 .. J(n-1)``, then ``H``) among a run's
    ``row_names`` (``"O: x gap"``, ...), in the order :func:`chain_quantities` reads them; ValueError naming the
    pin when a run of another mechanism is given."""
    index: list[int] = []
    for pin in pin_names(n, pinned):
        rows = [k for k, name in enumerate(row_names) if name.split(":", 1)[0] == pin]
        if len(rows) != 2:
            raise ValueError(f"row_names: pin {pin} has {len(rows)} rows (expected its x and y rows); is this run "
                             f"the chain of {n} bars{' pinned at H' if pinned else ''}? rows: {list(row_names)}")
        index += rows
    return np.asarray(index, dtype=int)


def chain_history(samples: dict[str, np.ndarray], params: SessionParameters, theta_sketch,
                  row_names: tuple[str, ...] | list[str]) -> dict[str, np.ndarray]:
    """The chain-shaped history (app/buffers.py's chain fields) of a hosted chain's stored ``samples`` (the dict
    :func:`app.readout.history` returns for its MechanismSpec run), for ``params`` (the chain in force) drawn at
    ``theta_sketch``; ``row_names`` are the run's (``MechanismSpec.row_names``)."""
    chain = params.chain
    n, pinned = chain.n, chain.pinned
    theta_sketch = np.asarray(theta_sketch, dtype=float)
    if theta_sketch.shape != (n,):
        raise ValueError(f"theta_sketch: expected {n} angles (one per bar), got shape {theta_sketch.shape}")
    q = np.asarray(samples["q"], dtype=float)
    if q.ndim != 2 or q.shape[1] != 3 * n:
        raise ValueError(f"samples['q']: expected (T, {3 * n}) for a chain of {n} bars, got shape {q.shape}")
    t = np.asarray(samples["t"], dtype=float)
    rows = np.asarray(samples["reactions"], dtype=float)[:, reaction_rows(row_names, n, pinned)]
    run = _Run(t=t, q=q, qdot=np.asarray(samples["qdot"], dtype=float), reaction_rows=rows)
    theta, omega, reactions, tip = chain_quantities(chain, theta_sketch, run)
    L = np.asarray(params.L, dtype=float)
    joints = joint_positions(L, theta)
    trace = params.trace
    out = {
        "t": t,
        "theta": theta,
        "omega": omega,
        "joints": joints,
        "trace_xy": point_on_bar(L, theta, trace.bar, trace.along, trace.across).reshape(len(t), 2),
        "kinetic": np.asarray(samples["kinetic"], dtype=float),
        "potential": np.asarray(samples["potential"], dtype=float),
        "energy": np.asarray(samples["energy"], dtype=float),
        "reactions": reactions,
    }
    if pinned:
        out["tip_reaction"] = tip
        out["constraint_xy"] = joints[:, -1, :] - np.asarray(chain.pin, dtype=float)
    return out


class _Run:
    """The members of a mechanism run :func:`chain_quantities` reads (``t``, ``q``, ``qdot``, ``reaction_rows``)."""

    def __init__(self, t: np.ndarray, q: np.ndarray, qdot: np.ndarray, reaction_rows: np.ndarray) -> None:
        self.t, self.q, self.qdot, self.reaction_rows = t, q, qdot, reaction_rows


def run_label(params: SessionParameters) -> str:
    """The JSON download's ``description`` of a chain's run (the method and the integrator as the menu words them)."""
    return f"{params.preset} ({params.n} bars), {METHOD_LABELS.get(params.method, params.method)}, {params.integrator}"


def download_file(player, label: str, params: SessionParameters, theta_sketch, row_names, kind: str) -> tuple[str, bytes]:
    """``(file name, content)`` of a hosted chain's download, the chain session's own (``csv``, ``json``,
    ``html``, ``setup``, ``tex``: :func:`app.readout.run_download`), from run ``label`` of ``player``."""
    def history() -> dict[str, np.ndarray]:
        return chain_history(readout.history(player, label), params, theta_sketch, row_names)

    return readout.run_download(params, kind, history, run_label(params))


def sample_reader(params: SessionParameters, theta_sketch) -> Callable[[Any, int], dict[str, np.ndarray] | None]:
    """``sample_of(run, i)`` for :func:`app.readout.snapshot_document`: stored sample ``i`` of a hosted chain's
    run in the chain's fields (the same mapping as the downloads', on one sample); None for a run of the
    mechanism being replaced (the menu chose this chain: the player installs its runs at its next wake)."""
    def sample_of(run, i: int) -> dict[str, np.ndarray] | None:
        try:
            mapped = chain_history(run.ring.window(i, i), params, theta_sketch, run.spec.row_names)
        except ValueError:  # another mechanism's layout (chain_history names it): not this chain's run
            return None
        return {name: value[0] for name, value in mapped.items() if name != "t"}

    return sample_of


def energy_values(sample: dict[str, np.ndarray], params: SessionParameters, reference: float) -> dict:
    """The snapshot's ``energy`` of one chain-shaped sample (docs/app.md lists its keys):
    kinetic, potential, total, the reference energy, the relative drift from it and, pinned, the loop's gap."""
    energy = float(sample["energy"])
    scale = energy_scale(params.chain.array("m"), params.chain.array("L"), params.chain.g)
    out = {
        "kinetic": float(sample["kinetic"]),
        "potential": float(sample["potential"]),
        "total": energy,
        "reference": reference,
        "relative_drift": float(relative_drift(np.array([energy]), reference, scale)[0]),
    }
    if params.pinned:
        out["constraint_error"] = float(np.hypot(*sample["constraint_xy"]))
    return out


def snapshot(*, session_id: int | str, shared: bool, params: SessionParameters, theta_sketch, compare: bool, player,
             notice: str | None, energy_reference: float | None, frames_sent: Callable[[], int],
             scene: Callable[[], dict], since: float | None = None) -> dict:
    """A hosted chain's JSON snapshot with the chain session's keys (docs/app.md), written by the chain's own
    :func:`app.readout.snapshot_document`. ``energy_reference``: the energy the drift is measured from (None:
    the stored sample's at time ``since``, the last change, as the chain view measures it; no ``since``: the
    first stored sample's); ``frames_sent`` and ``scene`` (``{"root": ..., "nodes": {...}}``) are the
    hosting session's view's, read under the player's lock."""
    sample_of = sample_reader(params, theta_sketch)

    def energy(runs: dict) -> dict:
        run = next((r for r in player.runs if r.spec.label != REFERENCE_LABEL and len(r.ring)), None)
        if run is None:
            return {}
        sample = sample_of(run, run.ring.index_at(player.display_time))
        if sample is None:
            return {}
        if energy_reference is not None:
            reference = float(energy_reference)
        else:
            reference = float(run.ring.get("energy", 0 if since is None else run.ring.index_at(since)))
        return energy_values(sample, params, reference)

    return readout.snapshot_document(
        session_id=session_id, shared=shared, params=params, compare=compare, player=player, notice=notice,
        sample_of=sample_of, energy=energy, frames_sent=frames_sent, scene=scene)


def chain_part_sources(root: str, n: int) -> dict[str, str]:
    """The chain's part names (``joint_k``, ``ground``) and the hosted drawing's part each is
    (:meth:`app.mechanism_scene.MechanismScene.parts`): bar 1's proximal point, bar k's distal point, the first
    ground block."""
    sources = {f"{root}/joint_{k}": f"{root}/point/bar1.P" if k == 0 else f"{root}/point/bar{k}.D"
               for k in range(n + 1)}
    sources[f"{root}/ground"] = f"{root}/ground_0"
    return sources


def chain_scene(nodes: dict[str, dict], root: str, n: int, trace) -> dict[str, dict]:
    """The scene's parts under the chain's names (docs/app.md): ``joint_0`` the ground pin O (bar 1's proximal
    point), ``joint_k`` bar k's distal point (the tip is ``joint_n``), ``com_k``, ``bar_k``, ``ground`` (the pivot's
    block) and ``trace`` (whether the traced point's line is shown, and how many points it holds). The hosted
    chain's drawing names them by body point (:meth:`app.mechanism_scene.MechanismScene.poses`)."""
    named = {name: pose for name, pose in nodes.items() if "/point/" not in name and "/ground_" not in name}
    for chain_name, source in chain_part_sources(root, n).items():
        if source in nodes:
            named[chain_name] = nodes[source]
    named[f"{root}/trace"] = {"visible": bool(getattr(trace, "points_shown", 0)),
                              "points": int(getattr(trace, "points_shown", 0))}
    return named

