"""A mechanism's run is a :class:`physics.Trajectory` (the one result type of every run); here its table, the
``mechanism`` command's CSV/JSON, and the names of its coordinates."""

from __future__ import annotations

import io
import json

import numpy as np

from ..errors import LinkageError
from ..simulate.trajectory import Trajectory


def coordinate_names(mechanism) -> tuple[str, ...]:
    """The names of a run's ``q`` columns: ``BODY.x, BODY.y, BODY.phi`` of every body, in order."""
    return tuple(f"{body.name}.{axis}" for body in mechanism.bodies for axis in ("x", "y", "phi"))


def state_vector(value, name: str, size: int) -> np.ndarray | None:
    """A run's start ``q0`` or ``qdot0`` (``name``) as a float array of ``size`` finite numbers (x, y, phi per
    body, or their rates), or None; else LinkageError, one line naming it and what it got."""
    if value is None:
        return None
    expected = f"{name}: expected {size} finite numbers (x, y, phi of each body's centre of mass)"
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise LinkageError(f"{expected}, got a {type(value).__name__}") from None
    if array.shape != (size,):
        raise LinkageError(f"{expected}, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise LinkageError(f"{expected}, got a non-finite entry")
    return array


def run_table(run: Trajectory, fmt: str = "csv") -> bytes:
    """The run as CSV (``fmt = "csv"``) or as JSON with the same names as keys of arrays (``"json"``; a missing
    traced point, NaN in the CSV, is ``null``): the one writer of a mechanism's samples, for ``mechanism``,
    ``simulate`` and the app's downloads. The columns are :meth:`Trajectory.columns`: ``t``, the traced point,
    the energies, the largest constraint residual and every reaction row as ``lambda[JOINT: row]`` (the names
    scripts read; docs/mechanisms.md)."""
    columns = run.columns()
    if fmt == "json":
        document = {name: [float(v) if np.isfinite(v) else None for v in values] for name, values in columns.items()}
        return (json.dumps(document, allow_nan=False) + "\n").encode("utf-8")
    buffer = io.StringIO()
    buffer.write(",".join(f'"{name}"' if "," in name or ":" in name else name for name in columns) + "\n")
    np.savetxt(buffer, np.column_stack(list(columns.values())), delimiter=",", fmt="%.17g")
    return buffer.getvalue().encode("utf-8")
