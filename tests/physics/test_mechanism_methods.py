"""Any planar mechanism, third part: choosing the formulation and the stabilisation of a run, and continuing one.

Each formulation integrates its own accelerations (the DAE in maximal coordinates, Lagrange and Newton–Euler in
tree coordinates) and reports its own reactions, so runs of the three methods agreeing is a check of all three;
the stabilisations are told apart by what they do to the constraint residual; a run continued from the end of
another equals one run over both spans.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from physics.errors import LinkageError
from physics.mechanism import MECHANISM_PRESETS
from physics.mechanism.simulate import simulate_mechanism

ROOT = Path(__file__).resolve().parents[2]
METHODS = ("dae", "lagrange", "newton_euler")


@pytest.mark.parametrize("name", ["slider-crank", "watt-six-bar"])
def test_the_three_methods_integrate_the_same_motion_and_reactions(name):
    """Undriven runs of each formulation (its own accelerations integrated, its own reactions) agree."""
    mechanism = MECHANISM_PRESETS[name]()
    runs = {method: simulate_mechanism(mechanism, 0.5, 11, method=method, rtol=1e-12, atol=1e-12)
            for method in METHODS}
    reference = runs["dae"]
    assert np.ptp(reference.potential) > 1e-3 * np.max(np.abs(reference.energy))  # it moves
    for method, run in runs.items():
        assert run.method == method and run.stabilization == "projection" and run.integrated
        assert run.row_names == reference.row_names
        assert np.max(np.abs(run.q - reference.q)) <= 1e-9
        assert np.max(np.abs(run.qdot - reference.qdot)) <= 1e-8
        scale = 1.0 + np.max(np.abs(reference.reaction_rows))
        assert np.max(np.abs(run.reaction_rows - reference.reaction_rows)) <= 1e-8 * scale, method
        assert np.max(run.residual) <= 1e-10


@pytest.mark.parametrize("method", METHODS)
def test_stabilizations_hold_the_loops_as_documented(method):
    """At a loose tolerance the closures drift without stabilisation; Baumgarte's terms pull the drift back by
    more than ten times; projection keeps it at rounding level."""
    mechanism = MECHANISM_PRESETS["watt-six-bar"]()
    worst = {}
    for stabilization in ("none", "baumgarte", "projection"):
        run = simulate_mechanism(mechanism, 3.0, 31, method=method, stabilization=stabilization, rtol=1e-6,
                                 atol=1e-6)
        assert run.stabilization == stabilization
        worst[stabilization] = float(np.max(run.residual))
    assert worst["none"] > 1e-8
    assert worst["baumgarte"] < worst["none"] / 10
    assert worst["projection"] <= 1e-10


@pytest.mark.parametrize("method", METHODS)
def test_a_continued_run_equals_one_run_over_both_spans(method):
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    whole = simulate_mechanism(mechanism, 0.6, 7, method=method, rtol=1e-12, atol=1e-12)
    first = simulate_mechanism(mechanism, 0.3, 4, method=method, rtol=1e-12, atol=1e-12)
    rest = simulate_mechanism(mechanism, 0.3, 4, q0=first.q[-1], qdot0=first.qdot[-1], t_start=float(first.t[-1]),
                              method=method, rtol=1e-12, atol=1e-12)
    assert np.allclose(rest.t, whole.t[3:], rtol=0, atol=1e-15)
    assert np.max(np.abs(rest.q - whole.q[3:])) <= 1e-9
    assert np.max(np.abs(rest.energy - whole.energy[3:])) <= 1e-9 * np.max(np.abs(whole.energy))


@pytest.mark.parametrize("method", METHODS)
def test_a_motor_follows_absolute_time_from_t_start(method):
    mechanism = MECHANISM_PRESETS["crank-rocker"]()
    speed = mechanism.drivers[0].speed
    crank = [body.name for body in mechanism.bodies].index("crank")
    run = simulate_mechanism(mechanism, 0.5, 6, t_start=0.25, method=method)
    assert np.allclose(run.t, np.linspace(0.25, 0.75, 6))
    assert np.allclose(run.q[:, 3 * crank + 2], speed * run.t, atol=1e-10)
    assert not run.integrated and run.method == method
    reference = simulate_mechanism(mechanism, 0.5, 6, t_start=0.25)
    assert np.max(np.abs(run.reaction_rows - reference.reaction_rows)) <= 1e-10 * (1 + np.max(np.abs(reference.reaction_rows)))


@pytest.mark.parametrize(
    "field, value, fragment",
    [
        ("t_end", 0.0, "t_end = 0.0: allowed range 0 < t_end <= 1e4"),
        ("t_end", float("nan"), "t_end = nan: allowed range"),
        ("samples", 1, "samples = 1: allowed range 2 <= samples <= 1000000"),
        ("t_start", float("inf"), "t_start = inf: allowed range"),
        ("method", "rk4", "method = 'rk4': allowed values dae, lagrange, newton_euler"),
        ("stabilization", "both", "stabilization = 'both': allowed values none, baumgarte, projection"),
        ("rtol", 0.5, "rtol = 0.5: allowed range 1e-14 <= rtol <= 1e-2"),
        ("atol", -1.0, "atol = -1.0: allowed range"),
    ],
)
def test_bad_run_options_are_one_line_naming_the_field(field, value, fragment):
    options = {"t_end": 1.0, "samples": 3, field: value}
    with pytest.raises(LinkageError) as error:
        simulate_mechanism(MECHANISM_PRESETS["slider-crank"](), **options)
    message = str(error.value)
    assert message.startswith(fragment) and "\n" not in message


@pytest.mark.parametrize("field, value, got", [("q0", np.zeros(4), "shape (4,)"),
                                               ("qdot0", [0.0] * 8 + [float("nan")], "a non-finite entry"),
                                               ("q0", "pose", "a str")])
def test_a_bad_start_state_is_one_line_naming_it(field, value, got):
    with pytest.raises(LinkageError) as error:
        simulate_mechanism(MECHANISM_PRESETS["slider-crank"](), 1.0, 3, **{field: value})
    assert str(error.value) == f"{field}: expected 9 finite numbers (x, y, phi of each body's centre of mass), got {got}"


def _physics(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "physics", *args], capture_output=True, text=True, timeout=300,
                          cwd=ROOT)


def test_both_commands_take_method_and_stabilization(tmp_path):
    path = tmp_path / "slider.json"
    path.write_text(MECHANISM_PRESETS["slider-crank"]().model_dump_json(), encoding="utf-8")
    result = _physics("mechanism", "--file", str(path), "--t-end", "0.2", "--samples", "3", "--method",
                      "newton_euler", "--stabilization", "baumgarte", "--json", "--out", str(tmp_path / "a.csv"))
    assert result.returncode == 0, result.stderr
    run = json.loads(result.stdout)["run"]
    assert run["method"] == "newton_euler" and run["stabilization"] == "baumgarte"
    result = _physics("simulate", "--mechanism", str(path), "--t-end", "0.2", "--samples", "3", "--method",
                      "newton_euler", "--stabilization", "baumgarte", "--out", str(tmp_path / "b.csv"))
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "a.csv").read_text() == (tmp_path / "b.csv").read_text()
    by_dae = _physics("mechanism", "--file", str(path), "--t-end", "0.2", "--samples", "3", "--out",
                      str(tmp_path / "c.csv"))
    assert by_dae.returncode == 0 and (tmp_path / "c.csv").read_text() != (tmp_path / "a.csv").read_text()
    for args, line in [
        (("mechanism", "--file", str(path), "--method", "euler"),
         "error: method = 'euler': allowed values dae, lagrange, newton_euler, reduced, reduced_fixed"),
        (("simulate", "--mechanism", str(path), "--stabilization", "tight"),
         "error: stabilization = 'tight': allowed values none, baumgarte, projection"),
        (("simulate", "--mechanism", str(path), "--integrator", "variational"),
         "error: integrator = variational: needs method = lagrange (got dae)"),
        (("mechanism", "--file", str(path), "--t-end", "1", "--integrator", "midpoint", "--step", "1e-6",
          "--max-steps", "1000"),
         "error: integrator = midpoint: t_end / step = 1 / 1e-06 = 1e+06 steps, more than max_steps = 1e+03 (about "
         "2 s at 2 us a step); use a larger step, a shorter t_end, or raise max_steps (at most 1e+09)"),
    ]:
        bad = _physics(*args)
        assert bad.returncode == 2 and bad.stdout == "" and bad.stderr.strip() == line, bad.stderr


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", ["slider-crank", "jansen-leg"])
def test_the_compiled_right_hand_sides_equal_the_formulations(name, method):
    """The generated code the kernels call (physics/mechanism/engine.py, numbers as a parameter vector) gives
    every body's accelerations of the numeric DAE at random states, for each formulation; and with Baumgarte
    gains the kernels add exactly ``- 2 alpha Phi' - beta^2 Phi`` to the constraints' rows, checked through the
    accelerations of the DAE written out here."""
    from physics.mechanism import assemble, engine  # noqa: PLC0415
    from physics.mechanism.numeric_dae import MechanismDAE  # noqa: PLC0415
    from physics.mechanism.parameters import parameter_vector  # noqa: PLC0415
    from physics.mechanism.simulate import project_velocity  # noqa: PLC0415
    from physics.mechanism.tree_coordinates import tree_state  # noqa: PLC0415

    mechanism = MECHANISM_PRESETS[name]()
    dae = MechanismDAE(mechanism)
    compiled = engine.compiled_system(mechanism, method)
    rng = np.random.default_rng(11)
    for _ in range(4):
        q = assemble(mechanism, dae.constraints.sketch_pose() + rng.normal(scale=0.05, size=dae.constraints.size)).q
        qdot = project_velocity(dae, q, rng.normal(size=dae.constraints.size))
        t = float(rng.uniform(0.0, 1.0))
        params = parameter_vector(mechanism, t=t)
        x, v = (q, qdot) if method == "dae" else tree_state(mechanism, q, qdot)
        solved = engine.samples(compiled, params, np.array([t]), x[None, :], v[None, :])
        expected = dae.solve(q, qdot).qddot
        assert np.max(np.abs(solved.qddot[0] - expected)) <= 1e-9 * (1 + np.max(np.abs(expected)))
        np.testing.assert_allclose(solved.q[0], q, atol=1e-12)
        if method != "dae":
            continue
        # the Baumgarte terms, written out from the numeric constraints, off the constraints
        x, v = x + rng.normal(scale=1e-3, size=x.size), v + rng.normal(scale=1e-2, size=v.size)
        plain, _ = compiled.accel(x, v, params)
        jacobian, residual = dae.constraints.jacobian(x), dae.constraints.residual(x, t)
        velocity_target, inverse_mass = dae.constraints.velocity_rhs(), 1.0 / dae.mass_diagonal
        applied = dae.applied(v)
        gamma = dae.constraints.acceleration_rhs(x, v) - 2 * 3.0 * (jacobian @ v - velocity_target) - 25.0 * residual
        weighted = jacobian * inverse_mass
        multipliers = np.linalg.solve(weighted @ jacobian.T, gamma - weighted @ applied)
        expected = inverse_mass * (applied + jacobian.T @ multipliers)
        got, _ = compiled.accel(x, v, params, 3.0, 5.0)
        assert np.max(np.abs(got - expected)) <= 1e-10 * (1 + np.max(np.abs(expected)))
        assert np.max(np.abs(got - plain)) > 1e-6  # the terms did something here


@pytest.mark.parametrize("method", ["lagrange", "newton_euler"])
def test_a_fully_driven_mechanism_integrated_by_a_tree_formulation_moves_as_by_kinematics(method):
    mechanism = MECHANISM_PRESETS["chebyshev-lambda"]()
    by_kinematics = simulate_mechanism(mechanism, 1.0, 11, method=method)
    integrated = simulate_mechanism(mechanism, 1.0, 11, method=method, integrate=True, rtol=1e-12, atol=1e-12)
    assert integrated.integrated and not by_kinematics.integrated and integrated.n_steps > 0
    assert np.max(np.abs(by_kinematics.q - integrated.q)) <= 1e-9
    assert np.max(np.abs(by_kinematics.reaction_rows - integrated.reaction_rows)) <= 1e-7 * np.max(
        np.abs(integrated.reaction_rows))


def test_runs_in_threads_at_once_give_the_runs_of_one_thread():
    """One compiled system serves every run of a mechanism in the process; runs in concurrent threads (an app's
    sessions) must not share its buffers."""
    from concurrent.futures import ThreadPoolExecutor  # noqa: PLC0415

    mechanism = MECHANISM_PRESETS["watt-six-bar"]()
    alone = {method: simulate_mechanism(mechanism, 0.3, 4, method=method).q for method in METHODS}
    with ThreadPoolExecutor(max_workers=6) as pool:
        futures = [(method, pool.submit(simulate_mechanism, mechanism, 0.3, 4, method=method))
                   for method in METHODS * 2]
        for method, future in futures:
            assert np.array_equal(future.result().q, alone[method]), method


def test_every_method_and_stabilization_agree_on_an_open_chain_and_a_damped_torque_driven_loop():
    """Loads beyond gravity (a torque motor, pin damping) and a mechanism without loops, through all nine
    combinations: the same motion and reactions at a tight tolerance."""
    from physics import Bar, Chain  # noqa: PLC0415
    from physics.mechanism import Mechanism  # noqa: PLC0415
    from physics.mechanism.chains import chain_mechanism  # noqa: PLC0415

    spec = MECHANISM_PRESETS["crank-rocker"]().model_dump()
    spec["drivers"] = [{"joint": spec["drivers"][0]["joint"], "torque": 0.05}]
    for joint in spec["joints"]:
        joint["damping"] = 0.001
    mechanisms = [chain_mechanism(Chain(bars=[Bar(), Bar()], g=9.81), [0.3, 0.5]), Mechanism.model_validate(spec)]
    for mechanism in mechanisms:
        runs = [simulate_mechanism(mechanism, 1.0, 11, method=method, stabilization=stabilization, rtol=1e-12,
                                   atol=1e-12)
                for method in METHODS for stabilization in ("none", "baumgarte", "projection")]
        reference = runs[0]
        assert np.ptp(reference.q[:, 2]) > 0.1  # it moves
        scale = 1.0 + np.max(np.abs(reference.reaction_rows))
        for run in runs[1:]:
            assert np.max(np.abs(run.q - reference.q)) <= 1e-9, (run.method, run.stabilization)
            assert np.max(np.abs(run.reaction_rows - reference.reaction_rows)) <= 1e-8 * scale, (run.method, run.stabilization)
