"""The constraints' geometric singularity test, judged once per accepted step (and at the start) instead of at
every right-hand side: a step that ends at a singular pose is not taken and the run stops where it was, with
the same status; a run released at a singular pose stops at once in every compiled integrator; a healthy run
is the same step for step.

The systems are hand-written (tests/physics/kernel_toys.py, shared with tests/physics/test_kernels.py): the
double pendulum's ``assemble`` with a two-row ``constraints`` function whose Jacobian loses its rank once
``theta_1`` drops below ``params[9]``. Its solve stays healthy throughout, so only the geometric test can stop
the run.
"""

import numpy as np
import pytest

from physics import LinkageError
from physics.kernels import common, explicit_rk, midpoint, ode45, system
from physics.kernels.constants import SINGULAR_PIVOT_RATIO, STATUS_OK, STATUS_SINGULAR

from .kernel_toys import DOUBLE_PARAMS, DOUBLE_Y0, Toy, double_assemble

THRESHOLD = 0.9  # DOUBLE_Y0 is released at rest: theta_1 swings down through 0.9 within 0.5 s


def folding_constraints(theta, omega, params, J, v):
    """Two rows with J = I, whose second row becomes a copy of the first once theta_1 < params[9] (> 0): the
    Jacobian's rank lost, as at a change point; phi and phi_dot are zero (nothing to project)."""
    J[0] = 1.0
    J[1] = 0.0
    J[2] = 0.0
    J[3] = 1.0
    if params[9] > 0.0 and theta[0] < params[9]:
        J[2] = 1.0
        J[3] = 0.0
    for i in range(4):
        v[i] = 0.0


def run(toy, method, t_eval, params, max_steps=10**6):
    """``toy`` run from DOUBLE_Y0 by the compiled ``method`` (no Baumgarte gains, no projection: the constraint
    rows only feed the geometric test)."""
    y_out = np.empty((len(t_eval), 4))
    cond_out = np.empty(len(t_eval))
    t_end = float(t_eval[-1])
    if method == "midpoint":
        result = midpoint.integrate_midpoint(toy.assemble, toy.layout, DOUBLE_Y0, 0.0, t_end, 0.01, t_eval,
                                             params, 0.0, 0.0, False, y_out, cond_out)
    else:
        kernel = {"rk45": explicit_rk.integrate_rk45, "dop853": explicit_rk.integrate_dop853,
                  "ode45": ode45.integrate_ode45}[method]
        result = kernel(toy.assemble, toy.layout, DOUBLE_Y0, 0.0, t_end, t_eval, params, 1e-8, 1e-10, 0.0,
                        0.0, False, max_steps, y_out, cond_out)
    return result, y_out, cond_out


@pytest.fixture(scope="module")
def toys():
    """The double pendulum with the folding rows, and without constraints."""
    return Toy(double_assemble, 2, 2, folding_constraints, rows=(0, 1)), Toy(double_assemble, 2, 2)


def faulty_params():
    params = DOUBLE_PARAMS.copy()
    params[9] = THRESHOLD
    return params


def test_the_stage_right_hand_side_leaves_the_geometric_test_to_the_step(toys):
    """Past the fold the stage's solve is healthy (condition of the mass matrix alone) while the step's test and
    the samples' condition (with the geometric test, as before) say singular."""
    folding, _ = toys
    sys_tuple = system.make_system(folding.assemble, folding.layout)
    params = faulty_params()
    y = np.array([0.5, 0.1, 0.0, 0.0])
    scratch = [np.empty(2) for _ in range(3)]
    dydt = np.empty(4)
    status, condition = common.ode_rhs(sys_tuple, 0.0, y, params, 0.0, 0.0, *scratch, dydt)
    assert status == STATUS_OK and 1.0 <= condition < 100.0
    step, ratio = common.step_status(sys_tuple, 0.0, y, params, scratch[0], scratch[1])
    assert step == STATUS_SINGULAR and ratio == np.inf
    assert common.sample_condition(sys_tuple, 0.0, y, params, 0.0, 0.0, *scratch) == np.inf
    start, start_condition = common.start_rhs(sys_tuple, 0.0, y, params, 0.0, 0.0, *scratch, dydt)
    assert start == STATUS_SINGULAR and start_condition == np.inf
    y[0] = 1.0  # before the fold: J = I, ratio 1, and the start's condition is the solve's
    assert common.step_status(sys_tuple, 0.0, y, params, scratch[0], scratch[1]) == (STATUS_OK, 1.0)
    start, start_condition = common.start_rhs(sys_tuple, 0.0, y, params, 0.0, 0.0, *scratch, dydt)
    assert start == STATUS_OK and start_condition == common.ode_rhs(sys_tuple, 0.0, y, params, 0.0, 0.0, *scratch,
                                                                    dydt)[1]


