"""Named points on the one result type (issue 24): every point a chain or a mechanism names has its path over
the run, by name, from the model's own positions; the CSV/JSON columns stay as they were."""

from __future__ import annotations

import dataclasses
import pickle

import numpy as np
import pytest

import physics
from physics.errors import LinkageError
from physics.mechanism import MECHANISM_PRESETS, Constraints, Prismatic, Revolute
from physics.mechanism.simulate import simulate_mechanism
from physics.model import TracePoint

EPS = np.finfo(float).eps


def _chain_run(preset_name: str, **settings):
    preset = physics.get_preset(preset_name)
    run = physics.simulate(preset.chain, preset.theta0, preset.omega0,
                           physics.Settings(t_end=2.0, samples=41, **settings))
    assert run.success, run.message
    return preset.chain, run


def _formula_joints(L: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """docs/physics.md, "Kinematics": joint k = sum_{i<=k} L_i (sin theta_i, -cos theta_i), joint 0 = O."""
    steps = L[None, :, None] * np.stack([np.sin(theta), -np.cos(theta)], axis=-1)  # (T, n, 2)
    return np.concatenate([np.zeros((theta.shape[0], 1, 2)), np.cumsum(steps, axis=1)], axis=1)


@pytest.mark.parametrize("preset_name", ["triple-a", "four-bar"])
def test_a_chain_names_its_joints_and_each_is_the_chain_formula(preset_name):
    chain, run = _chain_run(preset_name)
    names = ("O", *(f"J{k}" for k in range(1, chain.n)), "H")
    assert run.point_names == names and tuple(run.points) == names and len(run.points) == chain.n + 1
    expected = _formula_joints(chain.array("L"), run.theta)
    for k, name in enumerate(names):
        path = run.point(name)
        assert path.shape == (run.t.size, 2)
        np.testing.assert_allclose(path, expected[:, k], rtol=0, atol=1e-12)
        assert np.array_equal(run.points[name], path)
    assert np.array_equal(run.point("O"), np.zeros((run.t.size, 2)))
    assert np.array_equal(run.point("H"), run.tip_xy)
    if chain.pinned:  # the tip stays on its ground pin H to the run's own constraint report
        np.testing.assert_allclose(run.point("H") - np.asarray(chain.pin), run.constraint_xy, rtol=0, atol=0)
        assert np.max(np.abs(run.point("H") - np.asarray(chain.pin))) < 1e-8


def test_a_chain_traced_point_is_named_trace_and_is_the_bar_point_it_names():
    chain, run = _chain_run("triple-a", trace=TracePoint(bar=2, along=0.3, across=0.1))
    assert run.point_names == ("O", "J1", "J2", "H", "trace")
    theta2 = run.theta[:, 1]
    along = np.stack([np.sin(theta2), -np.cos(theta2)], axis=-1)
    across = np.stack([np.cos(theta2), np.sin(theta2)], axis=-1)
    expected = _formula_joints(chain.array("L"), run.theta)[:, 1] + 0.3 * along + 0.1 * across
    np.testing.assert_allclose(run.point("trace"), expected, rtol=0, atol=1e-12)
    assert np.array_equal(run.point("trace"), run.trace_xy)
    columns = run.columns()
    assert np.array_equal(np.column_stack([columns["trace_x"], columns["trace_y"]]), run.point("trace"))


def _pin_gap(run, joint: Revolute) -> np.ndarray:
    return np.max(np.abs(run.point(joint.a) - run.point(joint.b)), axis=1)


def _guide_offset(run, mechanism, joint: Prismatic) -> np.ndarray:
    """The sliding point's offset across its guide, the guide turned with the body that carries it."""
    direction = np.asarray(joint.direction, dtype=float) / np.hypot(*joint.direction)
    across = np.array([-direction[1], direction[0]])
    if joint.on == "ground":
        phi = np.zeros(run.t.size)
    else:
        phi = run.q[:, 3 * [body.name for body in mechanism.bodies].index(joint.on) + 2]
    normal = np.stack([np.cos(phi) * across[0] - np.sin(phi) * across[1],
                       np.sin(phi) * across[0] + np.cos(phi) * across[1]], axis=-1)
    gap = run.point(f"{joint.body}.{joint.point}") - run.point(f"{joint.on}.{joint.through}")
    return np.abs(np.sum(normal * gap, axis=1))


MECHANISM_RUNS = [("slider-crank", "dae"), ("slider-crank", "lagrange"), ("slider-crank", "reduced"),
                  ("jansen-leg", "dae")]


@pytest.fixture(scope="module", params=MECHANISM_RUNS, ids=["-".join(p) for p in MECHANISM_RUNS])
def mechanism_run(request):
    name, method = request.param
    mechanism = MECHANISM_PRESETS[name]()
    run = simulate_mechanism(mechanism, 1.0, 41, method=method)
    assert run.success, run.message
    return mechanism, run


def test_a_mechanism_names_every_body_point_then_its_ground_points(mechanism_run):
    mechanism, run = mechanism_run
    body_names = [f"{body.name}.{point}" for body in mechanism.bodies for point in body.points]
    assert run.point_names == (*body_names, *(f"ground.{name}" for name in mechanism.ground))
    for name, xy in mechanism.ground.items():
        assert np.array_equal(run.point(f"ground.{name}"), np.tile(xy, (run.t.size, 1)))
    # every body is rigid along the run: its points keep their sketch distances
    for body in mechanism.bodies:
        (first, a), *others = body.points.items()
        for other, b in others:
            distance = np.hypot(*(run.point(f"{body.name}.{other}") - run.point(f"{body.name}.{first}")).T)
            np.testing.assert_allclose(distance, np.hypot(b[0] - a[0], b[1] - a[1]), rtol=0, atol=1e-12)


def test_a_mechanism_point_paths_satisfy_its_joints_to_the_run_residual(mechanism_run):
    mechanism, run = mechanism_run
    scale = max(1.0, float(np.max(np.abs([xy for body in mechanism.bodies for xy in body.points.values()]))))
    rounding = 16 * EPS * scale  # the gap evaluated here and in the constraint rows, each rounded on its own
    pins = [joint for joint in mechanism.joints if isinstance(joint, Revolute)]
    sliders = [joint for joint in mechanism.joints if isinstance(joint, Prismatic)]
    assert pins and (sliders or mechanism.name != "slider-crank")
    for joint in pins:
        gap = _pin_gap(run, joint)
        assert np.all(gap <= run.residual + rounding), (joint.name, float(np.max(gap - run.residual)))
    for joint in sliders:
        offset = _guide_offset(run, mechanism, joint)
        assert np.all(offset <= run.residual + rounding), (joint.name, float(np.max(offset - run.residual)))
    assert np.max(run.residual) < 1e-8  # and the run held its loops: the paths above really do close


def test_a_mechanism_traced_point_is_its_trace_column_exactly(mechanism_run):
    mechanism, run = mechanism_run
    assert mechanism.trace in run.point_names
    traced = run.point(mechanism.trace)
    assert np.array_equal(traced, run.trace_xy)
    columns = run.columns()
    assert np.array_equal(columns["trace_x"], traced[:, 0]) and np.array_equal(columns["trace_y"], traced[:, 1])
    # the point where the constraints put the body's sketch point, pose by pose
    constraints = Constraints(mechanism)
    body, _, point = mechanism.trace.partition(".")
    index = constraints.body_index[body]
    sketch = mechanism.body(body).points[point]
    by_pose = np.array([constraints.body_point(q, index, sketch) for q in run.q])
    np.testing.assert_allclose(traced, by_pose, rtol=0, atol=1e-14)


def test_named_points_leave_the_table_alone(mechanism_run):
    _, run = mechanism_run
    columns = list(run.columns())
    assert columns[:7] == ["t", "trace_x", "trace_y", "kinetic", "potential", "energy", "constraint_residual"]
    assert all(name.startswith("lambda[") for name in columns[7:])


def test_a_bad_point_name_is_one_line_naming_the_allowed_names():
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    run = simulate_mechanism(mechanism, 0.2, 5)
    allowed = ", ".join(run.point_names)
    with pytest.raises(LinkageError) as caught:
        run.point("crank.Z")
    assert str(caught.value) == f"point = 'crank.Z': allowed names {allowed}" and "\n" not in str(caught.value)
    assert "crank.O" in allowed and "ground.O" in allowed
    _, chain_run = _chain_run("triple-a")
    with pytest.raises(LinkageError, match=r"^point = 'E': allowed names O, J1, J2, H$"):
        chain_run.point("E")
    with pytest.raises(LinkageError, match=r"^point = 3: allowed names O, J1, J2, H$"):
        chain_run.point(3)  # type: ignore[arg-type]
    # the mapping answers membership without computing a path, and a missing name as a mapping does
    assert "crank.O" in run.points and "crank.Z" not in run.points
    with pytest.raises(KeyError):
        run.points["crank.Z"]


def test_a_run_without_named_points_says_so():
    run = physics.Trajectory(method="dae", integrator="DOP853", t=np.zeros(2), trace_xy=np.zeros((2, 2)),
                             kinetic=np.zeros(2), potential=np.zeros(2), energy=np.zeros(2), q=np.zeros((2, 3)),
                             qdot=np.zeros((2, 3)))
    assert run.is_mechanism and run.point_names == () and len(run.points) == 0
    with pytest.raises(LinkageError, match=r"^point = 'a\.b': allowed names none \(this run names no points\)$"):
        run.point("a.b")


def test_named_points_travel_with_the_run():
    """A run crosses processes pickled (the app's workers) and is cut into segments by ``dataclasses.replace``
    (physics/long_run.py): its points go with it, and a cut run's paths are the cut paths."""
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    run = simulate_mechanism(mechanism, 0.5, 11)
    copy = pickle.loads(pickle.dumps(run))
    assert copy.point_names == run.point_names
    assert np.array_equal(copy.point("rod.B"), run.point("rod.B"))
    cut = dataclasses.replace(run, t=run.t[3:7], q=run.q[3:7], qdot=run.qdot[3:7])
    assert np.array_equal(cut.point("rod.B"), run.point("rod.B")[3:7])
