"""Symbolic derivations (sympy): three independent formulations behind one interface.

Imported only when generated code must be (re)built; a warm start never imports sympy.
"""

from .dae import DAE
from .formulation import Formulation, LinearSystem, linear_system
from .lagrange import Lagrange
from .newton_euler import NewtonEuler

FORMULATIONS = {cls.name: cls for cls in (NewtonEuler, Lagrange, DAE)}

__all__ = ["DAE", "FORMULATIONS", "Formulation", "Lagrange", "LinearSystem", "NewtonEuler", "linear_system"]
