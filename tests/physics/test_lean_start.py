"""The compiled path stays lean: a warm ``simulate`` loads neither sympy nor scipy's integrators, linear algebra
or optimisers (scipy is imported only for ``--backend scipy``, the reduced model and the equilibrium solver)."""

from __future__ import annotations

import json
import subprocess
import sys

CHILD = r"""
import contextlib, io, json, sys
from physics.cli import main
with contextlib.redirect_stdout(io.StringIO()):
    code = main(["simulate", "--preset", "triple-a", "--t-end", "0.5", "--samples", "3"])
print(json.dumps({"code": code, "modules": sorted(sys.modules)}))
"""


def test_warm_simulate_loads_no_sympy_and_no_heavy_scipy():
    subprocess.run([sys.executable, "-c", CHILD], capture_output=True, timeout=600, check=True)  # fills the cache
    result = subprocess.run([sys.executable, "-c", CHILD], capture_output=True, text=True, timeout=600, check=True)
    report = json.loads(result.stdout.strip().splitlines()[-1])
    assert report["code"] == 0
    modules = set(report["modules"])
    assert "sympy" not in modules
    heavy = {"scipy.integrate", "scipy.linalg", "scipy.optimize", "scipy.sparse"} & modules
    assert not heavy, sorted(heavy)
