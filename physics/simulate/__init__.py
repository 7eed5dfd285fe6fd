"""Simulation: numpy, scipy and the generated numba code only (never sympy)."""

from .run import SINGULAR_PIVOT_RATIO, check_assembled, simulate, status_message
from .trajectory import Trajectory

__all__ = ["SINGULAR_PIVOT_RATIO", "Trajectory", "check_assembled", "simulate", "status_message"]
