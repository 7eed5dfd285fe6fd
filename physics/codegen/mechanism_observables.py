"""What a run reports of its bodies besides the solve, read off every sample's body rotations: named points
fixed on bodies (where they are and how fast they move) and the kinetic and potential energy, generic in the
bodies and points (nothing here knows a chain; the chain's run on the mechanism engine names its joints, its
traced point and their path at its boundary, :mod:`physics.simulate.mechanism_route`).

A point is placed by walking a path of bodies from a ground point: through each body on the way from the point
where the path enters it to the one where it leaves, then from the last body's entry to the point itself,
every step an arm of the sketch turned with its body. So every point's ``x`` and ``y`` are linear in the bodies'
``cos phi, sin phi``: one product with a constant matrix gives every point of every sample, and the time
derivative (``d cos phi = -omega sin phi``) its velocity. Why a path and not the poses the formulation's
kinematics gives: a closed loop run without stabilisation drifts off its closure, and then a point's place
depends on which way round the loop it is reached; the path says which (a chain's: from ``O`` along its bars,
as its own kinematics read it), and for an open tree it is the tree's own, the same places to rounding.

The products are computed natively over every sample in one call (:mod:`physics.codegen.mechanism_observables_ir`,
with the energies and the reaction rows); they agree with the chain's own kinematics of the angles to rounding
(another order of the same sums). This module holds the constants of that call (:class:`ObservablesPlan`) and
loads its machine code.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np


# eq=False, repr=False: its arrays compare elementwise and print whole; generating __eq__ and __repr__ cost
# every process about 0.5 ms a class (benchmarks/small_cuts.py)
@dataclass(frozen=True, eq=False, repr=False)
class PathPoints:
    """Points, each reached along a path of bodies from a ground point: ``x = origin_x + [cos phi, sin phi]
    @ to_x`` (and ``y``) at every sample, ``cos phi, sin phi`` of the ``B`` bodies side by side ``(T, 2 B)``;
    ``to_x, to_y (2 B, P)``. Built by :meth:`along`."""

    origin_x: np.ndarray  # (P,)
    origin_y: np.ndarray
    to_x: np.ndarray
    to_y: np.ndarray

    @classmethod
    def along(cls, bodies: int, origins: np.ndarray, paths: list[list[tuple[int, np.ndarray]]]) -> PathPoints:
        """``origins (P, 2)``: each point's ground point; ``paths[p]``: the steps from it, ``(body, step)``
        with ``step`` the vector on that body in the sketch, from where the path enters it to where it leaves
        (or to the point, for the last); bodies 0-based, at most ``bodies``."""
        count = len(paths)
        to_x, to_y = np.zeros((2 * bodies, count)), np.zeros((2 * bodies, count))
        for point, path in enumerate(paths):
            for body, step in path:
                if not 0 <= body < bodies:
                    raise ValueError(f"point {point}: body {body} is not one of the {bodies}")
                step_x, step_y = (float(value) for value in step)
                # R(phi) step = (cos step_x - sin step_y, sin step_x + cos step_y)
                to_x[body, point] += step_x
                to_x[bodies + body, point] -= step_y
                to_y[body, point] += step_y
                to_y[bodies + body, point] += step_x
        origins = np.asarray(origins, dtype=float).reshape(count, 2)
        built = cls(np.ascontiguousarray(origins[:, 0]), np.ascontiguousarray(origins[:, 1]), to_x, to_y)
        for name in cls.__dataclass_fields__:
            getattr(built, name).setflags(write=False)
        return built


class ObservablesPlan:
    """The constants of :func:`observe` for one mechanism, its points and its reaction rows, in the layout of
    :mod:`physics.codegen.mechanism_observables_ir` (the arrays held here, their addresses taken once).

    ``rotation_index (B,)``: the coordinate that is each body's rotation (absolute rotations);
    ``acceleration_index (n,)``: where each coordinate's acceleration is among the solve's unknowns;
    ``mass_diagonal``, ``constant_force (3 B,)`` and ``damping (3 B, 3 B)``: ``M`` and ``Q = constant_force +
    damping @ qdot`` (gravity, torque motors; pin dampers); ``linear (3 B, R)`` and ``unknowns_map (k, R)``: the
    reaction rows reported, ``(M qddot - Q) @ linear + unknowns @ unknowns_map`` (``tree`` False: the second
    term alone); ``points``: a :class:`PathPoints` whose first ``B`` points are the bodies' centres;
    ``turns_in_pose``: the run's kinematics' vector holds the cosine and sine of each body's rotation
    coordinate (:attr:`physics.codegen.cache.CompiledSystem.pose_angle_index`), read instead of evaluated."""

    def __init__(self, rotation_index, acceleration_index, mass_diagonal, constant_force, damping, linear,
                 unknowns_map, points: PathPoints, tree: bool, turns_in_pose: bool = False) -> None:
        rotation_index = np.asarray(rotation_index, dtype=np.int64)
        acceleration_index = np.asarray(acceleration_index, dtype=np.int64)
        bodies, n = rotation_index.size, acceleration_index.size
        size = 3 * bodies
        linear = np.asarray(linear, dtype=float)
        unknowns_map = np.asarray(unknowns_map, dtype=float)
        count, reactions, unknowns = points.to_x.shape[1], linear.shape[1], unknowns_map.shape[0]
        if (np.shape(mass_diagonal) != (size,) or np.shape(constant_force) != (size,)
                or np.shape(damping) != (size, size) or linear.shape != (size, reactions)
                or unknowns_map.shape != (unknowns, reactions) or points.to_x.shape != (2 * bodies, count)
                or count < bodies or np.any(rotation_index >= n) or np.any(acceleration_index >= unknowns)):
            raise ValueError("inconsistent shapes for the mechanism's observables")
        places = np.zeros((2 * bodies, 2 * count))  # output 2 p + axis, as the points' (P, 2) rows lie
        places[:, 0::2], places[:, 1::2] = points.to_x, points.to_y
        matrices = [_terms(places), _terms(np.asarray(damping, dtype=float)), _terms(linear), _terms(unknowns_map)]
        self.shape = np.array([n, bodies, unknowns, count, reactions, *(len(weights) for _, _, weights in matrices)],
                              dtype=np.int64)
        self.indices = np.ascontiguousarray(np.concatenate(
            [acceleration_index, rotation_index, *(part for outputs, inputs, _ in matrices
                                                   for part in (outputs, inputs))]), dtype=np.int64)
        origin = np.column_stack([points.origin_x, points.origin_y])
        self.constants = np.ascontiguousarray(np.concatenate(
            [np.ravel(part) for part in (mass_diagonal, constant_force, origin)]
            + [weights for _, _, weights in matrices]), dtype=float)
        self.tree = bool(tree)
        # the IR's ``tree`` argument: 1 a tree formulation's (reactions by Newton's second law), each body's
        # cosine and sine evaluated from its rotation coordinate; 2 the same, those read from the kinematics'
        # vector instead; 0 not a tree formulation's (the unknowns' reactions), 3 the same, the kinematics'
        # cosines and sines read
        self.mode = (2 if turns_in_pose else 1) if tree else (3 if turns_in_pose else 0)
        self.bodies, self.count, self.reactions, self.unknowns, self.n = bodies, count, reactions, unknowns, n
        self.addresses = (self.shape.ctypes.data, self.indices.ctypes.data, self.constants.ctypes.data)


def _terms(matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(outputs, inputs, weights)`` of the non-zeros of ``matrix (inputs, outputs)`` (``y = x @ matrix``),
    ordered by output, then input: the dense product's sums in their order, less terms that add zero."""
    inputs, outputs = np.nonzero(matrix.T)[::-1]
    order = np.lexsort((inputs, outputs))
    inputs, outputs = inputs[order], outputs[order]
    return outputs.astype(np.int64), inputs.astype(np.int64), matrix[inputs, outputs].astype(float)


