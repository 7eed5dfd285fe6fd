"""Build one mechanism's code in a process of its own: ``python -m physics.codegen.prebuild METHOD N open|pinned
INTEGRATOR [chain|mechanism]``.

The app serves many browsers from one interpreter; a sympy derivation (seconds) or a first compilation of an
integrator (half a minute on an installation's first run) there would hold the interpreter lock and freeze
every other session's animation. The server runs this module as a child process instead: it derives and
generates the code into the shared cache, and runs one tiny simulation so numba compiles the integrator
into its disk cache; the server then only loads the results (a fraction of a second). The arguments are
names from our own validated models, never code.

The last argument is the route a chain's run takes (:data:`physics.simulate.on_mechanism.ENABLED`, which a child
process does not share): ``chain`` (the default, so the four-argument command keeps its meaning) builds the
chain's own generated systems; ``mechanism`` builds the chain written as a mechanism on the general engine, its
generated system and the structure's route record (:mod:`physics.simulate.chain_record`), so the server derives
nothing on that route either. :func:`prebuild_arguments` gives the server the arguments of its own route.
"""

from __future__ import annotations

import math
import sys

import numpy as np

from ..errors import LinkageError
from ..kinematics import joint_positions
from ..model import Chain, Settings
from ..presets import get_preset
from ..simulate import on_mechanism, simulate
from ..simulate.chain_record import load_record
from ..simulate.chain_system import chain_system
from .cache import FORMULATION_NAMES, is_generated, is_generated_key, load_compiled

USAGE = "usage: python -m physics.codegen.prebuild METHOD N open|pinned INTEGRATOR [chain|mechanism]"
# The routes a chain's run can take, as the worker's last argument names them.
ROUTES = ("chain", "mechanism")


def chain_engine() -> str:
    """The route a chain's run takes in this process: ``"mechanism"`` (the general mechanism engine) when
    :data:`physics.simulate.on_mechanism.ENABLED` is on, else ``"chain"`` (the chain's own generated kernels)."""
    return ROUTES[1] if on_mechanism.ENABLED else ROUTES[0]


def _on_route(on_mechanism_engine: bool | None) -> bool:
    return on_mechanism.ENABLED if on_mechanism_engine is None else bool(on_mechanism_engine)


def chain_systems(method: str, n: int, pinned: bool) -> list[tuple[str, int, bool]]:
    """The chain's generated systems a run of ``method`` loads: its formulation's; the reduced methods (a
    four-bar's, on the general reduced model) the pinned Lagrange system, which reports their samples."""
    return [(method, n, pinned)] if method in FORMULATION_NAMES else [("lagrange", n, True)]


def _route_generated(formulation: str, n: int, pinned: bool) -> bool:
    """True if the structure's route record is in the cache folder (trusted) and so is the generated system it
    names: :func:`physics.simulate.mechanism_route.chain_route` then derives nothing (no sympy, no mechanism)."""
    record = load_record(formulation, n, pinned)
    return record is not None and is_generated_key(record.compiled_key)


def code_missing(method: str, n: int, pinned: bool, *, on_mechanism_engine: bool | None = None) -> bool:
    """True when a run of ``method`` on such a chain would derive code in this process (sympy, seconds): one of
    its systems is not generated (on the route the switch chooses, or ``on_mechanism_engine``: the chain's own,
    or the chain written as a mechanism with its route record), or, for the reduced methods, the four-bar written
    as a mechanism has no generated DAE code (the general reduced model evaluates it). The app asks, to build in
    a worker instead."""
    generated = _route_generated if _on_route(on_mechanism_engine) else is_generated
    if not all(generated(*system) for system in chain_systems(method, n, pinned)):
        return True
    if method in FORMULATION_NAMES:
        return False
    from ..mechanism.chains import chain_mechanism  # noqa: PLC0415
    from ..mechanism.engine import is_compiled  # noqa: PLC0415

    four_bar = get_preset("four-bar")  # the structure is the same for every four-bar; only it is keyed
    return not is_compiled(chain_mechanism(four_bar.chain, four_bar.theta0), "dae")


