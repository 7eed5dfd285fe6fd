"""A mechanism's run is a :class:`physics.Trajectory` (the one result type of every run); here its table, the
``mechanism`` command's CSV/JSON, the names of its coordinates and its named points."""

from __future__ import annotations

import io
import json
import math
from dataclasses import dataclass

import numpy as np

from ..errors import LinkageError
from ..simulate.trajectory import Trajectory
from .constraints import points_at_poses
from .description import GROUND


def coordinate_names(mechanism) -> tuple[str, ...]:
    """The names of a run's ``q`` columns: ``BODY.x, BODY.y, BODY.phi`` of every body, in order."""
    return tuple(f"{body.name}.{axis}" for body in mechanism.bodies for axis in ("x", "y", "phi"))


@dataclass(frozen=True)
class BodyPoints:
    """Every point a mechanism names, and where it is at any poses (a run's :attr:`Trajectory.point_names`).

    ``names[k]`` is ``BODY.POINT`` (every point of every body in the description's order: the drawing's labels,
    app/mechanism_runs.py) or, after them, ``ground.NAME``; ``body[k]`` is its body's number in ``q`` (-1 for the
    ground) and ``offset[k]`` its place from that body's centre of mass in the sketch (a ground point's: the point
    itself). Its path is :func:`~physics.mechanism.constraints.points_at_poses`, the kinematics the drawing and
    the traced point use, so a body point's path is exactly the drawing's. Tuples, not arrays: the run's
    per-sample arrays are sliced along their first axis (physics/long_run.py), and this is not one of them."""

    names: tuple[str, ...]
    body: tuple[int, ...]
    offset: tuple[tuple[float, float], ...]

    def paths(self, q: np.ndarray, count: int) -> np.ndarray:
        """The first ``count`` points at every pose of ``q (T, 3 B)`` -> ``(T, count, 2)``: :meth:`path` of each,
        the body points in one batched pass (a chunk's drawing: one call instead of one per point)."""
        q = np.asarray(q, dtype=float)
        out = np.empty((q.shape[0], count, 2))
        body = np.array(self.body[:count], dtype=int)
        offset = np.array(self.offset[:count], dtype=float).reshape(-1, 2)
        moving = body >= 0
        if moving.any():
            out[:, moving] = points_at_poses(q, body[moving], offset[moving])
        if not moving.all():
            out[:, ~moving] = offset[~moving]
        return out

    def path(self, q: np.ndarray, index: int) -> np.ndarray:
        """Point ``names[index]`` at every pose of ``q (T, 3 B)`` -> ``(T, 2)``."""
        q = np.asarray(q, dtype=float)
        if self.body[index] < 0:
            return np.tile(np.array(self.offset[index], dtype=float), (q.shape[0], 1))
        body = np.array(self.body[index : index + 1], dtype=int)
        return points_at_poses(q, body, np.array(self.offset[index : index + 1], dtype=float))[:, 0]


def body_points(mechanism) -> BodyPoints:
    """The named points of ``mechanism`` (see :class:`BodyPoints`)."""
    names: list[str] = []
    body: list[int] = []
    offset: list[tuple[float, float]] = []
    for number, item in enumerate(mechanism.bodies):
        centre_x, centre_y = item.centre
        for name, (x, y) in item.points.items():
            names.append(f"{item.name}.{name}")
            body.append(number)
            offset.append((float(x - centre_x), float(y - centre_y)))
    for name, (x, y) in mechanism.ground.items():
        names.append(f"{GROUND}.{name}")
        body.append(-1)
        offset.append((float(x), float(y)))
    return BodyPoints(tuple(names), tuple(body), tuple(offset))


def traced_path(points: BodyPoints, trace: str | None, q: np.ndarray) -> np.ndarray:
    """The run's ``trace_xy (T, 2)``: the path of the body point ``trace`` names, the same array
    :meth:`BodyPoints.path` gives for that name; NaN when the mechanism traces no body's point."""
    q = np.asarray(q, dtype=float)
    if trace is None or trace.startswith(f"{GROUND}.") or trace not in points.names:
        return np.full((q.shape[0], 2), math.nan)
    return points.path(q, points.names.index(trace))


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
    if not math.isfinite(float(array.sum())) and not np.all(np.isfinite(array)):  # a finite sum: all finite
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
