"""The RK45 and DOP853 drivers written as LLVM IR (physics.codegen.integrator_ir) give the numba kernel's very
bits: every sample, the status, the step and evaluation counts and where the run stopped, stabilised or not
(projection onto the constraints, Baumgarte terms). Where the IR driver cannot answer as the kernel would (a
per-sample condition), it says so (None) and the kernel runs. Where the kernel takes its general linear solve (no fused rhs: Lagrange, Newton-Euler; or
a pivot ratio that asks for it), the IR driver takes the same solve written as IR (physics.codegen.linear_ir)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import physics
from physics.codegen import load_compiled, native_integrators
from physics.kernels import explicit_rk
from physics.kernels.constants import STATUS_MAX_STEPS, STATUS_NOT_FINITE, STATUS_OK, STATUS_SINGULAR
from physics.kinematics import joint_positions

KERNELS = {"RK45": explicit_rk.integrate_rk45, "DOP853": explicit_rk.integrate_dop853}
G_INDEX = -4  # chain.params(): [L.., d.., m.., I.., g, pin_x, pin_y, damping]


def _chain_case(preset: str, method: str = "dae", links: int | None = None):
    chosen = physics.get_preset(preset, links)
    compiled = load_compiled(method, chosen.chain.n, chosen.chain.pinned)
    y0 = np.concatenate([chosen.theta0, chosen.omega0]).astype(float)
    return compiled, y0, chosen.chain.params()


def _both(compiled, integrator, y0, t0, t_end, t_eval, params, rtol=1e-6, atol=1e-9, max_steps=1_000_000,
          alpha=0.0, beta=0.0, project=False, layout=None):
    """``(ir_result, ir_samples, kernel_result, kernel_samples)`` of one run; ``ir_result`` None: not answered.
    ``layout``: a run's own (a mechanism's, with its weights); default the system's integration layout."""
    layout = compiled.integration_layout if layout is None else layout
    results = []
    for run in ("ir", "kernel"):
        y_out = np.full((t_eval.size, y0.size), 7.0)  # anything but NaN: the run must write every row
        arguments = (layout, y0, t0, t_end, t_eval, params, rtol, atol, alpha, beta, project, max_steps, y_out,
                     np.empty(0))
        if run == "ir":
            result = native_integrators.integrate(integrator, compiled.assemble_function, *arguments)
        else:
            result = KERNELS[integrator](compiled.assemble_function, *arguments)
            result = (int(result[0]), int(result[1]), int(result[2]), float(result[3]), int(result[4]))
        results += [result, y_out]
    return tuple(results)


def _assert_identical(ir_result, ir_samples, kernel_result, kernel_samples):
    assert ir_result is not None, "the IR driver handed this run back to the kernel"
    assert ir_result == kernel_result
    assert np.array_equal(ir_samples, kernel_samples, equal_nan=True), float(
        np.nanmax(np.abs(ir_samples - kernel_samples)))


@pytest.mark.parametrize("integrator, rtol, atol, t_end", [("RK45", 1e-6, 1e-9, 20.0), ("DOP853", 1e-10, 1e-12, 10.0)])
@pytest.mark.parametrize("preset, links", [("triple-a", None), ("triple-c", None), ("chain", 10)])
def test_an_open_chain_gives_the_kernels_bits(preset, links, integrator, rtol, atol, t_end):
    compiled, y0, params = _chain_case(preset, "dae", links)
    t_eval = np.linspace(0.0, t_end, 200)
    ir_result, ir_samples, kernel_result, kernel_samples = _both(compiled, integrator, y0, 0.0, t_end, t_eval,
                                                                 params, rtol, atol)
    _assert_identical(ir_result, ir_samples, kernel_result, kernel_samples)
    assert ir_result[0] == STATUS_OK and ir_result[4] == 200 and ir_result[1] > 50
    assert np.all(np.isfinite(ir_samples))


