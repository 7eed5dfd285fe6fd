"""Build what a chain's run needs ahead of it, so the app's server derives nothing: the library half of the
worker ``python -m physics.codegen.prebuild_worker METHOD N open|pinned INTEGRATOR``
(:mod:`physics.codegen.prebuild_worker`).

The app serves many browsers from one interpreter; a sympy derivation (seconds) or a first compilation of an
integrator (half a minute on an installation's first run) there would hold the interpreter lock and freeze
every other session's animation. The server runs the worker as a child process instead: it derives and
generates the code into the shared cache (the chain written as a mechanism on the general engine, its generated
system and the structure's route record, :mod:`physics.simulate.chain_record`), and runs one tiny simulation so
the run's kernels are compiled into the disk cache; the server then only loads the results (a fraction of a
second). The arguments are names from our own validated models, never code.
"""

from __future__ import annotations

import math

import numpy as np

from ..chain_presets import get_preset
from ..errors import LinkageError
from ..kinematics import joint_positions
from ..model import Chain, Settings
from ..simulate import simulate
from ..simulate.chain_record import load_record
from ..simulate.chain_system import chain_system
from .cache import FORMULATION_NAMES, is_generated_key

__all__ = ["chain_systems", "code_missing", "load_run_systems", "prebuild", "structure_chain"]


def chain_systems(method: str, n: int, pinned: bool) -> list[tuple[str, int, bool]]:
    """The chain's generated systems a run of ``method`` loads: its formulation's; the reduced methods (a
    four-bar's, on the general reduced model) the pinned Lagrange system, which reports their samples."""
    return [(method, n, pinned)] if method in FORMULATION_NAMES else [("lagrange", n, True)]


def _route_generated(formulation: str, n: int, pinned: bool) -> bool:
    """True if the structure's route record is in the cache folder (trusted) and so is the generated system it
    names: :func:`physics.simulate.mechanism_route.chain_route` then derives nothing (no sympy, no mechanism)."""
    record = load_record(formulation, n, pinned)
    return record is not None and is_generated_key(record.compiled_key)


def code_missing(method: str, n: int, pinned: bool) -> bool:
    """True when a run of ``method`` on such a chain would derive code in this process (sympy, seconds): one of
    its systems (the chain written as a mechanism, with its route record) is not generated, or, for the reduced
    methods, the four-bar written as a mechanism has no generated DAE code (the general reduced model evaluates
    it). The app asks, to build in a worker instead."""
    if not all(_route_generated(*system) for system in chain_systems(method, n, pinned)):
        return True
    if method in FORMULATION_NAMES:
        return False
    from ..mechanism.chains import chain_mechanism  # noqa: PLC0415
    from ..mechanism.engine import is_compiled  # noqa: PLC0415

    four_bar = get_preset("four-bar")  # the structure is the same for every four-bar; only it is keyed
    return not is_compiled(chain_mechanism(four_bar.chain, four_bar.theta0), "dae")


def load_run_systems(chain: Chain, method: str, damping: float = 0.0) -> None:
    """Load (deriving on a miss) the compiled systems a run of ``method`` on ``chain`` reads: the chain written
    as a mechanism (:func:`physics.simulate.chain_system.chain_system`, from the structure's record when the
    cache holds it). What the app warms before a session's first run, so that run waits on nothing."""
    for formulation, _links, _closed in chain_systems(method, chain.n, chain.pinned):
        chain_system(chain, formulation, damping)


def structure_chain(n: int, pinned: bool) -> tuple[Chain, np.ndarray, np.ndarray]:
    """A chain of ``n`` uniform rods (its tip pinned where it starts when ``pinned``) and a start that assembles:
    what a route is built from is the structure (method, bars, pin), never the chain's numbers."""
    preset = get_preset("chain", links=n)
    if not pinned:
        return preset.chain, preset.theta0, preset.omega0
    if n < 2:
        raise LinkageError(f"links = {n}: a pinned chain has at least 2 bars")
    theta0 = np.array([math.pi / 2 + (0.6 if k % 2 else -0.6) for k in range(n)])  # a zigzag: no bars in line
    tip = joint_positions(preset.chain.array("L"), theta0)[-1]
    return preset.chain.with_pin((float(tip[0]), float(tip[1]))), theta0, np.zeros(n)


def _preset_start(preset) -> tuple[Chain, np.ndarray, np.ndarray]:
    return preset.chain, preset.theta0, preset.omega0


def prebuild(method: str, n: int, pinned: bool, integrator: str) -> None:
    """Derive (if missing) and compile what ``method`` needs for this chain: the chain written as a mechanism,
    its generated systems and records, then one tiny run of this very structure, which compiles its run's
    kernels (a reduced method: the four-bar, the only chain it runs, whose tiny run derives the four-bar
    mechanism's DAE code)."""
    settings = Settings(method=method, integrator=integrator, t_end=0.02, samples=2)
    chain, theta0, omega0 = (structure_chain(n, pinned) if method in FORMULATION_NAMES
                             else _preset_start(get_preset("four-bar")))
    for formulation, _links, _closed in chain_systems(method, n, pinned):
        chain_system(chain, formulation)
    simulate(chain, theta0, omega0, settings)
