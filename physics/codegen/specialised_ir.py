"""The RK45 and DOP853 drivers of :mod:`physics.codegen.integrator_ir` (and the samples' solve of
:mod:`physics.codegen.samples_ir`) specialised for one system.

The generic drivers read every size (``n``, ``k``, ``r``, the slots of the accelerations) from the layout at run
time, so their loops and the general solve (:mod:`physics.codegen.linear_ir`) run over sizes LLVM cannot see.
Here the same IR is given one system's layout as a constant table: a wrapper with the driver's signature calls
the generic driver (inlined) with that table instead of the caller's layout, and with the system's generated
functions (``assemble``, the fused ``rhs``, the structured solve, the constraints) as declared external symbols
instead of addresses read at run time. LLVM's O2 pipeline then folds the sizes into the code, unrolls the loops
over them and calls the generated functions directly.

No arithmetic changes: the operations, their order and their operands are the generic driver's, without
fast-math flags (nothing may be reassociated or contracted), so every sample, count and status is the generic
driver's, bit for bit (``tests/physics/test_specialised_ir.py``).

The symbols' names carry a digest of the system's own IR texts (never an address), so the specialised module's
text is the same in every process and its machine code is found in the machine-code cache
(:mod:`physics.codegen.machine_code`); the loading process binds each name to its address before linking.
"""

from __future__ import annotations

from llvmlite import ir

from .integrator_ir import FUNCTION_NAMES, integrators_module
from .ir_code import _I64
from .ir_shapes import ADDRESS_SLOTS, SAMPLES_SOLVE_NAME, SAMPLES_SOLVE_POSE_NAME, SPECIALISED_NAMES, symbol_names
from .linear_ir import LinearFunctions
from .samples_ir import add_solve_pose_states, add_solve_states

_OPAQUE = ir.FunctionType(ir.VoidType(), [])  # declared type of the external symbols: only their address is used


def _specialise(module: ir.Module, generic: ir.Function, name: str, layout_values: list[int],
                system_digest: str, first: str = "assemble") -> None:
    """Add ``name`` to ``module``: ``generic``'s signature (``i64 assemble, i64* layout, ...``), calling
    ``generic`` (made internal and always inlined) with the constant layout table and the symbols' addresses
    instead of its first two arguments (the first: the system's function ``first``)."""
    generic.linkage = "internal"
    generic.attributes.add("alwaysinline")
    names = symbol_names(system_digest)

    def address_of(symbol: str):
        declared = module.globals.get(symbol)  # a second entry point of the module shares the declarations
        return (declared if declared is not None else ir.Function(module, _OPAQUE, symbol)).ptrtoint(_I64)

    table = module.globals.get("specialised_layout")  # and the table
    if table is None:
        entries = []
        for slot, value in enumerate(layout_values):
            if slot in ADDRESS_SLOTS and value != 0:
                entries.append(address_of(names[str(slot)]))
            else:
                entries.append(ir.Constant(_I64, int(value)))
        table_type = ir.ArrayType(_I64, len(entries))
        table = ir.GlobalVariable(module, table_type, "specialised_layout")
        table.linkage = "private"
        table.global_constant = True
        table.initializer = ir.Constant(table_type, entries)
    wrapper = ir.Function(module, generic.function_type, name)
    builder = ir.IRBuilder(wrapper.append_basic_block("entry"))
    arguments = list(wrapper.args)
    arguments[0] = address_of(names[first])
    arguments[1] = table.gep([ir.Constant(_I64, 0), ir.Constant(_I64, 0)])
    call = builder.call(generic, arguments)
    if isinstance(generic.function_type.return_type, ir.VoidType):
        builder.ret_void()
    else:
        builder.ret(call)


def specialised_ir(method: str, layout_values: list[int], system_digest: str) -> str:
    """The IR text of ``method``'s driver specialised for the layout ``layout_values`` (the integration layout
    with its address slots set to 0 where the system has no such function, anything else where it has one: the
    address itself never enters the text). The entry point is ``SPECIALISED_NAMES[method]``, of the generic
    driver's signature; its ``assemble`` and ``layout`` arguments are ignored."""
    if method not in FUNCTION_NAMES:
        raise ValueError(f"method = {method!r}: expected one of {sorted(FUNCTION_NAMES)}")
    module = integrators_module((method,))
    _specialise(module, module.get_global(FUNCTION_NAMES[method]), SPECIALISED_NAMES[method], layout_values,
                system_digest)
    return str(module)


def specialised_samples_ir(layout_values: list[int], system_digest: str, pose: bool = False) -> str:
    """The IR text of the samples' solve (:func:`physics.codegen.samples_ir`'s ``solve_states``) specialised
    as :func:`specialised_ir` specialises a driver (``layout_values``: the system's layout for one evaluation
    at a time, without the fused ``rhs``). Entry point ``SAMPLES_SOLVE_NAME``, of ``solve_states``' signature;
    its ``assemble`` and ``layout`` arguments are ignored. ``pose`` (a system with a generated ``sample``):
    also ``SAMPLES_SOLVE_POSE_NAME``, ``solve_pose_states`` specialised the same way (its ``sample`` argument
    ignored)."""
    module = ir.Module(name="linkage_lab_samples_specialised")
    linear = LinearFunctions(module)
    add_solve_states(module, linear)
    _specialise(module, module.get_global("solve_states"), SAMPLES_SOLVE_NAME, layout_values, system_digest)
    if pose:
        add_solve_pose_states(module, linear)
        _specialise(module, module.get_global("solve_pose_states"), SAMPLES_SOLVE_POSE_NAME, layout_values,
                    system_digest, first="sample")
    return str(module)
