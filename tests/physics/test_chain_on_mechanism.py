"""A chain's run, on the one route it takes (the chain written as a mechanism on the general engine:
physics/simulate/mechanism_route.py), against the chain's own formulas: at every sample the
route's accelerations, reactions, positions, energies and condition equal what the chain's independent
derivations give at the sample's state (tests/physics/chain_formulas.py), for a representative set of chains
and settings; the run's times, status, sentence and counts are the chain's.

The tolerances are the chain's formulas' against the route's at the same state:

* :data:`ROUNDING` 1e-11 relative (to 1 + the largest value): the same equations summed in another order (the
  four-bar's tree even hangs bar 3 from the tip's pin, another but equivalent Lagrangian); a change of the
  equations, the reactions' rows or their signs would be off by order one.
* :data:`BAUMGARTE` 1e-9: Baumgarte's terms feed the loop's residual back with gains ``alpha = beta = 10``
  (beta^2 = 100 on a position residual of rounding size), so rounding shows more in the solved unknowns.
* :data:`NEWTON` 1e-8: the variational integrator's table entry, kept from the comparison of whole runs this
  test made while the chain had a route of its own.
"""

from __future__ import annotations

import numpy as np
import pytest

from physics import Settings, get_preset, simulate
from physics.simulate.chain_prepared import sample_times
from physics.status import Status

from .chain_formulas import ROUNDING, assert_run_follows_chain_formulas, relative

BAUMGARTE = 1e-9
NEWTON = 1e-8

SHORT = {"t_end": 2.0, "samples": 21}

CASES = [
    # (id, preset, links, settings, tolerance)
    *[(f"{preset}-{method}", preset, None, {"method": method, **SHORT}, ROUNDING)
      for preset in ("single", "double", "triple-a", "triple-b", "triple-c", "four-bar")
      for method in ("newton_euler", "lagrange", "dae")],
    *[(f"chain5-{method}", "chain", 5, {"method": method, **SHORT}, ROUNDING)
      for method in ("newton_euler", "lagrange", "dae")],
    ("change-point-lagrange", "change-point", None, {"method": "lagrange", **SHORT}, ROUNDING),
    ("four-bar-reduced", "four-bar", None, {"method": "reduced", **SHORT}, ROUNDING),
    ("four-bar-reduced_fixed", "four-bar", None, {"method": "reduced_fixed", **SHORT}, ROUNDING),
    ("four-bar-dae-none", "four-bar", None, {"method": "dae", "stabilization": "none", **SHORT}, ROUNDING),
    *[(f"four-bar-{method}-baumgarte", "four-bar", None,
       {"method": method, "stabilization": "baumgarte", **SHORT}, BAUMGARTE) for method in ("lagrange", "dae")],
    ("triple-a-dae-damped", "triple-a", None, {"method": "dae", "damping": 0.3, **SHORT}, ROUNDING),
    ("four-bar-lagrange-damped", "four-bar", None, {"method": "lagrange", "damping": 0.3, **SHORT}, ROUNDING),
    ("triple-c-rk45", "triple-c", None, {"method": "newton_euler", "integrator": "RK45", **SHORT}, ROUNDING),
    ("triple-c-ode45", "triple-c", None, {"method": "lagrange", "integrator": "ode45", **SHORT}, ROUNDING),
    ("change-point-reduced", "change-point", None, {"method": "reduced", **SHORT}, ROUNDING),
    ("triple-c-midpoint", "triple-c", None,
     {"method": "lagrange", "integrator": "midpoint", "t_end": 1.0, "samples": 11}, ROUNDING),
    ("four-bar-midpoint", "four-bar", None,
     {"method": "dae", "integrator": "midpoint", "t_end": 1.0, "samples": 11}, ROUNDING),
    ("triple-c-variational", "triple-c", None,
     {"method": "lagrange", "integrator": "variational", "t_end": 1.0, "samples": 11}, ROUNDING),
    ("four-bar-variational", "four-bar", None,
     {"method": "lagrange", "integrator": "variational", "t_end": 1.0, "samples": 11}, NEWTON),
    *[(f"four-bar-scipy-{integrator}", "four-bar", None,
       {"method": "dae", "integrator": integrator, "backend": "scipy", "t_end": 1.0, "samples": 11}, ROUNDING)
      for integrator in ("Radau", "LSODA", "DOP853")],
    ("triple-c-max-steps", "triple-c", None, {"method": "dae", "max_steps": 10, **SHORT}, ROUNDING),
]