@pytest.mark.parametrize("integrator", ["RK45", "DOP853"])
def test_a_pinned_chain_without_stabilisation_takes_the_kernels_geometric_test(integrator):
    """Two constraint rows, no projection, no Baumgarte terms: the loop's condition is judged as the kernel
    judges it, after each step and at the start. The four-bar runs through. A chain pinned where its tip is when
    stretched straight starts at a singular pose (the tip's Jacobian has rank one): there the fused rhs's pivot
    ratio asks for the general path (the equilibrated LU), which finds the system singular, as the kernel's."""
    compiled, y0, params = _chain_case("four-bar")
    t_eval = np.linspace(0.0, 10.0, 301)
    ir_result, ir_samples, kernel_result, kernel_samples = _both(compiled, integrator, y0, 0.0, 10.0, t_eval,
                                                                 params, 1e-8, 1e-10)
    _assert_identical(ir_result, ir_samples, kernel_result, kernel_samples)
    assert ir_result[0] == STATUS_OK and ir_result[4] == 301
    straight = np.concatenate([np.full(3, 0.3), np.zeros(3)])
    pinned = params.copy()
    pinned[-3:-1] = joint_positions(physics.get_preset("four-bar").chain.array("L"), straight[:3])[-1]
    results = _both(compiled, integrator, straight, 0.0, 10.0, t_eval, pinned)
    _assert_identical(*results)
    assert results[0][0] == STATUS_SINGULAR


@pytest.mark.parametrize("integrator", ["RK45", "DOP853"])
def test_a_run_out_of_steps_stops_where_the_kernel_stops(integrator):
    compiled, y0, params = _chain_case("triple-a")
    t_eval = np.linspace(0.0, 20.0, 101)
    ir_result, ir_samples, kernel_result, kernel_samples = _both(compiled, integrator, y0, 0.0, 20.0, t_eval,
                                                                 params, max_steps=17)
    _assert_identical(ir_result, ir_samples, kernel_result, kernel_samples)
    assert ir_result[0] == STATUS_MAX_STEPS and ir_result[1] == 17
    assert 0 < ir_result[4] < 101 and np.all(np.isnan(ir_samples[ir_result[4]:]))


@pytest.mark.parametrize("integrator", ["RK45", "DOP853"])
def test_a_run_of_zero_length_samples_the_start(integrator):
    compiled, y0, params = _chain_case("triple-a")
    t_eval = np.array([1.5, 1.5, 1.5])
    ir_result, ir_samples, kernel_result, kernel_samples = _both(compiled, integrator, y0, 1.5, 1.5, t_eval, params)
    _assert_identical(ir_result, ir_samples, kernel_result, kernel_samples)
    assert ir_result == (STATUS_OK, 0, 1, 1.5, 3)
    assert np.array_equal(ir_samples, np.tile(y0, (3, 1)))


@pytest.mark.parametrize("integrator", ["RK45", "DOP853"])
def test_a_blow_up_gives_the_kernels_status(integrator):
    """Gravity past any real value overflows the accelerations: the same NOT_FINITE at the same step. A NaN
    start: the fused rhs's pivot ratio is NaN, which sends the kernel and the IR driver down the general path
    (whose answer is a singular system)."""
    compiled, y0, params = _chain_case("triple-a")
    huge = params.copy()
    huge[G_INDEX] = 1e306
    t_eval = np.linspace(0.0, 5.0, 51)
    ir_result, ir_samples, kernel_result, kernel_samples = _both(compiled, integrator, y0, 0.0, 5.0, t_eval, huge)
    _assert_identical(ir_result, ir_samples, kernel_result, kernel_samples)
    assert ir_result[0] == STATUS_NOT_FINITE
    start = y0.copy()
    start[1] = np.nan
    results = _both(compiled, integrator, start, 0.0, 5.0, t_eval, params)
    _assert_identical(*results)
    assert results[0][0] == STATUS_SINGULAR


@pytest.mark.parametrize("integrator, rtol, atol, t_end", [("RK45", 1e-6, 1e-9, 20.0), ("DOP853", 1e-10, 1e-12, 10.0)])
@pytest.mark.parametrize("preset, links", [("triple-a", None), ("four-bar", None), ("chain", 10)])
@pytest.mark.parametrize("method", ["lagrange", "newton_euler"])
def test_a_system_without_a_fused_rhs_gives_the_kernels_bits(method, preset, links, integrator, rtol, atol, t_end):
    """Lagrange's and Newton-Euler's chains have no generated fused ``rhs`` (only a structured system has):
    every evaluation takes the general solve (Lagrange's L D L^T, Newton-Euler's pivoted LU, and a pinned
    chain's multipliers), in IR as in the kernel; open and pinned chains."""
    compiled, y0, params = _chain_case(preset, method, links)
    t_eval = np.linspace(0.0, t_end, 200)
    results = _both(compiled, integrator, y0, 0.0, t_end, t_eval, params, rtol, atol)
    _assert_identical(*results)
    assert results[0][0] == STATUS_OK and results[0][4] == 200 and results[0][1] > 20


