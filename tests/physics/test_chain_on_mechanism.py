"""A chain's run on the general mechanism engine (physics/simulate/on_mechanism.py, the switch, and
mechanism_route.py) against its run on the chain's own kernels: the same Trajectory, field by field, for a
representative set of chains and settings.

With absolute rotations the state integrated on the mechanism engine is the chain's ``(theta, omega)`` (the
four-bar's in its tree's order), by the same integrator code, so the two runs take the same steps and evaluate
the same number of right-hand sides; their values differ only by rounding: the two generated codes sum the same
terms in another order (the four-bar's tree even hangs bar 3 from the tip's pin, another but equivalent
Lagrangian). The tolerances say how far rounding goes over these short runs:

* :data:`ROUNDING` 1e-11 relative (to 1 + the largest value): measured at most 9e-14 on every field of every
  case below (2 s, rtol 1e-10), a hundred times under it; a change of the equations, the reactions' rows or
  their signs would be off by order one.
* :data:`BAUMGARTE` 1e-9: Baumgarte's terms feed the loop's residual back with gains ``alpha = beta = 10``
  (beta^2 = 100 on a position residual of rounding size), so rounding shows more: measured 1e-10 on the tip's
  reaction, 1e-12 on the rates.
* :data:`NEWTON` 1e-8: the variational integrator stops each step's Newton iteration at its tolerance
  (physics.kernels.constants.NEWTON_TOLERANCE, and up to a thousand times it where the corrections stop
  shrinking), so each step's answer is fixed to about 1e-13 only; over 1000 steps measured 4e-10.

The condition column: the chain route reports the condition of the chain formulation's matrix, this route the
mechanism system's; for an open chain of two bars or more their kernel estimates are equal (the same matrix up
to rounding), for a pinned chain the matrices differ (the four-bar's mechanism tree hangs bar 3 from ``H``), so
there only its shape and finiteness are compared (docs/architecture.md, "The chain on the mechanism engine").
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from physics import Settings, get_preset, simulate
from physics.simulate import on_mechanism
from physics.status import Status

ROUNDING = 1e-11
BAUMGARTE = 1e-9
NEWTON = 1e-8
STEP_SIZES = 1e-5

VALUE_FIELDS = ("theta", "omega", "joints", "tip_xy", "trace_xy", "kinetic", "potential", "energy", "reactions",
                "joint_reactions", "tip_reaction", "constraint_xy", "constraint_velocity")
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


def both_routes(chain, theta0, omega0, settings, monkeypatch):
    """The chain's run on its own kernels, then on the mechanism engine."""
    monkeypatch.setattr(on_mechanism, "ENABLED", False)
    chain_run = simulate(chain, theta0, omega0, settings)
    monkeypatch.setattr(on_mechanism, "ENABLED", True)
    mechanism_run = simulate(chain, theta0, omega0, settings)
    return chain_run, mechanism_run


def relative(mine: np.ndarray, theirs: np.ndarray) -> float:
    if theirs.size == 0:
        return 0.0
    return float(np.max(np.abs(mine - theirs)) / (1.0 + np.max(np.abs(theirs))))


def assert_same_trajectory(chain_run, mechanism_run, tolerance: float, pinned: bool) -> None:
    """Every field of the two runs: the same shapes, status, sentence, counts and stats' keys; values within
    ``tolerance``; the times bit for bit."""
    assert mechanism_run.status == chain_run.status
    assert mechanism_run.message == chain_run.message
    assert (mechanism_run.n_steps, mechanism_run.n_rhs) == (chain_run.n_steps, chain_run.n_rhs)
    assert (mechanism_run.method, mechanism_run.integrator) == (chain_run.method, chain_run.integrator)
    assert mechanism_run.trace_is_explicit == chain_run.trace_is_explicit
    np.testing.assert_array_equal(mechanism_run.t, chain_run.t)
    assert set(mechanism_run.stats) == set(chain_run.stats)
    # where the last accepted step ended: the step sizes come from the error estimate, itself of size rtol
    # (1e-10) over rounding (1e-16) in the right-hand sides, so they agree to about 1e-6 relative (measured 4e-7
    # after 10 steps of case C), not to rounding; the samples, read off the dense output, do
    for name in ("n_switches", "switch_times", "t_reached"):
        if name in chain_run.stats:
            assert mechanism_run.stats[name] == pytest.approx(chain_run.stats[name], rel=STEP_SIZES), name
    if "independent_index" in chain_run.stats:
        np.testing.assert_array_equal(mechanism_run.stats["independent_index"], chain_run.stats["independent_index"])
    for name in VALUE_FIELDS:
        mine, theirs = getattr(mechanism_run, name), getattr(chain_run, name)
        assert mine.shape == theirs.shape, name
        assert relative(mine, theirs) <= tolerance, (name, relative(mine, theirs))
    assert mechanism_run.condition.shape == chain_run.condition.shape
    assert np.all(np.isfinite(mechanism_run.condition) == np.isfinite(chain_run.condition))
    assert mechanism_run.columns().keys() == chain_run.columns().keys()
    if not pinned and chain_run.n > 1:
        assert relative(mechanism_run.condition, chain_run.condition) <= tolerance


@pytest.mark.parametrize(("preset", "links", "fields", "tolerance"), [case[1:] for case in CASES],
                         ids=[case[0] for case in CASES])
def test_a_chain_on_the_mechanism_engine_gives_the_chains_trajectory(preset, links, fields, tolerance, monkeypatch):
    chosen = get_preset(preset, links)
    settings = Settings(trace=chosen.trace, **fields)
    chain_run, mechanism_run = both_routes(chosen.chain, chosen.theta0, chosen.omega0, settings, monkeypatch)
    assert_same_trajectory(chain_run, mechanism_run, tolerance, chosen.chain.pinned)


def test_a_run_stopped_by_its_step_budget_is_a_status_on_both_routes(monkeypatch):
    """A failure midway is the chain's status and sentence on the mechanism engine too, never an exception."""
    chosen = get_preset("triple-c")
    settings = Settings(method="lagrange", max_steps=10, **SHORT)
    chain_run, mechanism_run = both_routes(chosen.chain, chosen.theta0, chosen.omega0, settings, monkeypatch)
    assert chain_run.status == Status.MAX_STEPS
    assert mechanism_run.status == chain_run.status and mechanism_run.message == chain_run.message
    assert 0 < mechanism_run.t.size == chain_run.t.size < settings.samples


def test_a_continued_run_starts_where_its_t_start_says(monkeypatch):
    """A chunk of the app's chunked integration (``t_start``, ``continuing``) on both routes."""
    chosen = get_preset("four-bar")
    settings = Settings(method="dae", **SHORT)
    runs = []
    for enabled in (False, True):
        monkeypatch.setattr(on_mechanism, "ENABLED", enabled)
        first = simulate(chosen.chain, chosen.theta0, chosen.omega0, settings)
        runs.append(simulate(chosen.chain, first.theta[-1], first.omega[-1], settings, t_start=float(first.t[-1]),
                             continuing=True))
    assert_same_trajectory(runs[0], runs[1], ROUNDING, pinned=True)


def test_the_switch_is_on_by_default():
    """Every chain runs on the mechanism engine unless a test turns the switch off (the module as written: the
    test session may have turned the loaded one off)."""
    tree = ast.parse(Path(on_mechanism.__file__).read_text(encoding="utf-8"))
    values = [node.value for node in tree.body if isinstance(node, ast.Assign)
              and any(isinstance(target, ast.Name) and target.id == "ENABLED" for target in node.targets)]
    assert len(values) == 1 and isinstance(values[0], ast.Constant) and values[0].value is True
