"""Simulation: numpy, scipy and the generated numba code only (never sympy)."""

from .run import SINGULAR_CONDITION, build_trajectory, check_assembled, simulate, status_message
from .trajectory import Trajectory

__all__ = ["SINGULAR_CONDITION", "Trajectory", "build_trajectory", "check_assembled", "simulate", "status_message"]