def test_a_run_asking_for_the_per_sample_condition_is_handed_to_the_kernel():
    compiled, y0, params = _chain_case("four-bar")
    t_eval = np.linspace(0.0, 1.0, 11)
    y_out = np.empty((11, y0.size))
    answer = native_integrators.integrate("RK45", compiled.assemble_function, compiled.integration_layout, y0, 0.0,
                                          1.0, t_eval, params, 1e-6, 1e-9, 0.0, 0.0, True, 10_000, y_out,
                                          np.empty(11))
    assert answer is None


@pytest.mark.parametrize("integrator", ["RK45", "DOP853"])
@pytest.mark.parametrize("stabilisation", ["projection", "baumgarte"])
@pytest.mark.parametrize("method", ["dae", "newton_euler"])
def test_a_stabilised_four_bar_gives_the_kernels_bits(method, stabilisation, integrator):
    """The four-bar's default run (projection onto the pin: every accepted step and every sample, positions
    then velocities) and a Baumgarte run (alpha = beta = 5: the general solve with the terms on the
    constraints' rows, the fused rhs never called), by the IR drivers as by the kernel."""
    compiled, y0, params = _chain_case("four-bar", method)
    t_eval = np.linspace(0.0, 10.0, 301)
    gains = {"alpha": 5.0, "beta": 5.0} if stabilisation == "baumgarte" else {"project": True}
    results = _both(compiled, integrator, y0, 0.0, 10.0, t_eval, params, 1e-8, 1e-10, **gains)
    _assert_identical(*results)
    assert results[0][0] == STATUS_OK and results[0][4] == 301 and results[0][1] > 50
    if stabilisation == "projection":  # held to the projection's tolerance at every sample
        pin = params[-3:-1]
        tips = np.array([joint_positions(physics.get_preset("four-bar").chain.array("L"), row[:3])[-1]
                         for row in results[1]])
        assert np.max(np.abs(tips - pin)) < 1e-12


@pytest.mark.parametrize("integrator", ["RK45", "DOP853"])
def test_a_projecting_runs_failures_give_the_kernels_status(integrator):
    """A NaN start: its projection is not finite, NOT_FINITE before any evaluation (no sample). A start at the
    singular straight pose: the projection leaves it (J W J^T singular), the run stops SINGULAR. Out of steps,
    and a blow-up (gravity past any real value), each where the kernel stops."""
    compiled, y0, params = _chain_case("four-bar")
    t_eval = np.linspace(0.0, 5.0, 51)
    start = y0.copy()
    start[1] = np.nan
    results = _both(compiled, integrator, start, 0.0, 5.0, t_eval, params, project=True)
    _assert_identical(*results)
    assert results[0] == (STATUS_NOT_FINITE, 0, 0, 0.0, 0)
    straight = np.concatenate([np.full(3, 0.3), np.zeros(3)])
    pinned = params.copy()
    pinned[-3:-1] = joint_positions(physics.get_preset("four-bar").chain.array("L"), straight[:3])[-1]
    results = _both(compiled, integrator, straight, 0.0, 5.0, t_eval, pinned, project=True)
    _assert_identical(*results)
    assert results[0][0] == STATUS_SINGULAR
    results = _both(compiled, integrator, y0, 0.0, 5.0, t_eval, params, project=True, max_steps=9)
    _assert_identical(*results)
    assert results[0][0] == STATUS_MAX_STEPS and results[0][1] == 9
    huge = params.copy()
    huge[G_INDEX] = 1e306
    results = _both(compiled, integrator, y0, 0.0, 5.0, t_eval, huge, project=True)
    _assert_identical(*results)
    assert results[0][0] == STATUS_NOT_FINITE


