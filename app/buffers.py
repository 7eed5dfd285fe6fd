"""Bounded storage of simulated samples: what a session has computed, displayed and may export.

A session never keeps more than ``capacity`` samples, so its memory does not grow with run time; the
oldest samples are dropped first. Samples sit on one uniform time grid (``dt`` apart): every chunk of
simulation starts at a stored sample, so the index of a time is plain arithmetic.
"""

from __future__ import annotations

import numpy as np


# Fields of a sample and their shape after the time axis; n = number of bars.
def _fields(n: int, pinned: bool) -> dict[str, tuple[int, ...]]:
    fields = {
        "t": (),
        "theta": (n,),
        "omega": (n,),
        "joints": (n + 1, 2),
        "trace_xy": (2,),
        "kinetic": (),
        "potential": (),
        "energy": (),
        "reactions": (n, 2),
    }
    if pinned:
        fields["constraint_xy"] = (2,)
        fields["tip_reaction"] = (2,)
    return fields


class TrajectoryRing:
    """Fixed-capacity ring of samples with uniform spacing ``dt``.

    ``append(chunk)`` adds samples at the newest end (dropping the oldest beyond capacity);
    ``truncate_after(t)`` forgets everything later than ``t`` (a restart from the state at ``t``).
    Arrays returned by :meth:`window` are copies in time order.
    """

    def __init__(self, n: int, pinned: bool, capacity: int, dt: float,
                 fields: dict[str, tuple[int, ...]] | None = None) -> None:
        if capacity < 2:
            raise ValueError(f"capacity = {capacity}: need at least 2 samples")
        self.n, self.pinned, self.capacity, self.dt = n, pinned, capacity, dt
        shapes = _fields(n, pinned) if fields is None else {"t": (), **fields}  # a mechanism's own fields
        self._data = {name: np.zeros((capacity,) + shape) for name, shape in shapes.items()}
        self._start = 0  # physical index of the oldest sample
        self._count = 0

    # ---------------------------------------------------------------- size and time
    def __len__(self) -> int:
        return self._count

    @property
    def nbytes(self) -> int:
        return sum(a.nbytes for a in self._data.values())

    def _phys(self, i):
        return (self._start + i) % self.capacity

    @property
    def t_first(self) -> float:
        return float(self._data["t"][self._phys(0)]) if self._count else 0.0

    @property
    def t_last(self) -> float:
        return float(self._data["t"][self._phys(self._count - 1)]) if self._count else 0.0

    def index_at(self, t: float) -> int:
        """Logical index of the last sample at or before ``t`` (clamped to the stored range)."""
        if not self._count:
            raise IndexError("empty ring")
        i = int(np.floor((t - self.t_first) / self.dt + 1e-6))
        return min(max(i, 0), self._count - 1)

    # ---------------------------------------------------------------- writing
    def clear(self) -> None:
        self._start = 0
        self._count = 0

    def append(self, chunk: dict[str, np.ndarray]) -> None:
        """Append samples (time along axis 0). Missing fields are stored as zeros."""
        m = len(chunk["t"])
        if m == 0:
            return
        if m > self.capacity:  # keep only the newest samples
            chunk = {k: v[-self.capacity :] for k, v in chunk.items()}
            m = self.capacity
        overflow = self._count + m - self.capacity
        if overflow > 0:
            self._start = (self._start + overflow) % self.capacity
            self._count -= overflow
        idx = (self._start + self._count + np.arange(m)) % self.capacity
        for name, array in self._data.items():
            value = chunk.get(name)
            if value is None or value.shape[1:] != array.shape[1:]:
                array[idx] = 0.0
            else:
                array[idx] = value
        self._count += m

    def truncate_after(self, i: int) -> None:
        """Keep logical samples 0..i, forget the rest."""
        self._count = max(0, min(self._count, i + 1))

    # ---------------------------------------------------------------- reading
    def sample(self, i: int) -> dict[str, np.ndarray]:
        p = self._phys(i)
        return {name: array[p].copy() for name, array in self._data.items()}

    def has(self, name: str) -> bool:
        return name in self._data

    def get(self, name: str, i: int) -> np.ndarray:
        return self._data[name][self._phys(i)]

    def window(self, i0: int, i1: int, names=None, stride: int = 1) -> dict[str, np.ndarray]:
        """Samples with logical index i0 <= i <= i1 (every ``stride``-th), in time order."""
        i0 = max(i0, 0)
        i1 = min(i1, self._count - 1)
        if i1 < i0:
            return {name: self._data[name][:0].copy() for name in (names or self._data)}
        idx = (self._start + np.arange(i0, i1 + 1, stride)) % self.capacity
        return {name: self._data[name][idx] for name in (names or self._data)}

    def series(self, name: str, i0: int, i1: int) -> np.ndarray:
        """One field's samples i0 <= i <= i1 in time order: at most two slices of the storage, no index array
        (the trace reads this every other frame)."""
        i0 = max(i0, 0)
        i1 = min(i1, self._count - 1)
        array = self._data[name]
        if i1 < i0:
            return array[:0].copy()
        a, b = self._phys(i0), self._phys(i1)
        if a <= b:
            return array[a : b + 1].copy()
        return np.concatenate([array[a:], array[: b + 1]])

    def field_names(self) -> tuple[str, ...]:
        return tuple(self._data)


class ThinnedSeries:
    """A time series over a whole run in bounded memory: at most ``capacity`` points, evenly thinned.

    Every ``stride``-th point appended is kept; when ``capacity`` are kept, every other one is dropped and the
    stride doubles. The newest point is always part of :meth:`arrays`, so a live figure ends at the present.
    Why: the ensemble's spread figure shows the spread since the ensemble started, however long it has run; a
    list of every frame's value grew without bound and was copied whole into the figure 10 times a second.
    """

    def __init__(self, capacity: int = 512) -> None:
        if capacity < 4 or capacity % 2:
            raise ValueError(f"capacity = {capacity}: need an even number >= 4")
        self.capacity = capacity
        self._t = np.zeros(capacity)
        self._y = np.zeros(capacity)
        self._count = 0
        self._stride = 1
        self._seen = 0  # points appended since the start
        self._latest: tuple[float, float] | None = None

    def __len__(self) -> int:
        return self._count

    def clear(self) -> None:
        self._count = 0
        self._stride = 1
        self._seen = 0
        self._latest = None

    def append(self, t: float, y: float) -> None:
        if self._seen % self._stride == 0:
            if self._count == self.capacity:
                half = self.capacity // 2
                self._t[:half] = self._t[0 : self.capacity : 2]
                self._y[:half] = self._y[0 : self.capacity : 2]
                self._count = half
                self._stride *= 2
            if self._seen % self._stride == 0:
                self._t[self._count] = t
                self._y[self._count] = y
                self._count += 1
        self._seen += 1
        self._latest = (t, y)

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """(t, y) of the kept points and the newest one, oldest first (copies)."""
        t, y = self._t[: self._count], self._y[: self._count]
        if self._latest is not None and (self._count == 0 or self._t[self._count - 1] != self._latest[0]):
            return np.append(t, self._latest[0]), np.append(y, self._latest[1])
        return t.copy(), y.copy()
