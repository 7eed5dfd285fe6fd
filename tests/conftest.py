"""Shared test fixtures: a private cache for generated code, seeded random chains, the formulation list."""

from __future__ import annotations

import os
import socket
import tempfile
from pathlib import Path

import numpy as np
import pytest

# Generated code for the whole test session goes to one private folder (kept between local runs so numba's
# compiled code is reused; CI starts from an empty one). Tests of the cache itself use their own folders.
os.environ.setdefault("LINKAGE_LAB_CACHE", str(Path(tempfile.gettempdir()) / f"linkage-lab-test-cache-{os.getuid()}"))

ALL_FORMULATIONS = ("newton_euler", "lagrange", "dae")


@pytest.fixture(params=ALL_FORMULATIONS)
def formulation(request):
    return request.param


def random_params(rng: np.random.Generator, n: int, pin=None, damping: float = 0.0) -> np.ndarray:
    """Random valid parameters in the layout of Chain.params(): lengths 0.3..2, d within the bar,
    masses 0.2..3, inertias 0.01..1, g 0.5..10."""
    L = rng.uniform(0.3, 2.0, n)
    d = L * rng.uniform(0.0, 1.0, n)
    m = rng.uniform(0.2, 3.0, n)
    I = rng.uniform(0.01, 1.0, n)
    g = rng.uniform(0.5, 10.0)
    pin = (0.0, 0.0) if pin is None else pin
    return np.concatenate([L, d, m, I, [g, pin[0], pin[1], damping]])


@pytest.fixture
def rng():
    return np.random.default_rng(20261122)


@pytest.fixture
def free_port():
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]
