"""The registries (physics.registry) and the status enum (physics.status) tell the truth about the code:
every name has its implementation, every declared capability is what the generated systems and the solvers
actually offer, and the models accept exactly the registered names."""

from __future__ import annotations

import typing

import pytest
import scipy.integrate
from scipy.integrate import OdeSolver

from physics import LinkageError, Settings, get_preset, load_compiled, simulate
from physics.derive import FORMULATIONS
from physics.kernels import constants
from physics.model import validated
from physics.registry import (
    FORMULATION_NAMES,
    INTEGRATOR_NAMES,
    INTEGRATORS,
    METHOD_NAMES,
    METHODS,
    backend_for,
    incompatibility,
    integrators_for,
)
from physics.simulate.scipy_backend import SOLVERS
from physics.status import Status

from ..conftest import ALL_FORMULATIONS


def test_the_derived_formulations_are_the_registered_ones():
    assert FORMULATION_NAMES == ALL_FORMULATIONS
    assert set(FORMULATIONS) == set(FORMULATION_NAMES)
    assert all(not METHODS[name].derived for name in set(METHOD_NAMES) - set(FORMULATION_NAMES))


@pytest.mark.parametrize("name", ALL_FORMULATIONS)
def test_declared_capabilities_match_the_generated_system(name):
    compiled = load_compiled(name, 2, False)
    assert bool(compiled.reaction_index.size) == METHODS[name].has_reactions
    assert compiled.has_lagrangian == METHODS[name].has_lagrangian


@pytest.mark.parametrize("name", INTEGRATOR_NAMES)
def test_every_integrator_has_its_implementation(name):
    spec = INTEGRATORS[name]
    assert spec.backends, name
    if spec.kernel is not None:
        assert callable(getattr(load_compiled("lagrange", 1, False), spec.kernel))
    if spec.scipy_solver is not None:
        solver = SOLVERS[spec.scipy_solver]
        assert issubclass(solver, OdeSolver)
        assert getattr(scipy.integrate, spec.scipy_solver) is solver  # the public class, not scipy's private table
        assert spec.order is None or getattr(solver, "order", spec.order) == spec.order
    assert (spec.kernel is not None) == spec.runs_on("compiled")
    assert (spec.scipy_solver is not None) == spec.runs_on("scipy")


def test_the_models_accept_exactly_the_registered_names():
    hints = typing.get_type_hints(Settings)
    assert typing.get_args(hints["method"]) == METHOD_NAMES
    assert typing.get_args(hints["integrator"]) == INTEGRATOR_NAMES
    for name in INTEGRATOR_NAMES:
        method = next(m for m in FORMULATION_NAMES if name in integrators_for(m))
        assert validated(Settings, method=method, integrator=name).backend == backend_for(name)
    with pytest.raises(LinkageError, match="integrator"):
        validated(Settings, integrator="Euler")


@pytest.mark.parametrize(("method", "integrator", "backend", "fragment"), [
    ("dae", "variational", "compiled", "needs method = lagrange"),
    ("lagrange", "midpoint", "scipy", "backend = compiled only"),
])
def test_an_incompatible_combination_names_the_fix(method, integrator, backend, fragment):
    problem = incompatibility(method, integrator, backend)
    assert problem is not None and fragment in problem
    with pytest.raises(LinkageError, match=fragment):
        validated(Settings, method=method, integrator=integrator, backend=backend)


def test_reduced_methods_run_only_their_integrator_and_only_on_a_four_bar():
    for name in METHOD_NAMES:
        if METHODS[name].reduced:
            assert integrators_for(name) == ("DOP853",)
            assert METHODS[name].available_for(pinned=True, n=3)
            assert not METHODS[name].available_for(pinned=False, n=3)


def test_one_status_table_for_kernels_and_trajectories():
    kernel_codes = {value for key, value in vars(constants).items() if key.startswith("STATUS_")}
    assert kernel_codes == {int(member) for member in Status}
    messages = [member.message(1.5, "detail") for member in Status]
    assert len(set(messages)) == len(messages)
    assert all("1.5" in text for member, text in zip(Status, messages) if member != Status.OK)
    assert Status.describe(-99, 2.0, "odd").startswith("failed at t = 2")


def test_a_failed_run_reports_a_status_member_and_its_message():
    preset = get_preset("triple-a")
    trajectory = simulate(preset.chain, preset.theta0, preset.omega0, Settings(t_end=5.0, samples=11, max_steps=3))
    assert trajectory.status == Status.MAX_STEPS and not trajectory.success
    reached = float(trajectory.message.split("t = ")[1].split(" s")[0])
    assert 0.0 < reached < 5.0
    assert trajectory.message == Status.MAX_STEPS.message(reached)
