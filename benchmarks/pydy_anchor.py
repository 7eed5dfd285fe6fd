"""Anchor for the BENCHMARKS.md target "beat PyDy cold at n=10": the n-link compound pendulum done the PyDy way.

    python -m benchmarks.pydy_anchor [--links 3 10] [--t-end 10] [--timeout 1800]

PyDy's own n-link pendulum example is the model: sympy.physics.mechanics builds the chain with absolute angles
(one frame per bar, rotated about N.z by theta_i, angular velocity omega_i N.z), KanesMethod derives the equations
with the kinematic equations theta_i' = omega_i, ``pydy.system.System(...).generate_ode_function(generator=
"lambdify")`` generates the right-hand side (lambdified mass matrix and forcing, solved numerically at every call),
and scipy's ``solve_ivp`` (RK45, rtol = atol = 1e-6) integrates 10 s with 101 output samples. PyDy's
generated function returns one reused output array (made for odeint, which copies it); solve_ivp keeps earlier
derivatives by reference, so the anchor copies each result (without the copy the initial step is chosen from
a clobbered f0 and the run differs from RK45's by up to 2e-4 after 1 s).

Conventions and numbers are Linkage Lab's (docs/architecture.md): bar i is ``-B_i.y`` = (sin theta_i,
-cos theta_i), centre of mass at d_i along it, centroidal inertia I_i about z, gravity g along -N.y; the chain is
``physics.get_preset("chain", links=n)``: L = 1, d = 0.5, m = 1, I = 1/12, g = 1, released at rest with every
theta = pi/2. The child process does not import ``physics`` (a PyDy user would not); the parent checks that these
numbers are the preset's.

Every n runs in a fresh subprocess (``--child N``), cold: its whole-process wall time (interpreter start, imports,
derivation, code generation, integration) is measured by the parent, and the split (import, derive, generate,
integrate) inside the child. The parent then checks the physics: the anchor's state after 1 s for n = 3 must agree
with ``physics.simulate`` of the same chain (Lagrange, compiled RK45, same tolerances: both take the same steps)
to 1e-6.

PyDy is an optional dependency (the ``bench`` extra); without it the command says how to install it and exits 2.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
DEFAULT_LINKS = (3, 10)
T_END = 10.0
SAMPLES = 101  # 0.1 s apart, as physics.simulate's default 201 samples over 20 s
RTOL = 1e-6
ATOL = 1e-6
CHECK_LINKS = 3
CHECK_T_END = 1.0
CHECK_TOLERANCE = 1e-6
CHILD_TIMEOUT_S = 1800.0
MISSING_PYDY = "pydy is not installed: pip install -e '.[bench]'"

# physics.get_preset("chain", links=n): uniform rods released at rest lying horizontal.
CHAIN_L = 1.0
CHAIN_D = 0.5
CHAIN_M = 1.0
CHAIN_I = 1.0 / 12.0
CHAIN_G = 1.0
CHAIN_THETA0 = math.pi / 2


def pydy_available() -> bool:
    return importlib.util.find_spec("pydy") is not None


# ---------------------------------------------------------------------------------------------------------------
# The model, the PyDy way


def derive_chain(n: int):
    """KanesMethod for the n-link compound pendulum; returns ``(kane, theta, omega, constants)`` where
    ``constants`` maps each parameter symbol to its value."""
    import sympy as sm
    import sympy.physics.mechanics as me

    theta = me.dynamicsymbols(f"theta1:{n + 1}")
    omega = me.dynamicsymbols(f"omega1:{n + 1}")
    lengths = sm.symbols(f"L1:{n + 1}")
    com_distances = sm.symbols(f"d1:{n + 1}")
    masses = sm.symbols(f"m1:{n + 1}")
    inertias = sm.symbols(f"I1:{n + 1}")
    g = sm.symbols("g")

    ground = me.ReferenceFrame("N")
    joint = me.Point("O")
    joint.set_vel(ground, 0)
    bodies, loads, kinematic_equations = [], [], []
    for i in range(n):
        bar_frame = ground.orientnew(f"B{i + 1}", "Axis", [theta[i], ground.z])
        bar_frame.set_ang_vel(ground, omega[i] * ground.z)
        # Along bar i, from its proximal joint: -B_i.y = (sin theta_i, -cos theta_i) in N.
        centre = joint.locatenew(f"G{i + 1}", -com_distances[i] * bar_frame.y)
        centre.v2pt_theory(joint, ground, bar_frame)
        central_inertia = (me.inertia(bar_frame, 0, 0, inertias[i]), centre)
        bodies.append(me.RigidBody(f"bar{i + 1}", centre, bar_frame, masses[i], central_inertia))
        loads.append((centre, -masses[i] * g * ground.y))
        kinematic_equations.append(theta[i].diff() - omega[i])
        distal = joint.locatenew(f"P{i + 1}", -lengths[i] * bar_frame.y)
        distal.v2pt_theory(joint, ground, bar_frame)
        joint = distal
    kane = me.KanesMethod(ground, q_ind=theta, u_ind=omega, kd_eqs=kinematic_equations)
    kane.kanes_equations(bodies, loads)
    constants = {}
    for i in range(n):
        constants.update({lengths[i]: CHAIN_L, com_distances[i]: CHAIN_D, masses[i]: CHAIN_M, inertias[i]: CHAIN_I})
    constants[g] = CHAIN_G
    return kane, theta, omega, constants


def generate_rhs(kane, theta, omega, constants, t_end: float):
    """PyDy's System and its lambdify generator: ``(rhs(t, y, p), p, y0)`` for solve_ivp."""
    import numpy as np
    from pydy.system import System

    system = System(
        kane,
        initial_conditions={**{q: CHAIN_THETA0 for q in theta}, **{u: 0.0 for u in omega}},
        times=np.linspace(0.0, t_end, SAMPLES),
    )
    # The last bar's length does not enter the equations of an open chain: give PyDy only the symbols it found.
    system.constants = {symbol: constants[symbol] for symbol in system.constants_symbols}
    evaluate = system.generate_ode_function(generator="lambdify", constants_arg_type="array", time_first=True)

    def rhs(t, y, p):
        # PyDy returns the same output array on every call (fine for odeint, which copies it); solve_ivp keeps
        # references to earlier derivatives (select_initial_step's f0), so each result must be a fresh array.
        return evaluate(t, y, p).copy()

    parameter_values = np.array([constants[symbol] for symbol in system.constants_symbols], dtype=float)
    y0 = np.array([system.initial_conditions[s] for s in system.states], dtype=float)
    return rhs, parameter_values, y0