@pytest.mark.parametrize("method", ["rk45", "dop853", "ode45", "midpoint"])
def test_a_step_that_ends_at_a_singular_pose_stops_the_run_where_it_was(toys, method):
    folding, plain = toys
    t_eval = np.linspace(0.0, 2.0, 201)
    (status, n_steps, _, t_reached, n_filled), y_out, cond_out = run(folding, method, t_eval, faulty_params())
    (healthy_status, *_), y_healthy, _ = run(folding, method, t_eval, DOUBLE_PARAMS)
    crossing = t_eval[np.argmax(y_healthy[:, 0] < THRESHOLD)]
    assert status == STATUS_SINGULAR and healthy_status == STATUS_OK
    assert 0.0 < t_reached < crossing and n_steps > 0
    assert n_filled == np.count_nonzero(t_eval <= t_reached) and n_filled >= 2
    assert np.all(np.isnan(y_out[n_filled:])) and np.all(np.isnan(cond_out[n_filled:]))
    np.testing.assert_array_equal(y_out[:n_filled], y_healthy[:n_filled])  # the healthy run up to the stop
    assert np.all(y_out[:n_filled, 0] >= THRESHOLD) and np.all(cond_out[:n_filled] < SINGULAR_PIVOT_RATIO)
    # It stopped at the first step that ends past the fold: the healthy run's next step ends there.
    if method == "midpoint":
        next_end = t_reached + 0.01
        assert t_reached == pytest.approx(n_steps * 0.01, rel=1e-12)
    else:
        (_, _, _, reached, _), _, _ = run(folding, method, t_eval, DOUBLE_PARAMS, max_steps=n_steps)
        assert reached == t_reached
        (_, _, _, next_end, _), _, _ = run(folding, method, t_eval, DOUBLE_PARAMS, max_steps=n_steps + 1)
    (_, *_), y_next, _ = run(folding, method, np.array([0.0, next_end]), DOUBLE_PARAMS)
    assert y_next[1, 0] < THRESHOLD
    # Without the constraints the run is the same, step for step and evaluation for evaluation.
    healthy_result, y_folding, _ = run(folding, method, t_eval, DOUBLE_PARAMS)
    plain_result, y_plain, _ = run(plain, method, t_eval, DOUBLE_PARAMS)
    assert healthy_result == plain_result
    np.testing.assert_array_equal(y_folding, y_plain)


@pytest.mark.parametrize("integrator, method, step", [
    ("RK45", "dae", None), ("ode45", "dae", None), ("midpoint", "dae", 1e-3), ("variational", "lagrange", 1e-3),
])
def test_every_compiled_integrator_released_at_the_change_point_stops_at_once(integrator, method, step):
    """The start's geometric test in each compiled integrator (DOP853's is tests/physics/
    test_mechanism_singularity.py): the same one line naming the time and the loop's joints."""
    from physics.mechanism.simulate import simulate_mechanism  # noqa: PLC0415
    from physics.studies.mechanism_stability import change_point_mechanism  # noqa: PLC0415

    mechanism, _ = change_point_mechanism(1e-6)
    with pytest.raises(LinkageError) as error:
        simulate_mechanism(mechanism, 1.0, 11, method=method, integrator=integrator, step=step)
    message = str(error.value)
    assert "singular pose at t = 0 s" in message and "\n" not in message, message
    assert set(message.split("joints ")[1].split(" became")[0].split(", ")) == {"O", "J1", "J2", "H"}, message
