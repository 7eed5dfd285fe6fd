"""Simulation: numpy, scipy and the generated numba code only (never sympy)."""

from .run import SINGULAR_PIVOT_RATIO, build_trajectory, check_assembled, simulate, status_message
from .trajectory import Trajectory

__all__ = ["SINGULAR_PIVOT_RATIO", "Trajectory", "build_trajectory", "check_assembled", "simulate", "status_message"]