def integrate(rhs, parameter_values, y0, t_end: float, samples: int):
    import numpy as np
    from scipy.integrate import solve_ivp

    return solve_ivp(
        rhs, (0.0, t_end), y0, method="RK45", t_eval=np.linspace(0.0, t_end, samples), rtol=RTOL, atol=ATOL,
        args=(parameter_values,),
    )


# ---------------------------------------------------------------------------------------------------------------
# One cold run (child process)


def run_child(n: int, t_end: float) -> dict:
    start = time.perf_counter()
    import numpy  # noqa: F401
    import pydy.system  # noqa: F401
    import scipy.integrate  # noqa: F401
    import sympy.physics.mechanics  # noqa: F401

    imported = time.perf_counter()
    kane, theta, omega, constants = derive_chain(n)
    derived = time.perf_counter()
    rhs, parameter_values, y0 = generate_rhs(kane, theta, omega, constants, t_end)
    generated = time.perf_counter()
    solution = integrate(rhs, parameter_values, y0, t_end, SAMPLES)
    integrated = time.perf_counter()
    final = solution.y[:, -1]
    return {
        "links": n,
        "import_s": imported - start,
        "derive_s": derived - imported,
        "generate_s": generated - derived,
        "integrate_s": integrated - generated,
        "inside_total_s": integrated - start,
        "nfev": int(solution.nfev),
        "success": bool(solution.success),
        "message": solution.message,
        "final_theta": [float(v) for v in final[:n]],
        "final_omega": [float(v) for v in final[n:]],
    }


# ---------------------------------------------------------------------------------------------------------------
# Parent: fresh subprocess per n, then the physics check


def time_cold(n: int, t_end: float, timeout: float) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(REPO_ROOT) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    start = time.perf_counter()
    try:
        done = subprocess.run(
            [sys.executable, "-m", "benchmarks.pydy_anchor", "--child", str(n), "--t-end", repr(t_end)],
            cwd=REPO_ROOT, env=env, capture_output=True, text=True, timeout=timeout, check=False,
        )
    except subprocess.TimeoutExpired:
        return {"links": n, "error": f"timed out after {timeout:.0f} s"}
    wall = time.perf_counter() - start
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or [f"exit {done.returncode}"])[-1]
        return {"links": n, "error": last}
    row = json.loads(done.stdout.strip().splitlines()[-1])
    row["process_wall_s"] = wall
    return row


