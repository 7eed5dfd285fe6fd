"""The compiled path stays lean: a warm ``simulate`` loads neither sympy nor scipy's integrators, linear algebra
or optimisers (scipy is imported only for ``--backend scipy``, the reduced model and the equilibrium solver), and
numba only when a run reaches a numba kernel: the package and its command line load without it, and the DAE
chain's integration (the LLVM IR driver, its machine code from the cache) runs without it."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

CHILD = r"""
import contextlib, io, json, sys
from physics.cli import main
with contextlib.redirect_stdout(io.StringIO()):
    code = main(["simulate", "--preset", "triple-a", "--t-end", "0.5", "--samples", "3", *sys.argv[1:]])
print(json.dumps({"code": code, "modules": sorted(sys.modules)}))
"""


# The modules that build the IR drivers and the samples' pass: a warm run loads their machine code from the cache
# and needs only their entry points' names and scratch sizes (physics.codegen.ir_shapes). llvmlite.ir itself is
# not in the list: llvmlite.binding, which loads the machine code, imports it.
IR_BUILDERS = {"physics.codegen.integrator_ir", "physics.codegen.samples_ir", "physics.codegen.linear_ir",
               "physics.codegen.ir_code"}


@pytest.mark.parametrize("method", ["lagrange", "dae"])
def test_warm_simulate_loads_no_sympy_no_heavy_scipy_and_no_ir_builders(method):
    arguments = [sys.executable, "-c", CHILD, "--method", method]
    subprocess.run(arguments, capture_output=True, timeout=600, check=True)  # fills the cache
    result = subprocess.run(arguments, capture_output=True, text=True, timeout=600, check=True)
    report = json.loads(result.stdout.strip().splitlines()[-1])
    assert report["code"] == 0
    modules = set(report["modules"])
    assert "sympy" not in modules
    heavy = {"scipy.integrate", "scipy.linalg", "scipy.optimize", "scipy.sparse"} & modules
    assert not heavy, sorted(heavy)
    assert "physics.codegen.native_integrators" in modules  # the run went through the IR drivers
    builders = IR_BUILDERS & modules
    assert not builders, sorted(builders)


IMPORTS_ONLY = r"""
import json, sys
import physics, physics.cli, physics.mechanism
print(json.dumps(sorted(sys.modules)))
"""


def test_the_package_and_its_command_line_load_without_numba():
    result = subprocess.run([sys.executable, "-c", IMPORTS_ONLY], capture_output=True, text=True, timeout=600,
                            check=True)
    modules = set(json.loads(result.stdout.strip().splitlines()[-1]))
    assert not {name for name in modules if name == "numba" or name.startswith("numba.")}
    assert "physics.cli" in modules


DAE_INTEGRATION = r"""
import json, sys
import numpy as np
from physics import get_preset, load_compiled
from physics.codegen import machine_code, native_integrators

if sys.argv[1:] == ["loaded"]:  # machine code from the cache: the drivers' IR is never built
    def unexpected(*arguments):
        raise AssertionError("the driver's IR was built")
    native_integrators.integrators_ir = unexpected

preset = get_preset("triple-a")
compiled = load_compiled("dae", preset.chain.n, preset.chain.pinned)
params = np.asarray(preset.chain.params(), dtype=float)
n = preset.chain.n
y0 = np.concatenate([np.asarray(preset.theta0, dtype=float), np.asarray(preset.omega0, dtype=float)])
t_eval = np.linspace(0.0, 0.5, 3)
y_out = np.empty((3, 2 * n))
status = compiled.integrate_dop853(y0, 0.0, 0.5, t_eval, params, 1e-8, 1e-8, 0.0, 0.0, False, 10000, y_out,
                                   np.empty(0))[0]
print(json.dumps({"status": int(status), "finite": bool(np.isfinite(y_out).all()), "counts": machine_code.COUNTS,
                  "numba": sorted(name for name in sys.modules if name == "numba" or name.startswith("numba."))}))
"""


def test_a_warm_dae_integration_runs_on_cached_machine_code_without_numba():
    """The DAE chain's integration is the IR driver calling the generated fused right-hand side: a second
    process loads the machine code of the system's two modules and of the driver from the cache (the driver's
    IR is not even built) and never imports numba."""
    for argument in ("first", "loaded"):  # the first fills the cache (generated file and machine code)
        result = subprocess.run([sys.executable, "-c", DAE_INTEGRATION, argument], capture_output=True, text=True,
                                timeout=600, check=True)
    report = json.loads(result.stdout.strip().splitlines()[-1])
    assert report["status"] == 0 and report["finite"]
    assert report["counts"] == {"compiled": 0, "loaded": 3}  # assemble/solve, the fused rhs, the DOP853 driver
    assert report["numba"] == []
