"""Build one mechanism's code in a process of its own: ``python -m physics.codegen.prebuild METHOD N open|pinned
INTEGRATOR``.

The app serves many browsers from one interpreter; a sympy derivation (seconds) or a first compilation of an
integrator (half a minute on an installation's first run) there would hold the interpreter lock and freeze
every other session's animation. The server runs this module as a child process instead: it derives and
generates the code into the shared cache, and runs one tiny simulation so numba compiles the integrator
into its disk cache; the server then only loads the results (a fraction of a second). The arguments are
names from our own validated models, never code.
"""

from __future__ import annotations

import sys

from ..errors import LinkageError
from ..model import Settings
from ..presets import get_preset
from ..simulate import simulate
from .cache import FORMULATION_NAMES, is_generated, load_compiled

USAGE = "usage: python -m physics.codegen.prebuild METHOD N open|pinned INTEGRATOR"


def chain_systems(method: str, n: int, pinned: bool) -> list[tuple[str, int, bool]]:
    """The chain's generated systems a run of ``method`` loads: its formulation's; the reduced methods (a
    four-bar's, on the general reduced model) the pinned Lagrange system, which reports their samples."""
    return [(method, n, pinned)] if method in FORMULATION_NAMES else [("lagrange", n, True)]


def code_missing(method: str, n: int, pinned: bool) -> bool:
    """True when a run of ``method`` on such a chain would derive code in this process (sympy, seconds): one of
    its chain systems is not generated, or, for the reduced methods, the four-bar written as a mechanism has no
    generated DAE code (the general reduced model evaluates it). The app asks, to build in a worker instead."""
    if not all(is_generated(*system) for system in chain_systems(method, n, pinned)):
        return True
    if method in FORMULATION_NAMES:
        return False
    from ..mechanism.chains import chain_mechanism  # noqa: PLC0415
    from ..mechanism.engine import is_compiled  # noqa: PLC0415

    four_bar = get_preset("four-bar")  # the structure is the same for every four-bar; only it is keyed
    return not is_compiled(chain_mechanism(four_bar.chain, four_bar.theta0), "dae")


def prebuild(method: str, n: int, pinned: bool, integrator: str) -> None:
    """Derive (if missing) and compile what ``method`` needs for this chain, and its integrator's kernel (for
    the reduced methods, the tiny run below derives the four-bar mechanism's DAE code and compiles its kernel)."""
    for formulation, links, closed in chain_systems(method, n, pinned):
        load_compiled(formulation, links, closed)
    # The integrator kernels are compiled once for every mechanism, in one variant for runs that project onto
    # held constraints and one for runs that do not (physics.kernels.explicit_rk): one tiny run of any chain
    # of the same closure compiles the variant this session needs (a pinned chain: the four-bar).
    closed_chain = pinned or method not in FORMULATION_NAMES
    preset = get_preset("four-bar") if closed_chain else get_preset("chain", links=n)
    settings = Settings(method=method, integrator=integrator, t_end=0.02, samples=2)
    simulate(preset.chain, preset.theta0, preset.omega0, settings)


def main(argv: list[str]) -> int:
    if len(argv) != 4 or argv[2] not in ("open", "pinned") or not argv[1].isdigit():
        print(USAGE, file=sys.stderr)
        return 2
    try:
        prebuild(argv[0], int(argv[1]), argv[2] == "pinned", argv[3])
    except (LinkageError, ValueError) as error:
        print("prebuild: " + " ".join(str(error).split()), file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