def scratch_length(bodies: int) -> int:
    """Doubles of ``mechanism_observables``' scratch: ``[cos, sin]`` and their rates (4 B), ``qdot``, ``qddot``
    and ``M qddot - Q`` (3 x 3 B)."""
    return 13 * bodies


_function: list = []  # [the ctypes function, the engine that owns its machine code]


def observables_function():
    """The ctypes function of ``mechanism_observables`` (:mod:`physics.codegen.mechanism_observables_ir`),
    compiled once per process at O2 as the specialised drivers are (no pass may reassociate or contract without
    fast-math flags, so the same operations; at the drivers' O0 its small loops over matrices cost about 2 us a
    sample, more than the solve) or loaded from the machine-code cache."""
    if not _function:
        import ctypes  # noqa: PLC0415

        from . import native  # noqa: PLC0415  (the O2 pipeline and target machine of the specialised code)
        from .machine_code import compile_module, llvm_binding, sources_digest  # noqa: PLC0415
        from .native_integrators import _lock, ir_builder  # noqa: PLC0415

        p, i, d = ctypes.c_void_p, ctypes.c_int64, ctypes.c_double
        signature = ctypes.CFUNCTYPE(None, p, p, p, i, i, d, p, p, i, p, p, p, p, p, p, p, p)
        with _lock, native._lock:
            if not _function:
                llvm_binding()
                engine = compile_module(ir_builder("mechanism_observables_ir", "observables_ir"), "driver-O2",
                                        native._optimize, native._target_machine,
                                        key=f"mechanism_observables\n{sources_digest()}")
                _function.extend([signature(engine.get_function_address("mechanism_observables")), engine])
    return _function[0]


