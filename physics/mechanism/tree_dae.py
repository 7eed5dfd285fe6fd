"""The DAE in tree coordinates: a mechanism's maximal DAE integrated in its spanning tree's joint coordinates.

Why: the seed's DAE (course report, section 2.3; its ode45 call) integrates the chain's joint angles and rates,
and at each state solves one linear system for every centre-of-mass acceleration, angular acceleration and joint
reaction. The mechanism engine's ``dae`` integrates the maximal coordinates (every body's x, y and angle) instead,
so a chain built as a mechanism (:mod:`physics.mechanism.chains`) could not run the seed's DAE with its meaning.
Here the state is the tree formulations' ``(s, sd)`` (:mod:`physics.mechanism.tree_coordinates`), and each
right-hand side is one call of generated code (:mod:`physics.mechanism.symbolic_tree_dae`): the poses and
velocities from the tree coordinates, the DAE's linear system with its parameter vector (the loops' closures,
motors, sliders and gears among its rows) solved for every body's acceleration and every reaction, and the tree
joints' accelerations read off the bodies'. The loops' drift is held as the tree formulations hold it
(projection or Baumgarte terms on the closures in tree coordinates). A run reports the DAE's own multipliers as
its reactions (the rows and names of the maximal ``dae``), not Newton's law on its accelerations.

It is chosen by ``coordinates="tree"`` with ``method="dae"`` (:func:`physics.mechanism.simulate.simulate_mechanism`);
the ``mechanism`` command's ``dae`` keeps its meaning (maximal coordinates).
"""

from __future__ import annotations

import numpy as np

from ..codegen.cache import CompiledSystem, load_generated
from ..errors import LinkageError
from .description import Mechanism
from .parameters import structure, structure_key
from .tree_coordinates import check_rotations

FORMULATION = "tree_dae"
COORDINATES = ("maximal", "tree")  # the values of simulate_mechanism's ``coordinates``


def check_coordinates(coordinates: str, method: str) -> None:
    """Refuse, in one line, a ``coordinates`` that is not one of :data:`COORDINATES` or ``tree`` with a method
    other than ``dae`` (the tree formulations integrate tree coordinates already; the reduced model its one)."""
    if coordinates not in COORDINATES:
        raise LinkageError(f"coordinates = {coordinates!r}: allowed values {', '.join(COORDINATES)}")
    if coordinates == "tree" and method != "dae":
        raise LinkageError(f"coordinates = 'tree': applies to method 'dae' only (method {method!r} has its own "
                           f"coordinates); leave it out or choose method 'dae'")


def compiled_tree_dae(mechanism: Mechanism, key_of_structure: str | None = None,
                      rotations: str = "relative") -> CompiledSystem:
    """The generated DAE in tree coordinates for ``mechanism``'s structure: from memory, from the cache folder,
    or derived (sympy, only on a miss) and cached, exactly as :func:`physics.mechanism.engine.compiled_system`
    keeps the three formulations (the key names the structure and ``rotations``, what a pin's coordinate is,
    never its numbers)."""
    check_rotations(rotations)
    digest = structure_key(mechanism) if key_of_structure is None else key_of_structure

    def derive():
        from .symbolic import derive_structure  # noqa: PLC0415
        from .symbolic_parameters import parameter_symbols  # noqa: PLC0415  (sympy only on a cache miss)
        from .symbolic_tree_dae import derive_tree_dae  # noqa: PLC0415

        shape = structure(mechanism)
        system = derive_tree_dae(shape, parameter_symbols(shape), derive_structure(shape, "dae", "relative"),
                                 rotations)
        return system, (f"the DAE in tree coordinates of a mechanism of {shape.bodies} bodies and "
                        f"{len(shape.joints)} joints, structure {digest}"
                        f"{', absolute rotations' * (rotations == 'absolute')}")

    kind = "" if rotations == "relative" else f"{rotations}-"  # relative: the key every cached one has had
    return load_generated(f"treedae-mechanism-{kind}{digest}", FORMULATION, derive)


def instant(mechanism: Mechanism, s: np.ndarray, sd: np.ndarray, t: float = 0.0, rotations: str = "relative"
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(sdd, qddot, reactions)`` at the tree state ``(s, sd)`` (its pins' coordinates by ``rotations``) and time
    ``t``: one solve of the generated system (every body's acceleration, every reaction row in the DAE's layout,
    the tree coordinates' accelerations)."""
    from .prepared import prepared  # noqa: PLC0415

    pieces = prepared(mechanism)
    compiled = compiled_tree_dae(mechanism, pieces.structure_key, rotations)
    full, _ = compiled.solve_full(np.asarray(s, dtype=float), np.asarray(sd, dtype=float), pieces.parameters_at(t))
    size = 3 * len(mechanism.bodies)
    return full[compiled.theta_ddot_index], full[:size], full[compiled.multiplier_index]