def load_run_systems(chain: Chain, method: str, damping: float = 0.0) -> None:
    """Load (deriving on a miss) the compiled systems a run of ``method`` on ``chain`` reads, on the route the
    switch chooses: the chain's own generated systems (:func:`chain_systems`), or the chain written as a mechanism
    (:func:`physics.simulate.chain_system.chain_system`, from the structure's record when the cache holds it).
    What the app warms before a session's first run, so that run waits on nothing; the chain's own kernels are
    never loaded on the mechanism engine."""
    if not on_mechanism.ENABLED:
        for system in chain_systems(method, chain.n, chain.pinned):
            load_compiled(*system)
        return
    for formulation, _links, _closed in chain_systems(method, chain.n, chain.pinned):
        chain_system(chain, formulation, damping, on_mechanism_engine=True)


def prebuild_arguments(method: str, n: int, pinned: bool, integrator: str) -> list[str]:
    """The worker's arguments for a build on this process's route (the worker does not share the switch); with
    the switch off the four arguments the command always took."""
    arguments = [method, str(int(n)), "pinned" if pinned else "open", integrator]
    return arguments + [ROUTES[1]] if on_mechanism.ENABLED else arguments


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


def prebuild(method: str, n: int, pinned: bool, integrator: str, on_mechanism_engine: bool | None = None) -> None:
    """Derive (if missing) and compile what ``method`` needs for this chain on the route (the switch, or
    ``on_mechanism_engine``), and its integrator's kernel (for the reduced methods, the tiny run below derives
    the four-bar mechanism's DAE code and compiles its kernel)."""
    route = _on_route(on_mechanism_engine)
    settings = Settings(method=method, integrator=integrator, t_end=0.02, samples=2)
    if route:
        # the route's generated systems and records, then one tiny run of this very structure on the route, which
        # compiles its run's kernels (a reduced method: the four-bar, the only chain it runs)
        chain, theta0, omega0 = (structure_chain(n, pinned) if method in FORMULATION_NAMES
                                 else _preset_start(get_preset("four-bar")))
        for formulation, _links, _closed in chain_systems(method, n, pinned):
            chain_system(chain, formulation, on_mechanism_engine=True)
        switch = on_mechanism.ENABLED
        on_mechanism.ENABLED = True  # physics.simulate reads the switch: this process's own (a worker's, or a test's)
        try:
            simulate(chain, theta0, omega0, settings)
        finally:
            on_mechanism.ENABLED = switch
        return
    for formulation, links, closed in chain_systems(method, n, pinned):
        load_compiled(formulation, links, closed)
    # The integrator kernels are compiled once for every mechanism, in one variant for runs that project onto
    # held constraints and one for runs that do not (physics.kernels.explicit_rk): one tiny run of any chain
    # of the same closure compiles the variant this session needs (a pinned chain: the four-bar).
    closed_chain = pinned or method not in FORMULATION_NAMES
    preset = get_preset("four-bar") if closed_chain else get_preset("chain", links=n)
    simulate(preset.chain, preset.theta0, preset.omega0, settings)


def main(argv: list[str]) -> int:
    if (len(argv) not in (4, 5) or argv[2] not in ("open", "pinned") or not argv[1].isdigit()
            or (len(argv) == 5 and argv[4] not in ROUTES)):
        print(USAGE, file=sys.stderr)
        return 2
    on_engine = len(argv) == 5 and argv[4] == ROUTES[1]
    try:
        prebuild(argv[0], int(argv[1]), argv[2] == "pinned", argv[3], on_mechanism_engine=on_engine)
    except (LinkageError, ValueError) as error:
        print("prebuild: " + " ".join(str(error).split()), file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
