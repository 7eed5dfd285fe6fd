"""A mechanism the cache lacks is derived in a worker process, never in the server's interpreter.

A sympy derivation holds the interpreter lock for seconds; in the server it would freeze every other
session's animation. The test runs the app's build path (``app.warm.ensure_ready``) in a fresh interpreter
with an empty derivation cache and checks that the mechanism was built by a worker (the cache holds it
afterwards) while sympy was never imported by the interpreter that asked.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from physics import Settings, get_preset, simulate
from physics.kernels.disk_cache import kernels_folder

ROOT = Path(__file__).resolve().parents[2]

SCRIPT = """
import json, sys
import numpy as np
from app import warm
import physics
from physics import get_preset, Settings
preset = get_preset("chain", links=2)
before = physics.code_missing("newton_euler", 2, False)
built = warm.build_outside("newton_euler", 2, False, "RK45")
warm.ensure_ready(preset.chain, Settings(method="newton_euler", integrator="RK45"), preset.theta0, preset.omega0)
print(json.dumps({"before": before, "built": built, "after": physics.code_missing("newton_euler", 2, False),
                  "sympy": "sympy" in sys.modules}))
"""


@pytest.mark.slow  # a worker process derives a mechanism with sympy
def test_a_missing_mechanism_is_derived_by_a_worker_not_by_the_server(tmp_path):
    # the integrator kernels compile once per installation: bring them along so the test derives only
    preset = get_preset("chain", links=2)
    simulate(preset.chain, preset.theta0, preset.omega0, Settings(method="newton_euler", integrator="RK45", t_end=0.01))
    cache = tmp_path / "cache"
    target = cache / "numba" / kernels_folder().name
    shutil.copytree(kernels_folder(), target)
    os.chmod(cache, 0o700)
    env = dict(os.environ, LINKAGE_LAB_CACHE=str(cache))
    done = subprocess.run([sys.executable, "-c", SCRIPT], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.strip().splitlines()[-1])
    # code missing before, built by the worker, nothing missing after (the chain written as a mechanism: its
    # generated system and the structure's record)
    assert result == {"before": True, "built": True, "after": False, "sympy": False}, (result, done.stderr)


REDUCED_SCRIPT = """
import json, sys
from app import warm
import physics
from physics import get_preset, Settings
preset = get_preset("four-bar")
before = physics.code_missing("reduced", 3, True)
built = warm.build_outside("reduced", 3, True, "DOP853")
warm.ensure_ready(preset.chain, Settings(method="reduced"), preset.theta0, preset.omega0)
print(json.dumps({"before": before, "built": built, "after": physics.code_missing("reduced", 3, True),
                  "sympy": "sympy" in sys.modules}))
"""


@pytest.mark.slow  # a worker process derives the four-bar's Lagrange code and its mechanism's DAE with sympy
def test_the_reduced_models_code_is_derived_by_a_worker_not_by_the_server(tmp_path):
    """The chain's reduced methods run the general reduced model on the four-bar written as a mechanism: the
    server must see that mechanism's generated DAE code missing too (not only the Lagrange system that reads the
    samples), or it would derive it in its own interpreter."""
    preset = get_preset("four-bar")
    simulate(preset.chain, preset.theta0, preset.omega0, Settings(method="reduced", t_end=0.01))  # its kernels
    cache = tmp_path / "cache"
    shutil.copytree(kernels_folder(), cache / "numba" / kernels_folder().name)
    os.chmod(cache, 0o700)
    env = dict(os.environ, LINKAGE_LAB_CACHE=str(cache))
    # an installation that has the system reading the reduced run's samples (the four-bar written as a mechanism,
    # Lagrange, with its record) but not yet the mechanism's DAE code
    derived = subprocess.run([sys.executable, "-c", "from physics import get_preset, code_missing; "
                              "from physics.simulate.chain_system import chain_system; "
                              "chain_system(get_preset('four-bar').chain, 'lagrange'); "
                              "assert not code_missing('lagrange', 3, True)"],
                             cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert derived.returncode == 0, derived.stderr
    done = subprocess.run([sys.executable, "-c", REDUCED_SCRIPT], cwd=ROOT, env=env, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result == {"before": True, "built": True, "after": False, "sympy": False}, (result, done.stderr)