# Per structure of plan (shape, indices, tree): the observables' function specialised for it
# (:func:`specialised_observables`), or how often it was asked for while it is not there.
SPECIALISE_OBSERVABLES = True
MAX_SPECIALISED = 64  # structures kept per process (each a small engine); past it the oldest is let go
_specialised: dict[tuple, tuple] = {}  # structure -> (ctypes function, engine)
_asked: dict[tuple, int] = {}
_building: set[tuple] = set()
_specialised_lock = threading.Lock()


def _structure(plan: ObservablesPlan) -> tuple:
    return plan.shape.tobytes(), plan.indices.tobytes(), plan.mode


def specialised_key(plan: ObservablesPlan) -> str:
    """The machine-code cache's key of :func:`specialised_observables` for ``plan``'s structure: the sources the
    IR is built from (:func:`~physics.codegen.machine_code.sources_digest`: this module and the IR's) and the
    structure's integers, so a change of either names other machine code."""
    from .machine_code import sources_digest  # noqa: PLC0415

    return (f"mechanism_observables specialised\n{sources_digest()}\nshape {plan.shape.tolist()}\n"
            f"indices {plan.indices.tolist()}\ntree {plan.mode}")


def specialised_observables(plan: ObservablesPlan) -> tuple | None:
    """``(function, engine)``: ``mechanism_observables`` specialised for ``plan``'s structure
    (:func:`~physics.codegen.mechanism_observables_ir.specialised_observables_ir`, the same bits; the function
    of :func:`observables_function`'s signature, valid while ``engine`` lives), or None (the caller takes the
    generic function) until it is there. By the specialised drivers' rule
    (:meth:`physics.codegen.cache.CompiledSystem._specialised`): loaded at once when its machine code is
    cached; else compiled from a structure's second request in this process on, in a background thread, so
    that a one-off run (the CLI's) compiles nothing and no run waits for the compilation."""
    if not SPECIALISE_OBSERVABLES:
        return None
    structure = _structure(plan)
    with _specialised_lock:
        made = _specialised.get(structure)
        if made is not None:
            return made
        if structure in _building:
            return None
        if len(_asked) >= 4 * MAX_SPECIALISED and structure not in _asked:  # structures asked for once, let go
            _asked.clear()
        asked = _asked[structure] = _asked.get(structure, 0) + 1
    from . import native  # noqa: PLC0415
    from .cache import SPECIALISE_IN_BACKGROUND  # noqa: PLC0415
    from .machine_code import is_cached  # noqa: PLC0415

    key = specialised_key(plan)
    cached = is_cached(key, SPECIALISED_VARIANT)
    if asked < 2 and not cached:
        return None
    shape, indices, tree = plan.shape.tolist(), plan.indices.tolist(), plan.mode

    def build() -> None:
        import ctypes  # noqa: PLC0415

        from .ir_shapes import OBSERVABLES_SPECIALISED_NAME  # noqa: PLC0415  (the IR builder: on a cache miss only)
        from .machine_code import compile_module, llvm_binding  # noqa: PLC0415
        from .native_integrators import _lock  # noqa: PLC0415

        try:
            with _lock, native._lock:
                llvm_binding()
                engine = compile_module(lambda: _specialised_text(shape, indices, tree),
                                        SPECIALISED_VARIANT, native._optimize, native._target_machine, key=key)
                p, i, d = ctypes.c_void_p, ctypes.c_int64, ctypes.c_double
                signature = ctypes.CFUNCTYPE(None, p, p, p, i, i, d, p, p, i, p, p, p, p, p, p, p, p)
                function = signature(engine.get_function_address(OBSERVABLES_SPECIALISED_NAME))
            with _specialised_lock:
                if len(_specialised) >= MAX_SPECIALISED:  # a caller holding an entry holds its engine too
                    _specialised.pop(next(iter(_specialised)))
                _specialised[structure] = (function, engine)
                _asked.pop(structure, None)
        finally:
            with _specialised_lock:
                _building.discard(structure)

    with _specialised_lock:
        if structure in _building:
            return None
        _building.add(structure)
    if cached or not SPECIALISE_IN_BACKGROUND:
        build()
        return _specialised.get(structure)
    # not a daemon: a process that ends meanwhile waits for it rather than tearing LLVM down under it
    threading.Thread(target=build, name="specialise observables", daemon=False).start()
    return None


def _specialised_text(shape: list, indices: list, tree: int) -> str:
    """The IR text of one structure's observables, built on a machine-code cache miss only (a warm process never
    imports the IR builders: tests/physics/test_lean_start.py)."""
    from .mechanism_observables_ir import specialised_observables_ir  # noqa: PLC0415

    return specialised_observables_ir(shape, indices, tree)


SPECIALISED_VARIANT = "driver-O2"  # observables_function's passes and code generation level