def check_against_physics(n: int = CHECK_LINKS, t_end: float = CHECK_T_END) -> dict:
    """The anchor's state after ``t_end`` against physics.simulate (Lagrange, compiled RK45, same tolerances)."""
    import numpy as np

    import physics

    preset = physics.get_preset("chain", links=n)
    params = preset.chain.params()
    expected_params = np.concatenate([
        np.full(n, CHAIN_L), np.full(n, CHAIN_D), np.full(n, CHAIN_M), np.full(n, CHAIN_I), [CHAIN_G, 0.0, 0.0, 0.0],
    ])
    same_chain = bool(
        np.array_equal(params, expected_params)
        and np.array_equal(preset.theta0, np.full(n, CHAIN_THETA0))
        and not np.any(preset.omega0)
    )
    kane, theta, omega, constants = derive_chain(n)
    rhs, parameter_values, y0 = generate_rhs(kane, theta, omega, constants, t_end)
    anchor = integrate(rhs, parameter_values, y0, t_end, 2)
    settings = physics.Settings(method="lagrange", integrator="RK45", rtol=RTOL, atol=ATOL, t_end=t_end, samples=2)
    ours = physics.simulate(preset.chain, preset.theta0, preset.omega0, settings)
    anchor_final = anchor.y[:, -1]
    ours_final = np.concatenate([ours.theta[-1], ours.omega[-1]])
    difference = float(np.max(np.abs(anchor_final - ours_final)))
    return {
        "links": n,
        "t_end": t_end,
        "same_chain_as_preset": same_chain,
        "anchor_final_state": [float(v) for v in anchor_final],
        "physics_final_state": [float(v) for v in ours_final],
        "max_abs_diff": difference,
        "tolerance": CHECK_TOLERANCE,
        "anchor_nfev": int(anchor.nfev),
        "physics_n_rhs": int(ours.n_rhs),
        "agree": same_chain and difference <= CHECK_TOLERANCE,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.pydy_anchor", description=__doc__.split("\n\n")[0])
    parser.add_argument("--links", type=int, nargs="+", default=list(DEFAULT_LINKS), help="chain sizes (1..12)")
    parser.add_argument("--t-end", type=float, default=T_END, help="integrated seconds")
    parser.add_argument("--timeout", type=float, default=CHILD_TIMEOUT_S, help="per-subprocess limit (s)")
    parser.add_argument("--no-check", action="store_true", help="skip the check against physics.simulate")
    parser.add_argument("--child", type=int, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if not pydy_available():
        print(MISSING_PYDY)
        return 2
    if args.child is not None:
        print(json.dumps(run_child(args.child, args.t_end)))
        return 0
    bad = [n for n in args.links if not 1 <= n <= 12]
    if bad:
        parser.error(f"--links: {bad} outside 1..12")
    import pydy
    import scipy
    import sympy

    result = {
        "command": "python -m benchmarks.pydy_anchor " + " ".join(argv if argv is not None else sys.argv[1:]),
        "versions": {"pydy": pydy.__version__, "sympy": sympy.__version__, "scipy": scipy.__version__,
                     "python": sys.version.split()[0]},
        "settings": {"integrator": "RK45", "rtol": RTOL, "atol": ATOL, "t_end": args.t_end, "samples": SAMPLES,
                     "generator": "lambdify"},
        "load_average_at_start": os.getloadavg(),
        "cold": [time_cold(n, args.t_end, args.timeout) for n in args.links],
    }
    if not args.no_check:
        try:
            result["check_vs_physics"] = check_against_physics()
        except Exception as error:  # noqa: BLE001 (physics failing is a result to report, not a crash)
            result["check_vs_physics"] = {"error": f"{type(error).__name__}: {error}", "agree": False}
    result["load_average_at_end"] = os.getloadavg()
    print(json.dumps(result, indent=2))
    failed = any("error" in row or not row.get("success") for row in result["cold"])
    if not args.no_check and not result["check_vs_physics"]["agree"]:
        failed = True
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