def assert_chain_run(chain, settings, run, tolerance: float, t_start: float = 0.0) -> None:
    """A successful run: the chain's sample times bit for bit, status and sentence ok, steps counted, the
    method and integrator named, and every sample as the chain's formulas give it."""
    assert run.status == Status.OK and run.message == "ok", run.message
    np.testing.assert_array_equal(run.t, sample_times(t_start, settings.t_end, settings.samples))
    assert (run.method, run.integrator) == (settings.method, settings.integrator)
    assert run.n_rhs >= run.n_steps > 0
    assert run.trace_is_explicit == (settings.trace is not None)
    assert_run_follows_chain_formulas(chain, settings, run, tolerance)


@pytest.mark.parametrize(("preset", "links", "fields", "tolerance"), [case[1:] for case in CASES],
                         ids=[case[0] for case in CASES])
def test_a_chains_run_follows_the_chains_own_formulas(preset, links, fields, tolerance):
    chosen = get_preset(preset, links)
    settings = Settings(trace=chosen.trace, **fields)
    run = simulate(chosen.chain, chosen.theta0, chosen.omega0, settings)
    if settings.max_steps == 10:  # the step budget's case: a status, the samples up to where it stopped
        assert run.status == Status.MAX_STEPS
        assert 0 < run.t.size < settings.samples
        assert_run_follows_chain_formulas(chosen.chain, settings, run, tolerance)
        return
    assert_chain_run(chosen.chain, settings, run, tolerance)
    if settings.method.startswith("reduced"):
        assert {"n_switches", "switch_times", "independent_index"} <= set(run.stats)
        assert run.stats["independent_index"].shape == run.t.shape
    else:
        assert run.stats["t_reached"] == pytest.approx(settings.t_end)


def test_a_run_stopped_by_its_step_budget_is_a_status_and_the_chains_sentence():
    """A failure midway is the chain's status and sentence, never an exception."""
    chosen = get_preset("triple-c")
    settings = Settings(method="lagrange", max_steps=10, **SHORT)
    run = simulate(chosen.chain, chosen.theta0, chosen.omega0, settings)
    assert run.status == Status.MAX_STEPS
    assert run.message == Status.describe(Status.MAX_STEPS, run.stats["t_reached"])
    assert 0 < run.t.size < settings.samples
    assert run.n_steps == settings.max_steps
    assert_run_follows_chain_formulas(chosen.chain, settings, run)


def test_a_continued_run_starts_where_its_t_start_says():
    """A chunk of the app's chunked integration (``t_start``, ``continuing``): its times from ``t_start``, its
    first sample the last of the chunk before (to rounding), every sample the chain's formulas'."""
    chosen = get_preset("four-bar")
    settings = Settings(method="dae", **SHORT)
    first = simulate(chosen.chain, chosen.theta0, chosen.omega0, settings)
    t_start = float(first.t[-1])
    second = simulate(chosen.chain, first.theta[-1], first.omega[-1], settings, t_start=t_start, continuing=True)
    assert_chain_run(chosen.chain, settings, second, ROUNDING, t_start=t_start)
    # the start as given (its rates read back through the tree's order: rounding)
    assert relative(second.theta[0], first.theta[-1]) <= ROUNDING
    assert relative(second.omega[0], first.omega[-1]) <= ROUNDING
