"""What every run of one chain object needs from it, worked out once: its bars' arrays and parameter vector.

A chain is a frozen pydantic model whose bars are frozen too, so the same object (holding the same bar objects)
always gives the same arrays. Reading them back through pydantic on every run cost more than a short run's
post-processing (the app and a notebook simulate the same chain again and again, a chunk at a time); they are
kept per chain object here, and the arrays handed out are copies where a caller might write into them.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import numpy as np

from ..errors import LinkageError
from ..model import Chain, Settings, TracePoint

# Chains remembered at once (the oldest forgotten first): a few presets and the app's current chains.
MAX_CHAINS = 32


# eq=False, repr=False: its arrays compare elementwise and print whole; generating __eq__ and __repr__ cost
# every process about 0.5 ms a class (benchmarks/small_cuts.py)
@dataclass(frozen=True, eq=False, repr=False)
class ChainArrays:
    """A chain's bars as arrays (never written by the simulation), its parameters without damping and the
    point traced when a run names none (the tip)."""

    L: np.ndarray
    d: np.ndarray
    m: np.ndarray
    I: np.ndarray  # noqa: E741 - the bars' field name
    g: float
    params: np.ndarray
    tip: TracePoint

    def params_with(self, damping: float) -> np.ndarray:
        """A fresh copy of ``chain.params(damping=damping)`` (the kernels and the scipy back end may write to it)."""
        params = self.params.copy()
        params[-1] = damping
        return params


_lock = threading.Lock()
# id(chain) -> (the chain, its bars when remembered, the arrays); holding the chain keeps its id from being reused.
_remembered: dict[int, tuple[Chain, tuple, ChainArrays]] = {}


def chain_arrays(chain: Chain) -> ChainArrays:
    """The arrays of ``chain``: remembered for this object and these bars, or read from it now."""
    entry = _remembered.get(id(chain))
    bars = chain.bars
    if entry is not None and entry[0] is chain and len(entry[1]) == len(bars) and all(
        kept is bar for kept, bar in zip(entry[1], bars)
    ):
        return entry[2]
    L = chain.array("L")
    arrays = ChainArrays(L=L, d=chain.array("d"), m=chain.array("m"), I=chain.array("I"), g=float(chain.g),
                         params=chain.params(), tip=TracePoint(bar=chain.n, along=float(L[-1])))
    with _lock:
        if len(_remembered) >= MAX_CHAINS:
            _remembered.pop(next(iter(_remembered)))
        _remembered[id(chain)] = (chain, tuple(bars), arrays)
    return arrays


def stabilization_gains(chain: Chain, settings: Settings) -> tuple[float, float, bool]:
    """``(alpha, beta, project)`` of a chain's run: an
    open chain holds no constraint, so nothing; a pinned one Baumgarte's gains or projection by its setting."""
    if not chain.pinned or settings.stabilization == "none":
        return 0.0, 0.0, False
    if settings.stabilization == "baumgarte":
        return settings.baumgarte_alpha, settings.baumgarte_beta, False
    return 0.0, 0.0, True


_times: dict[tuple, np.ndarray] = {}
MAX_SAMPLE_TIMES = 128  # argument sets remembered at once: the app's chunks, a study's runs (chains and mechanisms)


def sample_times(t_start: float, t_end: float, samples: int, *, from_zero: bool = False) -> np.ndarray:
    """A run's sample times, a copy of the array computed for these arguments before (a copy costs a tenth to a
    twentieth of ``linspace``; the run's reader may write to its times): ``np.linspace(t_start, t_start + t_end,
    samples)``, a chain's run's, or with ``from_zero`` ``t_start + np.linspace(0, t_end, samples)``, a
    mechanism's (a motor's angle follows absolute time). The two differ in the last bits, so each keeps its own."""
    key = (t_start, t_end, samples, math.copysign(1.0, t_start), from_zero)  # -0.0 == 0.0 as a key, not as t[0]
    times = _times.get(key)
    if times is None:
        if len(_times) >= MAX_SAMPLE_TIMES:
            _times.clear()
        times = (t_start + np.linspace(0.0, t_end, samples) if from_zero
                 else np.linspace(t_start, t_start + t_end, samples))
        _times[key] = times
    return times.copy()


def trace_point(chain: Chain, settings: Settings, bars: ChainArrays) -> TracePoint:
    """The point a run traces (the settings', else the tip), its bar checked against the chain."""
    trace = settings.trace or bars.tip
    if trace.bar > chain.n:
        raise LinkageError(f"trace bar = {trace.bar}: allowed range 1 <= bar <= {chain.n}")
    return trace