@pytest.mark.parametrize("method", ["dae", "lagrange"])
def test_a_compiled_systems_integrators_give_the_kernels_bits(method):
    """CompiledSystem.integrate_rk45 / integrate_dop853 run the IR drivers (the DAE's fused rhs, Lagrange's
    general solve): the kernel's result either way."""
    compiled, y0, params = _chain_case("triple-a", method)
    t_eval = np.linspace(0.0, 5.0, 101)
    for integrator, through_system in (("RK45", compiled.integrate_rk45), ("DOP853", compiled.integrate_dop853)):
        y_system = np.empty((101, 6))
        result = through_system(y0, 0.0, 5.0, t_eval, params, 1e-8, 1e-10, 0.0, 0.0, False, 100_000, y_system,
                                np.empty(0))
        _, _, kernel_result, kernel_samples = _both(compiled, integrator, y0, 0.0, 5.0, t_eval, params, 1e-8, 1e-10)
        assert tuple(result) == kernel_result
        assert np.array_equal(y_system, kernel_samples)


def test_a_dae_chains_run_never_calls_the_numba_driver():
    """In a fresh process, a DAE chain's compiled RK45 and DOP853 runs (physics.simulate's path) leave numba's
    driver untouched: no overload compiled or loaded from the cache, so an empty cache has nothing of it to
    compile."""
    script = (
        "import numpy as np, physics\n"
        "from physics.codegen import load_compiled\n"
        "from physics.kernels import explicit_rk\n"
        "p = physics.get_preset('triple-a')\n"
        "c = load_compiled('dae', 3, False)\n"
        "y0 = np.concatenate([p.theta0, p.omega0])\n"
        "t = np.linspace(0.0, 2.0, 21)\n"
        "for run in (c.integrate_rk45, c.integrate_dop853):\n"
        "    out = np.empty((21, 6))\n"
        "    assert run(y0, 0.0, 2.0, t, p.chain.params(), 1e-8, 1e-10, 0.0, 0.0, False, 10**6, out,"
        " np.empty(0))[0] == 0\n"
        "print(len(explicit_rk._integrate_explicit_rk.overloads))\n"
    )
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300,
                            cwd=Path(__file__).resolve().parents[2])
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "0"
    assert "compiling" not in result.stderr


@pytest.mark.parametrize("integrator", ["RK45", "DOP853"])
@pytest.mark.parametrize("source, method", [("double-pendulum", "dae"), ("slider-crank", "dae"),
                                            ("jansen-leg", "tree")])
def test_a_mechanism_without_stabilisation_gives_the_kernels_bits(source, method, integrator):
    """Mechanisms hold their joints (r = 4, 8 or 7 rows, with a generated fused rhs): judged after each step by
    J J^T's pivots exactly as the kernel judges them. The double pendulum is the docs' mechanism file, started
    with its bars turning (it hangs at rest in its sketch)."""
    from physics.kernels.abi import LAYOUT_CONSTRAINTS  # noqa: PLC0415
    from physics.mechanism import engine  # noqa: PLC0415
    from physics.mechanism.files import load_mechanism  # noqa: PLC0415
    from physics.mechanism.presets import MECHANISM_PRESETS  # noqa: PLC0415
    from physics.mechanism.simulate import simulate_mechanism  # noqa: PLC0415
    from physics.mechanism.tree_coordinates import tree_state  # noqa: PLC0415

    kick = None
    if source == "double-pendulum":
        mechanism = load_mechanism(Path(__file__).resolve().parents[2] / "docs" / "examples" / "double-pendulum.toml")
        kick = np.array([0.0, 0.0, 2.0, 0.0, 0.0, -1.0])  # projected onto the joints by the assembly
    else:
        mechanism = MECHANISM_PRESETS[source]()
    start = simulate_mechanism(mechanism, 0.01, 2, method="dae", qdot0=kick)
    q, qdot = start.q[0], start.qdot[0]
    if method == "tree":
        q, qdot = tree_state(mechanism, q, qdot)
    compiled = engine.compiled_system(mechanism, method)
    params, layout = engine.run_parameters(mechanism, compiled, 0.0, None)
    assert layout[LAYOUT_CONSTRAINTS] > 2
    y0 = np.ascontiguousarray(np.concatenate([q, qdot]), dtype=float)
    t_eval = np.linspace(0.0, 2.0, 41)
    results = _both(compiled, integrator, y0, 0.0, 2.0, t_eval, params, rtol=1e-9, atol=1e-9, max_steps=100_000,
                    layout=layout)
    _assert_identical(*results)
    assert results[0][0] == STATUS_OK and results[0][4] == 41 and results[0][1] > 10, results[0]


