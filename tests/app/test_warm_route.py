"""The app's warm-up and its worker builds follow the one route a chain's run takes (issue 24, "one pipeline").

A chain runs as a mechanism on the general engine: warming the chain's own generated kernel would cost a session
a derivation it never uses, and a worker that built the chain's kernel would leave the server to derive the
route itself (sympy in the server's interpreter, every other session's animation frozen).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import physics
from app import warm
from physics import Settings, get_preset, simulate
from physics import codegen as codegen_module
from physics.codegen import cache as cache_module
from physics.codegen import prebuild as prebuild_module
from physics.codegen import prebuild_worker
from physics.kernels.disk_cache import kernels_folder
from physics.simulate import reduced_adapter

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def fresh_warm(monkeypatch):
    """The app's once-per-process memory of what it loaded and warmed, empty for this test only."""
    monkeypatch.setattr(warm, "_loaded", set())
    monkeypatch.setattr(warm, "_ready", set())


def _refused(*_arguments, **_keywords):
    raise AssertionError("the chain's own generated system was loaded by the warm-up")


@pytest.mark.parametrize(("preset_name", "method"), [("triple-a", "lagrange"), ("four-bar", "dae"),
                                                     ("double", "newton_euler"), ("four-bar", "reduced")])
def test_the_warm_up_never_loads_the_chains_own_kernel(preset_name, method, monkeypatch, fresh_warm):
    preset = get_preset(preset_name)
    settings = Settings(method=method)
    # the route's code and record in this test's cache (derived here on a miss, so the warm-up below builds nothing)
    simulate(preset.chain, preset.theta0, preset.omega0, settings.model_copy(update={"t_end": 0.02, "samples": 2}))
    assert not physics.code_missing(method, preset.chain.n, preset.chain.pinned)
    for module in (cache_module, codegen_module, physics):
        monkeypatch.setattr(module, "load_compiled", _refused)
    monkeypatch.setattr(warm.subprocess, "Popen", _refused)  # nothing missing: no worker either
    warm.ensure_ready(preset.chain, settings, preset.theta0, preset.omega0)
    assert warm.is_ready(preset.chain, settings)
    assert warm.is_loaded(method, preset.chain.n, preset.chain.pinned)


def test_the_warm_up_loads_the_routes_systems(monkeypatch, fresh_warm):
    """A reduced method's samples are read by the pinned Lagrange system, the DAE's by its own: the chain written
    as a mechanism for each, once per structure."""
    preset = get_preset("four-bar")
    loaded: list[tuple] = []
    chain_system = prebuild_module.chain_system

    def recorded(chain, formulation, damping=0.0):
        loaded.append((chain.n, chain.pinned, formulation))
        return chain_system(chain, formulation, damping)

    monkeypatch.setattr(prebuild_module, "chain_system", recorded)
    warm.ensure_loaded(preset.chain, "reduced")
    warm.ensure_loaded(preset.chain, "dae")
    warm.ensure_loaded(preset.chain, "dae")
    assert loaded == [(3, True, "lagrange"), (3, True, "dae")]
    assert warm.is_loaded("dae", 3, True)


def test_the_worker_command_is_the_four_argument_one(monkeypatch):
    """The server starts ``python -m physics.codegen.prebuild_worker METHOD N open|pinned INTEGRATOR``; the worker
    refuses anything else with its usage line."""
    started: list[list[str]] = []

    def popen(command, **_keywords):
        started.append(command)
        raise OSError("not started in this test")

    monkeypatch.setattr(physics, "code_missing", lambda *_arguments: True)
    monkeypatch.setattr(warm.subprocess, "Popen", popen)
    assert warm.build_outside("lagrange", 3, True, "DOP853") is False  # the worker did not start: build in-process
    assert started == [[sys.executable, "-m", "physics.codegen.prebuild_worker", "lagrange", "3", "pinned",
                        "DOP853"]]
    assert prebuild_worker.main(["dae", "4", "open", "RK45", "mechanism"]) == 2  # the old route argument: gone
    assert prebuild_worker.main(["dae", "4", "sideways", "RK45"]) == 2
    assert prebuild_worker.main(["dae", "four", "open", "RK45"]) == 2


class _InterruptedWorker:
    """A build worker the terminal's Ctrl+C reached: ended by SIGINT, its traceback in its own stderr."""

    returncode = -2

    def __init__(self, command, stdout=None, stderr=None, **_keywords):
        stderr.write("Traceback (most recent call last):\nKeyboardInterrupt\n")

    def wait(self, timeout=None):
        return self.returncode

    def poll(self):
        return self.returncode

    def kill(self):
        raise AssertionError("an ended worker is not killed")


