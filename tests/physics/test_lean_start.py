"""The compiled path stays lean: a warm ``simulate`` loads neither sympy nor scipy's integrators, linear algebra
or optimisers (scipy is imported only for ``--backend scipy``, the reduced model and the equilibrium solver), and
numba only when a run reaches a numba kernel: the package and its command line load without it, and the DAE
chain's integration (the LLVM IR driver, its machine code from the cache) runs without it."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from physics import blas_start

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
               "physics.codegen.ir_code", "physics.codegen.mechanism_run_ir"}


# What only other commands use: the case file's pydantic model (accelerations --input), the ensemble and the cache
# inventory (physics/cli.py imports each in its own command).
OTHER_COMMANDS_MODULES = {"physics.case_file", "physics.ensemble", "physics.codegen.inventory"}


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
    other_commands = OTHER_COMMANDS_MODULES & modules
    assert not other_commands, sorted(other_commands)


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


MECHANISM_COMMAND = r"""
import contextlib, io, json, sys
from physics.cli import main
with contextlib.redirect_stdout(io.StringIO()):
    code = main(sys.argv[1:])
print(json.dumps({"code": code,
                  "numba": sorted(name for name in sys.modules if name == "numba" or name.startswith("numba.")),
                  "mechanism": sorted(name for name in sys.modules if name.startswith("physics.mechanism."))}))
"""


def _warm_command_report(command: list[str], folder: Path) -> dict:
    """:data:`MECHANISM_COMMAND`'s report of the second of two processes running ``command`` on a cache folder
    in ``folder`` (the first fills it)."""
    env = dict(os.environ, LINKAGE_LAB_CACHE=str(folder / "cache"))
    for _ in range(2):
        result = subprocess.run([sys.executable, "-c", MECHANISM_COMMAND, *command], capture_output=True, text=True,
                                timeout=600, check=True, env=env)
    return json.loads(result.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("command", [
    ["mechanism", "--preset", "jansen-leg", "--t-end", "1"],  # driven: position analysis by the IR projection
    ["mechanism", "--preset", "slider-crank", "--t-end", "1"],  # integrated, projected in maximal coordinates
    ["simulate", "--preset", "four-bar", "--t-end", "1"],  # the chain's default: projection onto the pin
], ids=["jansen-leg", "slider-crank", "four-bar"])
def test_a_warm_stabilised_run_never_imports_numba(command, tmp_path):
    """Projection and position analysis are IR too, so a warm run of the presets' defaults loads no numba at all
    (importing it costs 0.2 to 0.4 s): the reduced model's kernel, the one numba kernel a mechanism command may
    call, is imported by a reduced run only."""
    report = _warm_command_report(command, tmp_path)
    assert report["code"] == 0
    assert report["numba"] == []


@pytest.mark.parametrize(("command", "closed_form_reactions"), [
    (["mechanism", "--preset", "slider-crank", "--method", "dae", "--t-end", "1"], False),
    (["mechanism", "--preset", "crank-rocker", "--method", "dae", "--t-end", "1"], False),
    (["mechanism", "--preset", "jansen-leg", "--t-end", "1"], False),
    (["mechanism", "--preset", "crank-rocker", "--method", "lagrange", "--t-end", "1"], True),
], ids=["slider-crank-dae", "crank-rocker-dae", "jansen-leg", "crank-rocker-lagrange"])
def test_a_warm_mechanism_run_never_imports_what_only_a_derivation_or_a_tree_formulation_uses(
        command, closed_form_reactions, tmp_path):
    """The derivation's parameter symbols (physics/mechanism/symbolic_parameters.py) are for sympy's derivations
    alone, and the closed form of the reactions (physics/mechanism/tree_reactions.py) for the tree formulations
    alone: a warm run from cached code never imports the first, and a DAE run (its reactions are its
    multipliers) or a driven one not the second, even for pins closing a loop (the crank-rocker), whose
    assembly asks whether its rows are independent by structure. A tree formulation's run does use it."""
    report = _warm_command_report(command, tmp_path)
    assert report["code"] == 0
    loaded = set(report["mechanism"])
    assert "physics.mechanism.engine" in loaded  # the run went through the mechanism engine
    assert "physics.mechanism.symbolic_parameters" not in loaded
    assert ("physics.mechanism.tree_reactions" in loaded) == closed_form_reactions


LIBRARY_PROCESS = r"""
import json, os, sys
if sys.argv[1:] == ["as-the-command-line"]:  # what ``python -m physics`` shows while it imports the package
    sys.argv[:] = ["-m"]
    sys.orig_argv[:] = [sys.executable, "-m", "physics", "simulate"]
import physics
print(json.dumps({"threads": len(os.listdir("/proc/self/task")), "variable": os.environ.get("OPENBLAS_NUM_THREADS")}))
"""


def _threads_of_a_warm_simulate(extra_environment: dict[str, str]) -> int:
    """The threads of a real ``python -m physics simulate`` process, counted while it writes its table: the table
    is far longer than a pipe holds, so the process waits on the pipe, past every import, until it is read."""
    command = [sys.executable, "-m", "physics", "simulate", "--preset", "triple-a", "--samples", "5001"]
    environment = {key: value for key, value in os.environ.items() if key not in blas_start.THREAD_VARIABLES}
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                               env={**environment, **extra_environment})
    try:
        assert process.stdout is not None and process.stdout.read(1) == b"t"  # the header: the run is done
        threads = len(os.listdir(f"/proc/{process.pid}/task"))
        process.stdout.read()
    finally:
        process.wait(timeout=600)
    assert process.returncode == 0
    return threads


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="counts threads through Linux's /proc")
def test_the_command_line_runs_numpy_with_one_blas_thread_and_leaves_the_environment_as_it_was():
    """physics.blas_start: OpenBLAS's worker pool only spins in a command-line run (a warm simulate's CPU); the
    command line starts numpy without it unless the user chose a thread count, a library process keeps it, and
    the variable that asks for it is gone once numpy is loaded."""
    environment = {key: value for key, value in os.environ.items() if key not in blas_start.THREAD_VARIABLES}
    library, emulated = (
        json.loads(subprocess.run([sys.executable, "-c", LIBRARY_PROCESS, *argument], capture_output=True, text=True,
                                  env=environment, timeout=600, check=True).stdout.strip().splitlines()[-1])
        for argument in ([], ["as-the-command-line"]))
    assert library["variable"] is None and emulated["variable"] is None  # nothing left for a command's children
    if library["threads"] < 2:
        pytest.skip("OpenBLAS starts no worker thread on this machine (one core, or another BLAS)")
    assert emulated["threads"] == 1
    assert _threads_of_a_warm_simulate({}) == 1
    assert _threads_of_a_warm_simulate({"OPENBLAS_NUM_THREADS": "2"}) == 2  # the user's choice stands