@pytest.mark.parametrize("integrator", ["RK45", "DOP853"])
@pytest.mark.parametrize("method", ["lagrange", "newton_euler", "dae"])
def test_a_light_tip_takes_the_equilibrated_solve_with_the_kernels_bits(method, integrator):
    """A tip a million times lighter than the other bars: the plain solve's pivot ratio passes RESCALE_ABOVE at
    every state, so each evaluation is redone equilibrated (linear.lu_solve_equilibrated), the DAE's after its
    fused rhs answered NOT_FUSED. The IR's rescaled solve gives the kernel's bits (and its status: the DAE's
    equilibrated system is judged singular at the start)."""
    from physics.kernels.linear import ldlt_solve, lu_solve  # noqa: PLC0415
    from physics.kernels.system import RESCALE_ABOVE  # noqa: PLC0415

    compiled, y0, params = _chain_case("triple-a", method)
    light = params.copy()
    light[8] *= 1e-6  # m_3 of [L1..3, d1..3, m1..3, I1..3, ...]
    light[11] *= 1e-6  # I_3
    A, b = compiled.matrix(y0[:3], y0[3:], light)
    plain = (ldlt_solve if compiled.layout[4] else lu_solve).py_func(A.copy(), b.copy(), np.empty(b.size))
    assert plain > RESCALE_ABOVE
    t_eval = np.linspace(0.0, 2.0, 51)
    results = _both(compiled, integrator, y0, 0.0, 2.0, t_eval, light, 1e-8, 1e-10)
    _assert_identical(*results)
    if method == "dae":  # its equilibrated multipliers' pivots pass SINGULAR_PIVOT_RATIO: the kernel stops too
        assert results[0][0] == STATUS_SINGULAR
    else:
        assert results[0][0] == STATUS_OK and results[0][4] == 51


def _mechanism_runs(monkeypatch, name: str, **options):
    """A mechanism preset's run through the engine twice: by the IR drivers (each call answered, counted) and
    with them refused (the numba kernel integrates), as ``(ir_trajectory, kernel_trajectory)``."""
    from physics.mechanism.presets import MECHANISM_PRESETS  # noqa: PLC0415
    from physics.mechanism.simulate import simulate_mechanism  # noqa: PLC0415

    integrate = native_integrators.integrate
    answered = []

    def counted(*arguments):
        answer = integrate(*arguments)
        answered.append(answer is not None)
        return answer

    runs = []
    for refuse in (False, True):
        monkeypatch.setattr(native_integrators, "integrate", (lambda *arguments: None) if refuse else counted)
        runs.append(simulate_mechanism(MECHANISM_PRESETS[name](), 2.0, 41, integrate=True, **options))
    monkeypatch.setattr(native_integrators, "integrate", integrate)
    assert answered == [True]
    return runs


def _assert_same_run(ir_run, kernel_run):
    for field in ("t", "q", "qdot"):
        assert np.array_equal(getattr(ir_run, field), getattr(kernel_run, field)), field
    assert (ir_run.status, ir_run.n_steps, ir_run.n_rhs) == (kernel_run.status, kernel_run.n_steps, kernel_run.n_rhs)


@pytest.mark.parametrize("name", ["slider-crank", "crank-rocker", "chebyshev-lambda", "watt-six-bar",
                                  "stephenson-six-bar", "jansen-leg", "geared-five-bar"])
def test_every_mechanism_preset_with_projection_gives_the_kernels_bits(name, monkeypatch):
    """The general mechanisms' default (projection, DOP853, weighted: rotations by the sketch's size, velocities
    by the inverse mass matrix), integrated for 2 s, by the engine's call of the IR driver and by the kernel:
    the same samples, status and counts; RK45 in the tree coordinates (unit weights)."""
    ir_run, kernel_run = _mechanism_runs(monkeypatch, name, stabilization="projection")
    _assert_same_run(ir_run, kernel_run)
    assert ir_run.t.size == 41 and ir_run.n_steps > 5
    ir_run, kernel_run = _mechanism_runs(monkeypatch, name, stabilization="projection", integrator="RK45",
                                         coordinates="tree", rtol=1e-8, atol=1e-8)
    _assert_same_run(ir_run, kernel_run)


@pytest.mark.parametrize("name", ["slider-crank", "watt-six-bar"])
def test_a_mechanism_with_baumgarte_terms_gives_the_kernels_bits(name, monkeypatch):
    ir_run, kernel_run = _mechanism_runs(monkeypatch, name, stabilization="baumgarte")
    _assert_same_run(ir_run, kernel_run)
    assert ir_run.t.size == 41