@pytest.mark.parametrize("stopping", [False, True], ids=["serving", "stopping"])
def test_a_worker_interrupted_while_the_server_stops_is_no_build_failure(monkeypatch, capsys, stopping):
    """Ctrl+C reaches the whole group, a build worker too. While the server serves, a worker that failed is
    reported and the server builds in-process; while it stops (an ending signal arrived), the worker's end is
    the stop: no line, no build in the server (it said "worker build failed ...; building in the server" and
    began compiling as it stopped)."""
    monkeypatch.setattr(physics, "code_missing", lambda *_arguments: True)
    monkeypatch.setattr(warm.subprocess, "Popen", _InterruptedWorker)
    monkeypatch.setattr(warm.lifetime, "stopping", lambda: stopping)
    if stopping:
        with pytest.raises(warm.Cancelled):
            warm.build_outside("lagrange", 3, True, "DOP853")
        assert capsys.readouterr().err == ""
    else:
        assert warm.build_outside("lagrange", 3, True, "DOP853") is False
        assert capsys.readouterr().err == "linkage-lab: worker build failed (KeyboardInterrupt); building in the server\n"


def test_the_worker_module_starts_without_a_runpy_warning():
    """``import physics`` imports physics.codegen.prebuild; the worker is a module of its own, so ``-m`` does not
    import it a second time (runpy's RuntimeWarning on every start, before)."""
    done = subprocess.run([sys.executable, "-W", "error::RuntimeWarning", "-m", "physics.codegen.prebuild_worker"],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    assert done.stderr.strip() == prebuild_worker.USAGE


def test_a_pinned_structure_chain_closes_its_loop():
    chain, theta0, _ = prebuild_module.structure_chain(5, True)
    tip = physics.joint_positions(chain.array("L"), theta0)[-1]
    assert chain.pinned and chain.n == 5
    np.testing.assert_allclose(tip, chain.pin, atol=1e-12)


@pytest.mark.parametrize("method", ["reduced", "reduced_fixed"])
def test_a_reduced_runs_samples_are_read_through_chain_system_unchanged(method):
    """The reduced adapter reads its samples with the pinned Lagrange system through chain_system: exactly the
    mechanism route's Trajectory (tests/physics/test_chain_on_mechanism.py checks it against the chain's own
    formulas)."""
    from physics.simulate.mechanism_route import reduced_samples_trajectory  # noqa: PLC0415

    preset = get_preset("four-bar")
    settings = Settings(method=method, t_end=2.0, samples=40)
    got = reduced_adapter.simulate_reduced_trajectory(preset.chain, preset.theta0, preset.omega0, settings, 0.0)
    expected = reduced_adapter.simulate_reduced_trajectory(preset.chain, preset.theta0, preset.omega0, settings,
                                                           0.0, build=reduced_samples_trajectory)
    assert got.status == expected.status
    for field in ("t", "theta", "omega", "energy", "trace_xy", "reactions", "tip_reaction", "condition"):
        np.testing.assert_array_equal(getattr(got, field), getattr(expected, field), err_msg=field)


WORKER_SCRIPT = """
import json, sys
from physics.simulate import mechanism_route
import physics
from app import warm
from physics import Settings, get_preset
derived = []
derive = mechanism_route.derived_route
def counted(*arguments, **keywords):
    derived.append(arguments[1])
    return derive(*arguments, **keywords)
mechanism_route.derived_route = counted
def refused(*arguments, **keywords):
    raise AssertionError("the chain's own generated system was loaded by the server")
for module in (physics, sys.modules["physics.codegen"], sys.modules["physics.codegen.cache"]):
    module.load_compiled = refused
preset = get_preset("{preset}")
settings = Settings(method="{method}", integrator="RK45")
n, pinned = preset.chain.n, preset.chain.pinned
before = physics.code_missing("{method}", n, pinned)
built = warm.build_outside("{method}", n, pinned, "RK45")
after = physics.code_missing("{method}", n, pinned)
warm.ensure_ready(preset.chain, settings, preset.theta0, preset.omega0)
run = physics.simulate(preset.chain, preset.theta0, preset.omega0, settings.model_copy(update={{"t_end": 0.1}}))
print(json.dumps({{"before": before, "built": built, "after": after, "derived": derived, "status": int(run.status),
                  "engine": "physics.mechanism.engine" in sys.modules,
                  "sympy": "sympy" in sys.modules}}))
"""


@pytest.mark.slow  # a worker process derives the route's system with sympy
@pytest.mark.parametrize(("preset_name", "method"), [("double", "lagrange"), ("four-bar", "dae")])
def test_a_worker_builds_the_route_so_the_server_derives_nothing(preset_name, method, tmp_path):
    preset = get_preset(preset_name)
    # the route's run kernels compile once: bring them along
    simulate(preset.chain, preset.theta0, preset.omega0, Settings(method=method, integrator="RK45", t_end=0.01))
    cache = tmp_path / "cache"
    shutil.copytree(kernels_folder(), cache / "numba" / kernels_folder().name)
    os.chmod(cache, 0o700)
    env = dict(os.environ, LINKAGE_LAB_CACHE=str(cache))
    script = WORKER_SCRIPT.format(preset=preset_name, method=method)
    done = subprocess.run([sys.executable, "-c", script], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result == {"before": True, "built": True, "after": False, "derived": [], "status": 0,
                      "engine": False, "sympy": False}, (result, done.stderr[-2000:])
    assert list(cache.glob(f"chainroute-{method.replace('_', '')}-n{preset.chain.n}-*.json"))  # the worker's record
