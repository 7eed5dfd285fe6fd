"""Any planar mechanism, second part: the maximal-coordinate DAE and its motion.

Independent checks: a chain written as a mechanism gives the accelerations and reactions of the derived chain
formulations; a motor's torque equals the power balance computed from kinematics alone; undriven mechanisms keep
their energy and their constraints over a run.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from physics import load_compiled
from physics.chain_presets import get_preset
from physics.errors import LinkageError
from physics.mechanism import MECHANISM_PRESETS, Mechanism
from physics.mechanism.assembly import kinematics, track
from physics.mechanism.chains import chain_mechanism, chain_state
from physics.mechanism.numeric_dae import MechanismDAE
from physics.mechanism.simulate import simulate_mechanism
from physics.model import Bar, Chain

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("n", [1, 2, 3, 5])
def test_a_chain_as_a_mechanism_matches_the_derived_chain_dae(n):
    rng = np.random.default_rng(50 + n)
    system = load_compiled("dae", n, False)
    for _ in range(20):
        chain = Chain(bars=[Bar(L=rng.uniform(0.5, 2), d=rng.uniform(0.1, 0.5), m=rng.uniform(0.5, 2),
                                I=rng.uniform(0.01, 0.3)) for _ in range(n)], g=9.81)
        sketch = rng.uniform(-np.pi, np.pi, n)
        theta, omega = rng.uniform(-np.pi, np.pi, n), rng.uniform(-3, 3, n)
        dae = MechanismDAE(chain_mechanism(chain, sketch))
        solution = dae.solve(*chain_state(chain, sketch, theta, omega))
        x, _ = system.solve_full(theta, omega, chain.params())
        theta_ddot = x[system.theta_ddot_index]
        reactions = x[system.reaction_index]  # (n, 2): ON bar k+1 BY bar k (or the ground)
        scale = np.max(np.abs(theta_ddot)) + 9.81
        assert np.max(np.abs(solution.qddot[2::3] - theta_ddot)) <= 1e-10 * scale
        force_scale = np.max(np.abs(reactions)) + 9.81 * sum(b.m for b in chain.bars)
        assert np.max(np.abs(solution.reactions.reshape(n, 2) - reactions)) <= 1e-10 * force_scale


def test_the_seed_four_bar_as_a_mechanism_matches_its_pin_reaction():
    preset = get_preset("four-bar")
    chain = preset.chain
    system = load_compiled("lagrange", 3, True)
    theta, omega = preset.theta0, np.zeros(3)
    dae = MechanismDAE(chain_mechanism(chain, theta))
    solution = dae.solve(*chain_state(chain, theta, theta, omega))
    x, _ = system.solve_full(theta, omega, chain.params())
    assert np.max(np.abs(solution.qddot[2::3] - x[system.theta_ddot_index])) <= 1e-10
    # the last pin joins a = bar 3's tip to b = the ground at H: its multipliers are the force ON bar 3 BY the
    # ground, the chain's R_H
    assert np.max(np.abs(solution.reactions[-2:] - x[system.tip_reaction_index])) <= 1e-10


@pytest.mark.parametrize("name", ["crank-rocker", "chebyshev-lambda", "jansen-leg"])
def test_motor_torque_equals_the_power_balance_from_kinematics(name):
    """tau * omega = d/dt (T + V), with the rates of T and V computed from kinematics alone."""
    mechanism = MECHANISM_PRESETS[name]()
    speed = mechanism.drivers[0].speed
    dae = MechanismDAE(mechanism)
    driver_row = [k for k, row in enumerate(dae.constraints.rows) if row.meaning == "driven angle"][0]
    times = np.linspace(0.0, 2 * math.pi / speed, 25)
    for q in track(mechanism, times):
        qdot, qddot = kinematics(mechanism, q)
        power = float(qdot @ (dae.mass_diagonal * qddot) - qdot @ dae.gravity)  # dT/dt + dV/dt
        solution = dae.solve(q, qdot)
        assert np.allclose(solution.qddot, qddot, atol=1e-9 * (1 + np.max(np.abs(qddot))))
        torque = solution.reactions[driver_row]
        assert torque * speed == pytest.approx(power, abs=1e-9 * (1 + abs(power)))


@pytest.mark.parametrize("name", ["slider-crank", "watt-six-bar", "stephenson-six-bar"])
def test_undriven_mechanisms_keep_energy_and_constraints(name):
    mechanism = MECHANISM_PRESETS[name]()
    run = simulate_mechanism(mechanism, t_end=2.0, samples=21, rtol=1e-12, atol=1e-12)
    assert np.max(run.residual) <= 1e-10
    scale = max(abs(run.energy[0]), np.max(np.abs(run.potential - run.potential[0])), 1e-9)
    drift = np.max(np.abs(run.energy - run.energy[0])) / scale
    assert drift <= 1e-8, drift
    assert np.ptp(run.potential) > 1e-3 * scale  # it moved: the energy test is not of a mechanism at rest


def test_a_speed_driven_mechanism_follows_its_motor():
    mechanism = MECHANISM_PRESETS["crank-rocker"]()
    run = simulate_mechanism(mechanism, t_end=1.0, samples=11)
    crank = [b.name for b in mechanism.bodies].index("crank")
    assert np.allclose(run.q[:, 3 * crank + 2], mechanism.drivers[0].speed * run.t, atol=1e-10)
    assert np.max(run.residual) <= 1e-10


def test_a_singular_pose_is_refused_in_one_line():
    chain = Chain(bars=[Bar(), Bar(), Bar()], g=9.81, pin=(0.0, -3.0))
    mechanism: Mechanism = chain_mechanism(chain, [0.0, 0.0, 0.0])  # all bars in line: a singular position
    with pytest.raises(LinkageError, match="over-constrained|singular"):
        MechanismDAE(mechanism).solve(*chain_state(chain, [0.0] * 3, [0.0] * 3, [0.0] * 3))


def _physics(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "physics", "mechanism", *args], capture_output=True, text=True,
                          timeout=300, cwd=ROOT)


def test_command_reports_topology_and_writes_a_run(tmp_path):
    result = _physics("--preset", "watt-six-bar", "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["mobility"] == report["grubler_mobility"] == 1 and len(report["loops"]) == 2
    out = tmp_path / "rocker.csv"
    result = _physics("--preset", "crank-rocker", "--t-end", "0.5", "--samples", "6", "--out", str(out), "--json")
    assert result.returncode == 0, result.stderr
    rows = out.read_text().splitlines()
    assert len(rows) == 7 and rows[0].startswith("t,trace_x,trace_y,kinetic,potential,energy,constraint_residual")
    assert json.loads(result.stdout)["run"]["max_constraint_residual"] <= 1e-10


@pytest.mark.parametrize(
    "args, fragment",
    [
        ((), "give one of --preset NAME or --file"),
        (("--file", "/nonexistent/m.toml"), "cannot read it"),
        (("--preset", "slider-crank", "--t-end", "-1"), "t_end = -1.0: allowed range"),
        (("--preset", "slider-crank", "--samples", "1"), "--samples 1: allowed range"),
        (("--preset", "pentagon",), "--preset"),
    ],
)
def test_command_bad_input_is_one_line(args, fragment):
    result = _physics(*args)
    assert result.returncode == 2 and result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and fragment in lines[0] and "Traceback" not in result.stderr, result.stderr


def test_a_fully_driven_mechanism_moves_by_kinematics_as_the_integrated_dae_does():
    mechanism = MECHANISM_PRESETS["chebyshev-lambda"]()
    by_kinematics = simulate_mechanism(mechanism, t_end=1.0, samples=11)
    integrated = simulate_mechanism(mechanism, t_end=1.0, samples=11, integrate=True, rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(by_kinematics.q - integrated.q)) <= 1e-9
    assert np.max(np.abs(by_kinematics.reaction_rows - integrated.reaction_rows)) <= 1e-7 * np.max(np.abs(integrated.reaction_rows))


def test_simulate_takes_a_mechanism_file(tmp_path):
    """Issue 16: ``python -m physics simulate --mechanism FILE`` runs a mechanism file as the mechanism command
    does; a chain option that does not apply to it (--links) is refused with one line naming it and what applies."""
    path = tmp_path / "rocker.json"
    path.write_text(MECHANISM_PRESETS["crank-rocker"]().model_dump_json(), encoding="utf-8")
    out = tmp_path / "run.csv"
    run = subprocess.run([sys.executable, "-m", "physics", "simulate", "--mechanism", str(path), "--t-end", "0.5",
                          "--samples", "6", "--out", str(out)], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert run.returncode == 0, run.stderr
    assert len(out.read_text().splitlines()) == 7 and "wrote" in run.stdout
    same = _physics("--file", str(path), "--t-end", "0.5", "--samples", "6", "--out", str(tmp_path / "same.csv"))
    assert same.returncode == 0 and (tmp_path / "same.csv").read_text() == out.read_text()
    bad = subprocess.run([sys.executable, "-m", "physics", "simulate", "--mechanism", str(path), "--links", "3"],
                         capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert bad.returncode == 2 and bad.stderr.strip() == (
        "error: --links: does not apply to a mechanism (the number of bars of preset chain); a mechanism's run takes "
        "--t-end, --samples, --method, --stabilization, --rtol, --atol, --integrator, --step, --max-steps, --backend, "
        "--set, --out, --format, --json")
    missing = subprocess.run([sys.executable, "-m", "physics", "simulate", "--mechanism", str(tmp_path / "no.toml")],
                             capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert missing.returncode == 2 and missing.stderr.count("\n") == 1 and "cannot read it" in missing.stderr
