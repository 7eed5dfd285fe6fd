"""The names and scratch sizes of the IR modules' entry points, apart from the IR that builds them.

A run calls the drivers of :mod:`physics.codegen.integrator_ir` and the samples' pass of
:mod:`physics.codegen.samples_ir` by these names with scratch of these sizes, but their machine code normally
comes from the cache (:mod:`physics.codegen.machine_code`): kept here, they spare a warm process the IR
builders and ``llvmlite.ir``, which only a cache miss needs.
"""

from __future__ import annotations

from ..kernels import tables
from ..kernels.layout import LAYOUT_CONSTRAINT_FUNCTION, LAYOUT_RHS, LAYOUT_SOLVE

INTEGRATOR_FUNCTION_NAMES = {"RK45": "integrate_rk45", "DOP853": "integrate_dop853"}
WORK_VECTORS = 8  # y, y_new, y_next, y_stage, f, f_next, scale, work
# The drivers and the samples' solve specialised for one system (physics/codegen/specialised_ir.py): their entry
# points, and the layout's entries that are addresses (external symbols named from the system's IR digest).
ADDRESS_SLOTS = (LAYOUT_SOLVE, LAYOUT_CONSTRAINT_FUNCTION, LAYOUT_RHS)
SPECIALISED_NAMES = {method: f"{name}_specialised" for method, name in INTEGRATOR_FUNCTION_NAMES.items()}
# the observables function specialised per structure (physics/codegen/mechanism_observables.py loads it by this
# name from the machine-code cache without importing its IR builder)
OBSERVABLES_SPECIALISED_NAME = "mechanism_observables_specialised"
SAMPLES_SOLVE_NAME = "solve_states_specialised"
SAMPLES_SOLVE_POSE_NAME = "solve_pose_states_specialised"


def symbol_names(system_digest: str) -> dict[str, str]:
    """The external symbols of a system whose IR texts have digest ``system_digest``: ``assemble``, ``sample``
    and one per address slot of the layout (keyed by the slot's number as text)."""
    names = {"assemble": f"linkage_lab_{system_digest}_assemble", "sample": f"linkage_lab_{system_digest}_sample"}
    names.update({str(slot): f"linkage_lab_{system_digest}_slot{slot}" for slot in ADDRESS_SLOTS})
    return names


def stage_rows(method: str) -> int:
    """Rows of stage derivatives ``K`` the driver of ``method`` keeps: DOP853's extended stages, or RK45's
    stages and the last evaluation (any name but "DOP853" is RK45, as the numba driver selects it)."""
    return tables.DOP853_N_STAGES_EXTENDED if method == "DOP853" else tables.RK45_N_STAGES + 1


def integrator_scratch_length(method: str, n_state: int, n_constraints: int, n_unknowns: int) -> int:
    """Doubles of scratch the driver of ``method`` needs for a state of ``n_state`` (= 2 n) entries,
    ``n_constraints`` rows and ``n_unknowns`` unknowns: the stage rows ``K``, DOP853's dense-output rows ``F``,
    eight vectors, ``theta``, ``omega``, the constraints' ``J`` (r x n, two rows at least), ``v`` (2 r), ``G``
    (r x r), the general solve's ``A`` (k x k), ``b``, ``x`` and ``col_scale`` (k each), and the projection's
    multipliers ``lam`` (r)."""
    rows = stage_rows(method)
    r = max(n_constraints, 2)
    k = n_unknowns
    return ((rows + tables.DOP853_INTERPOLATOR_POWER + WORK_VECTORS) * n_state + n_state + r * n_state // 2 + 2 * r
            + r * r + k * k + 3 * k + r)


def samples_scratch_length(n: int, n_unknowns: int, n_constraints: int) -> int:
    """Doubles of ``solve_states``' scratch: make_system's ``A`` (k x k), ``b``, ``x``, ``col_scale`` (k), ``J``
    (r x n), ``v`` (2 r) and ``G`` (r x r), one constraint row at least."""
    k, r = n_unknowns, max(n_constraints, 1)
    return k * k + 3 * k + r * n + 2 * r + r * r


def solve_pose_scratch_length(n: int, n_unknowns: int, n_constraints: int, pose_size: int) -> int:
    """Doubles of ``solve_pose_states``' scratch: ``solve_states``' and, right after ``b``, the kinematics'
    ``d pose/d theta`` (pose_size x n) and vector (pose, bias, each body's cosine and sine)."""
    return samples_scratch_length(n, n_unknowns, n_constraints) + pose_size * n + 2 * pose_size + 2 * (pose_size // 3)


def states_scratch_length(n: int, r: int) -> int:
    """Doubles of ``project_states``' scratch: ``J`` (r x n), ``v`` (2 r), ``G`` (r x r) and ``lam`` (r)."""
    r = max(r, 1)
    return r * n + 2 * r + r * r + r
