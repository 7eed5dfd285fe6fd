"""Every integrator of the registry runs any mechanism (issue 24, "One engine"): the compiled kernels with dense
output (RK45, DOP853, ode45, midpoint, variational) and scipy's solvers on the same right-hand side (Radau,
LSODA, and RK45/DOP853 on the scipy back end), described by the chain's own Settings.

Checked against independent numbers: a DOP853 run at a far tighter tolerance (the adaptive integrators must
agree with it to their tolerance), the fixed-step integrators' second order (the error falls four times when
the step halves), the energy of an undriven, undamped mechanism (bounded, not drifting, under the symmetric
fixed-step integrators), the prescribed angle of a speed motor (the clock reaches scipy's right-hand side), and
a run stopped midway (its status, its sentence, and the samples before the stop equal the complete run's).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from physics.cli import main
from physics.errors import LinkageError
from physics.mechanism import MECHANISM_PRESETS
from physics.mechanism.simulate import run_options, simulate_mechanism
from physics.model import Settings
from physics.registry import ADAPTIVE_INTEGRATORS, FIXED_STEP_INTEGRATORS, INTEGRATORS, SCIPY
from physics.status import Status

PRESETS = ("slider-crank", "watt-six-bar")  # undriven, mobility 1: one loop of three bodies, two loops of five
T_END, SAMPLES = 0.4, 5


def _reference(name: str, method: str = "dae"):
    return simulate_mechanism(MECHANISM_PRESETS[name](), T_END, SAMPLES, method=method, rtol=1e-13, atol=1e-13)


def _scale(run) -> float:
    return 1.0 + float(np.max(np.abs(run.reaction_rows)))


@pytest.mark.parametrize("name", PRESETS)
@pytest.mark.parametrize("integrator, backend", [(name, backend) for name in ADAPTIVE_INTEGRATORS
                                                 for backend in INTEGRATORS[name].backends])
def test_every_adaptive_integrator_agrees_with_a_tight_dop853_run(name, integrator, backend):
    """At rtol = atol = 1e-10 every adaptive integrator, on each back end it runs on, gives the poses and every
    reaction row of a DOP853 run at 1e-13 to within 1e-7; the run says which integrator produced it."""
    reference = _reference(name)
    run = simulate_mechanism(MECHANISM_PRESETS[name](), T_END, SAMPLES, integrator=integrator, backend=backend)
    assert run.success and run.message == "ok" and run.integrator == integrator and run.integrated
    assert run.n_steps > 0 and run.n_rhs >= run.n_steps
    np.testing.assert_allclose(run.t, reference.t, rtol=0, atol=0)
    assert np.max(np.abs(run.q - reference.q)) < 1e-7, integrator
    assert np.max(np.abs(run.reaction_rows - reference.reaction_rows)) < 1e-6 * _scale(reference), integrator
    assert np.max(run.residual) < 1e-9  # projection after every step (every sample for scipy's solvers)


@pytest.mark.parametrize("name", PRESETS)
@pytest.mark.parametrize("integrator", FIXED_STEP_INTEGRATORS)
def test_fixed_step_integrators_converge_at_second_order(name, integrator):
    """Midpoint (on the DAE) and variational (on Lagrange's tree coordinates, where the Lagrangian lives): the
    error against a tight DOP853 run falls by 4 (3.5..4.5) each time the step halves, and the loops stay closed."""
    method = "lagrange" if INTEGRATORS[integrator].needs_lagrangian else "dae"
    reference = _reference(name, method)
    errors = []
    for step in (4e-3, 2e-3, 1e-3):
        run = simulate_mechanism(MECHANISM_PRESETS[name](), T_END, SAMPLES, integrator=integrator, method=method,
                                 step=step)
        assert run.success and run.integrator == integrator and run.n_steps == round(T_END / step)
        assert np.max(run.residual) < 1e-9
        errors.append(float(np.max(np.abs(run.q - reference.q))))
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    assert all(3.5 < ratio < 4.5 for ratio in ratios), (errors, ratios)
    assert errors[-1] < 1e-3


@pytest.mark.parametrize("integrator", FIXED_STEP_INTEGRATORS)
def test_an_undriven_undamped_mechanism_keeps_its_energy_under_the_symmetric_integrators(integrator):
    """The slider-crank (no motor, no damping) over 10 s of swinging on Lagrange's tree coordinates: the energy
    error is bounded (the second half's largest no more than 1.2 times the first half's: no drift), second order
    in the step, and small against the kinetic energy the swing reaches."""
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    worst = {}
    for step in (1e-2, 5e-3):
        run = simulate_mechanism(mechanism, 10.0, 1001, integrator=integrator, method="lagrange", step=step)
        assert run.success
        error = np.abs(run.energy - run.energy[0])
        first, second = float(np.max(error[:500])), float(np.max(error[500:]))
        assert second <= 1.2 * first, (step, first, second)
        worst[step] = max(first, second)
        assert worst[step] < 0.05 * float(np.max(run.kinetic))
    assert 3.0 < worst[1e-2] / worst[5e-3] < 5.0, worst


def test_a_speed_motors_clock_reaches_scipys_right_hand_side():
    """The crank-rocker integrated (not position analysis) by Radau with Baumgarte terms, which pull the crank
    towards the motor's angle at the time the right-hand side is evaluated: it follows ``speed * t``."""
    mechanism = MECHANISM_PRESETS["crank-rocker"]()
    run = simulate_mechanism(mechanism, 0.5, 11, integrator="Radau", stabilization="baumgarte", integrate=True)
    crank = [body.name for body in mechanism.bodies].index("crank")
    assert run.success and run.integrated and run.integrator == "Radau"
    np.testing.assert_allclose(run.q[:, 3 * crank + 2], mechanism.drivers[0].speed * run.t, atol=1e-8)


def test_a_mechanism_its_motors_drive_ignores_the_integrator_and_says_so():
    """The Jansen leg (mobility 0) is position analysis whatever integrator is asked for: the same samples, and
    ``integrator`` says "position analysis"."""
    mechanism = MECHANISM_PRESETS["jansen-leg"]()
    plain = simulate_mechanism(mechanism, 0.5, 6)
    asked = simulate_mechanism(mechanism, 0.5, 6, integrator="RK45")
    assert not asked.integrated and asked.integrator == plain.integrator == "position analysis"
    np.testing.assert_array_equal(asked.q, plain.q)


@pytest.mark.parametrize("integrator, backend", [("DOP853", "compiled"), ("RK45", "scipy"), ("Radau", "scipy")])
def test_a_run_that_runs_out_of_steps_returns_its_status_and_the_samples_before(integrator, backend):
    """``max_steps`` too small to reach the end: no exception, ``status`` MAX_STEPS with the one-line sentence
    naming the fix, and the samples up to the stop equal the complete run's."""
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    whole = simulate_mechanism(mechanism, 1.0, 21, integrator=integrator, backend=backend)
    stopped = simulate_mechanism(mechanism, 1.0, 21, integrator=integrator, backend=backend, max_steps=20)
    assert whole.success and stopped.status == Status.MAX_STEPS and not stopped.success
    assert "reached max_steps" in stopped.message and "raise max_steps" in stopped.message
    assert "\n" not in stopped.message and stopped.message.startswith("slider-crank: ")
    count = len(stopped.t)
    assert 1 <= count < 21 and stopped.n_steps == 20
    np.testing.assert_array_equal(stopped.t, whole.t[:count])
    assert np.all(np.isfinite(stopped.q)) and stopped.reaction_rows.shape == (count, whole.reaction_rows.shape[1])
    np.testing.assert_allclose(stopped.q, whole.q[:count], atol=1e-9)
    reached = float(stopped.message.split("at t = ")[1].split(" s")[0])
    assert stopped.t[-1] <= reached < whole.t[count]


@pytest.mark.parametrize("options, line", [
    ({"integrator": "variational"}, "integrator = variational: needs method = lagrange (got dae)"),
    ({"integrator": "midpoint", "backend": "scipy"}, "integrator = midpoint: available with backend = compiled only"),
    ({"integrator": "ode45", "backend": "scipy"}, "integrator = ode45: available with backend = compiled only"),
    ({"integrator": "RK45", "method": "reduced"}, "integrator = RK45: method 'reduced' integrates with DOP853 only"),
    ({"integrator": "euler"}, "integrator = 'euler': allowed values RK45, DOP853, ode45, Radau, LSODA, midpoint, "
                              "variational"),
    ({"backend": "gpu"}, "backend = 'gpu': allowed values compiled, scipy"),
    ({"integrator": "midpoint", "step": 2.0}, "step = 2.0: allowed range 0 < step <= 1"),
    ({"max_steps": 0}, "max_steps = 0: allowed range 1 <= max_steps <= 1e9"),
    ({"integrator": "midpoint", "step": 1e-6, "max_steps": 1000}, "integrator = midpoint: t_end / step = 1 / 1e-06"),
    ({"settings": Settings(damping=0.5)}, "damping = 0.5: does not apply to a mechanism"),
])
def test_a_combination_that_cannot_run_is_one_line_naming_the_field(options, line):
    with pytest.raises(LinkageError) as error:
        simulate_mechanism(MECHANISM_PRESETS["slider-crank"](), 1.0, 3, **options)
    message = str(error.value)
    assert message.startswith(line) and "\n" not in message, message


def test_a_chains_settings_describe_a_mechanisms_run():
    """``settings=`` (the chain's Settings) gives the run its method, integrator, step and Baumgarte gains; the
    run equals the one asked with the same keywords, and run_options builds that Settings."""
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    settings = Settings(method="lagrange", integrator="midpoint", step=2e-3, stabilization="baumgarte",
                        baumgarte_alpha=5.0, baumgarte_beta=5.0)
    by_settings = simulate_mechanism(mechanism, 0.2, 3, settings=settings)
    checked = run_options(t_end=0.2, samples=3, settings=settings)
    assert isinstance(checked, Settings) and checked.baumgarte_alpha == 5.0 and checked.t_end == 0.2
    assert by_settings.method == "lagrange" and by_settings.integrator == "midpoint"
    stiffer = simulate_mechanism(mechanism, 0.2, 3, method="lagrange", integrator="midpoint", step=2e-3,
                                 stabilization="baumgarte")  # the default gains, 10
    assert np.max(np.abs(by_settings.q - stiffer.q)) > 0.0  # the gains reached the right-hand side
    again = simulate_mechanism(mechanism, 0.2, 3, settings=settings.model_copy(update={"baumgarte_alpha": 10.0,
                                                                                       "baumgarte_beta": 10.0}))
    np.testing.assert_array_equal(again.q, stiffer.q)


def test_the_command_line_runs_every_integrator_and_reports_it(capsys, tmp_path):
    """``simulate --preset slider-crank --integrator NAME``: the table has exactly the default run's columns, and
    ``--json`` names the integrator; Radau runs on scipy without --backend (as for a chain)."""
    headers = {}
    for integrator, extra in (("DOP853", ()), ("RK45", ()), ("Radau", ()), ("midpoint", ("--step", "0.002")),
                              ("variational", ("--method", "lagrange", "--step", "0.002"))):
        out = tmp_path / f"{integrator}.csv"
        code = main(["simulate", "--preset", "slider-crank", "--t-end", "0.2", "--samples", "3", "--integrator",
                     integrator, *extra, "--out", str(out), "--json"])
        report = json.loads(capsys.readouterr().out)["run"]
        assert code == 0 and report["integrator"] == integrator and report["steps"] > 0
        headers[integrator] = out.read_text().splitlines()[0]
    assert len(set(headers.values())) == 1
    code = main(["mechanism", "--preset", "jansen-leg", "--t-end", "0.2", "--samples", "3", "--integrator", "RK45",
                 "--json"])
    report = json.loads(capsys.readouterr().out)["run"]
    assert code == 0 and report["integrator"] == "position analysis" and report["steps"] == 0


def test_the_command_line_keeps_a_stopped_runs_samples_in_partial(capsys, tmp_path):
    """A run out of --max-steps: exit 3, its one line last on stderr, the samples before the stop in
    OUT.partial (as a chain's run), and no OUT."""
    out = tmp_path / "run.csv"
    code = main(["simulate", "--preset", "slider-crank", "--t-end", "1", "--samples", "21", "--max-steps", "20",
                 "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 3 and not out.exists() and err[-1].startswith("error: slider-crank: the integrator reached")
    rows = (tmp_path / "run.csv.partial").read_text().splitlines()
    assert 2 <= len(rows) < 22 and f"the {len(rows) - 1} samples up to" in err[-1]


def test_every_compiled_integrator_is_reachable_by_a_mechanisms_run():
    """The registry's compiled kernels all have a module in the engine's table (a new one without is caught
    here, not by a user's KeyError)."""
    import importlib  # noqa: PLC0415

    from physics.mechanism.engine import KERNEL_MODULES  # noqa: PLC0415

    for spec in INTEGRATORS.values():
        if spec.kernel is not None:
            module = importlib.import_module(f"physics.kernels.{KERNEL_MODULES[spec.kernel]}")
            assert callable(getattr(module, spec.kernel)), spec.name
    assert SCIPY in {backend for spec in INTEGRATORS.values() for backend in spec.backends}


def test_a_segmented_run_spends_one_step_budget_and_keeps_what_it_computed(monkeypatch):
    """The command line's segmented run (physics/long_run.py): ``max_steps`` is the whole run's budget, as for
    a chain's segments; the run that spends it stops with MAX_STEPS and keeps its samples on the run's times,
    close to the unsegmented run's."""
    from physics import long_run  # noqa: PLC0415

    monkeypatch.setattr(long_run, "PROBE_SPAN", 0.1)
    monkeypatch.setattr(long_run, "SEGMENTED_AFTER", 0.0)
    monkeypatch.setattr(long_run, "MAX_MECHANISM_SEGMENT", 0.1)  # ten segments of 0.1 s
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    whole = simulate_mechanism(mechanism, 1.0, 21)
    complete, message = long_run.simulate_mechanism_in_segments(mechanism, 1.0, 21, "dae", "projection")
    assert message is None and complete.success and complete.n_steps > 60
    np.testing.assert_allclose(complete.q, whole.q, atol=1e-7)
    run, message = long_run.simulate_mechanism_in_segments(mechanism, 1.0, 21, "dae", "projection", max_steps=60)
    assert run.status == Status.MAX_STEPS and message == run.message and "reached max_steps" in message
    assert run.n_steps <= 60 and 2 <= len(run.t) < 21
    np.testing.assert_array_equal(run.t, whole.t[:len(run.t)])
    np.testing.assert_allclose(run.q, whole.q[:len(run.t)], atol=1e-7)


def test_a_reduced_run_that_stops_midway_returns_its_status_and_the_samples_before(monkeypatch):
    """The reduced model through simulate_mechanism: a run that stops midway (here: made to switch its coordinate
    often, and allowed only one switch) keeps the samples recorded before the stop, equal to the complete
    run's, with the status and the sentence; simulate_reduced itself still raises (its own API)."""
    from physics.mechanism import reduced  # noqa: PLC0415

    monkeypatch.setattr(reduced, "SWITCH_SHARE", 0.999)
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    whole = simulate_mechanism(mechanism, 1.0, 21, method="reduced")
    switched = reduced.simulate_reduced(mechanism, 1.0, 21).switches
    assert whole.success and whole.integrator == "DOP853" and len(switched) >= 2
    monkeypatch.setattr(reduced, "MAX_SWITCHES", 1)
    stopped = simulate_mechanism(mechanism, 1.0, 21, method="reduced")
    assert stopped.status == Status.SINGULAR and "more than 1 coordinate switches" in stopped.message
    count = len(stopped.t)
    assert 1 <= count < 21 and stopped.t[-1] <= switched[1].t
    np.testing.assert_array_equal(stopped.t, whole.t[:count])
    np.testing.assert_allclose(stopped.q, whole.q[:count], atol=1e-12)
    with pytest.raises(LinkageError, match="more than 1 coordinate switches"):
        reduced.simulate_reduced(mechanism, 1.0, 21)
