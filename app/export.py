"""CSV and JSON of a session's run, with the column names of ``python -m physics`` (Trajectory.columns).

``history`` is a dict of arrays from the session's ring buffer (time along axis 0); ``params`` the
session's :class:`~app.parameters.SessionParameters`. Nothing here touches viser.
"""

from __future__ import annotations

import io
import json

import numpy as np


def columns(history: dict[str, np.ndarray], method: str, pinned: bool) -> dict[str, np.ndarray]:
    """Named 1-D columns: ``t, theta1..n, omega1..n, tip_x, tip_y, kinetic, potential, energy``, then joint
    reactions ``R0x, R0y, ...`` (every method: the DAE solves for them, the others recover them from the
    accelerations, physics/chain_reactions.py), then ``RHx, RHy, constraint_x, constraint_y`` (closed loops), then
    ``trace_x, trace_y``."""
    n = history["theta"].shape[1]
    cols = {"t": history["t"]}
    for i in range(n):
        cols[f"theta{i + 1}"] = history["theta"][:, i]
    for i in range(n):
        cols[f"omega{i + 1}"] = history["omega"][:, i]
    cols["tip_x"] = history["joints"][:, -1, 0]
    cols["tip_y"] = history["joints"][:, -1, 1]
    cols["kinetic"] = history["kinetic"]
    cols["potential"] = history["potential"]
    cols["energy"] = history["energy"]
    if "reactions" in history:
        for k in range(n):
            cols[f"R{k}x"] = history["reactions"][:, k, 0]
            cols[f"R{k}y"] = history["reactions"][:, k, 1]
    if pinned:
        cols["RHx"] = history["tip_reaction"][:, 0]
        cols["RHy"] = history["tip_reaction"][:, 1]
        cols["constraint_x"] = history["constraint_xy"][:, 0]
        cols["constraint_y"] = history["constraint_xy"][:, 1]
    cols["trace_x"] = history["trace_xy"][:, 0]
    cols["trace_y"] = history["trace_xy"][:, 1]
    return cols


def to_csv(history: dict[str, np.ndarray], params) -> bytes:
    cols = columns(history, params.method, params.pinned)
    table = np.column_stack(list(cols.values()))
    buffer = io.StringIO()
    buffer.write(",".join(cols) + "\n")
    np.savetxt(buffer, table, delimiter=",", fmt="%.10g")
    return buffer.getvalue().encode("utf-8")


def to_json(history: dict[str, np.ndarray], params, label: str = "") -> bytes:
    cols = columns(history, params.method, params.pinned)
    document = {
        "description": label,
        "parameters": params.as_dict(),
        "samples": int(len(history["t"])),
        "columns": {name: [float(v) for v in values] for name, values in cols.items()},
    }
    return json.dumps(document).encode("utf-8")
