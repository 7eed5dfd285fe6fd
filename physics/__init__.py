"""Linkage Lab physics: planar n-bar chains and closed loops, three derivations, generated code, simulation.

Pure Python (numpy, scipy, sympy, numba, pydantic); it never imports the GUI. The public names are
re-exported here; see docs/architecture.md for conventions and shapes.
"""

from . import blas_start  # noqa: F401  (first: numpy, with one BLAS thread in a command-line process)
from .chain_presets import Preset, get_preset, preset_names
from .codegen import CompiledSystem, equations_latex, load_compiled
from .codegen.cache import is_generated
from .codegen.prebuild import code_missing, load_run_systems
from .errors import LinkageError
from .evaluate import accelerations
from .kinematics import energies, joint_positions
from .model import (
    FORMULATION_NAMES,
    INTEGRATOR_NAMES,
    METHOD_NAMES,
    Bar,
    Chain,
    Settings,
    TracePoint,
    apply_overrides,
    make_chain,
    parameter_names,
)
from .registry import INTEGRATORS, METHODS
from .simulate import Trajectory, simulate
from .status import Status

__version__ = "0.1.0"


def reduced_available(chain: Chain) -> bool:
    """The reduced one-coordinate model exists for one-degree-of-freedom loops: a pinned 3-bar chain."""
    return chain.pinned and chain.n == 3


def equations_of_motion(linkage, method: str):
    """The equations of motion ``method`` (``dae``, ``lagrange``, ``newton_euler``) integrates for ``linkage``, a
    :class:`Chain` or a :class:`physics.mechanism.Mechanism`: the linear system ``A x = b`` solved at every
    evaluation of the right-hand side, in readable symbols (a chain's ``theta``, ``L``, ``d``, a mechanism's body
    names), as :class:`physics.mechanism.equations.EquationsOfMotion`. A chain's are those of the mechanism its
    runs integrate (:func:`physics.mechanism.chains.chain_mechanism`). What the app's Equations tab shows and
    downloads as LaTeX; sympy loads only when this is called (seconds the first time per structure)."""
    from .mechanism.equations import equations_of_motion as derive  # noqa: PLC0415 - sympy: only when asked for

    return derive(linkage, method)


def derived_system(formulation: str, n: int, pinned: bool = False):
    """One formulation's symbolic system of an ``n``-bar chain from the chain's own derivation (:mod:`physics.derive`,
    the chain formulas of docs/physics.md): an independent check of what runs, not what runs (that is
    :func:`equations_of_motion`). sympy loads only when this is called."""
    from .derive import FORMULATIONS  # noqa: PLC0415 - sympy: only when asked for

    return FORMULATIONS[formulation]().derive(n, pinned)


__all__ = [
    "Bar",
    "Chain",
    "CompiledSystem",
    "FORMULATION_NAMES",
    "INTEGRATORS",
    "INTEGRATOR_NAMES",
    "LinkageError",
    "METHOD_NAMES",
    "METHODS",
    "Preset",
    "Settings",
    "Status",
    "TracePoint",
    "Trajectory",
    "accelerations",
    "apply_overrides",
    "derived_system",
    "energies",
    "equations_latex",
    "equations_of_motion",
    "get_preset",
    "code_missing",
    "load_run_systems",
    "is_generated",
    "joint_positions",
    "load_compiled",
    "make_chain",
    "parameter_names",
    "preset_names",
    "reduced_available",
    "simulate",
]
