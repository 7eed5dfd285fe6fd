"""Every formulation and integrator by name, with what each can do: the one place that knows.

The models (``Settings``' allowed values), the simulation of a chain and of any mechanism, the CLI, the studies
and the app ask these tables
(``INTEGRATORS["variational"].needs_lagrangian``, ``METHODS["dae"].has_reactions``) instead of comparing
names, so adding an integrator or a formulation is one entry here plus its implementation (CONTRIBUTING.md).

Pure data: no sympy, numba or scipy, so the warm compiled path can import it. The symbolic derivations are
registered separately in ``physics.derive.FORMULATIONS`` (it imports sympy); a test checks the two agree.
"""

from __future__ import annotations

from dataclasses import dataclass

COMPILED = "compiled"  # the once-compiled numba kernels (physics.kernels)
SCIPY = "scipy"  # scipy.integrate's public solver classes, stepped by hand (physics.simulate.scipy_backend)
BACKENDS = (COMPILED, SCIPY)
DEFAULT_BACKEND = COMPILED
# How a closed loop's constraints are held during integration: not at all, by Baumgarte terms in the
# accelerations, or by projecting the state back onto them after every step (docs/integrators.md).
STABILIZATIONS = ("none", "baumgarte", "projection")


@dataclass(frozen=True)
class IntegratorSpec:
    """One integrator: how its step is chosen, where it runs and what it needs.

    ``kernel``: the ``CompiledSystem`` method that runs it on the compiled back end (None: scipy only);
    ``scipy_solver``: the name of the public ``scipy.integrate`` solver class (None: compiled only);
    ``order``: its order of accuracy (None for LSODA, which varies its order as it goes)."""

    name: str
    order: int | None
    adaptive: bool  # True: rtol/atol control the step; False: a fixed step (Settings.step)
    backends: tuple[str, ...]
    kernel: str | None = None
    scipy_solver: str | None = None
    needs_lagrangian: bool = False  # it discretises T - V itself (only formulations with has_lagrangian)

    @property
    def fixed_step(self) -> bool:
        return not self.adaptive

    def runs_on(self, backend: str) -> bool:
        return backend in self.backends


INTEGRATORS: dict[str, IntegratorSpec] = {
    spec.name: spec
    for spec in (
        IntegratorSpec("RK45", 5, True, (COMPILED, SCIPY), kernel="integrate_rk45", scipy_solver="RK45"),
        IntegratorSpec("DOP853", 8, True, (COMPILED, SCIPY), kernel="integrate_dop853", scipy_solver="DOP853"),
        # MATLAB's ode45: RK45's pair with MATLAB's controller, error norm and output (physics/kernels/ode45.py)
        IntegratorSpec("ode45", 5, True, (COMPILED,), kernel="integrate_ode45"),
        IntegratorSpec("Radau", 5, True, (SCIPY,), scipy_solver="Radau"),
        IntegratorSpec("LSODA", None, True, (SCIPY,), scipy_solver="LSODA"),
        IntegratorSpec("midpoint", 2, False, (COMPILED,), kernel="integrate_midpoint"),
        IntegratorSpec("variational", 2, False, (COMPILED,), kernel="integrate_variational", needs_lagrangian=True),
    )
}


@dataclass(frozen=True)
class MethodSpec:
    """One way to get equations of motion, and what it offers.

    A *formulation* is derived symbolically and compiled (``physics.derive``); a *reduced* method integrates
    one joint coordinate of a one-degree-of-freedom mechanism (for a chain: a pinned three-bar) with scipy's
    DOP853 (``physics.mechanism.reduced``; a chain's through ``physics.simulate.reduced_adapter``)."""

    name: str
    has_reactions: bool = False  # joint reactions are unknowns of its system (Trajectory.reactions filled)
    has_lagrangian: bool = False  # exposes the mass matrix and force of L = T - V (variational integrator)
    reduced: bool = False  # the one-coordinate model of physics.mechanism.reduced, not a derived formulation
    switches_branch: bool = False  # reduced only: crosses dead centres by switching its joint coordinate

    @property
    def derived(self) -> bool:
        """It has a symbolic derivation and generated code (an entry of physics.derive.FORMULATIONS)."""
        return not self.reduced

    def available_for(self, pinned: bool, n: int) -> bool:
        """A reduced method exists for one-degree-of-freedom loops only: a pinned three-bar chain."""
        return not self.reduced or (pinned and n == 3)


METHODS: dict[str, MethodSpec] = {
    spec.name: spec
    for spec in (
        MethodSpec("newton_euler"),
        MethodSpec("lagrange", has_lagrangian=True),
        MethodSpec("dae", has_reactions=True),
        MethodSpec("reduced", reduced=True, switches_branch=True),
        MethodSpec("reduced_fixed", reduced=True),
    )
}

# The derived formulations, the integrators, and the subsets callers iterate over, in table order.
FORMULATION_NAMES = tuple(name for name, spec in METHODS.items() if spec.derived)
METHOD_NAMES = tuple(METHODS)
REDUCED_METHODS = tuple(name for name, spec in METHODS.items() if spec.reduced)
INTEGRATOR_NAMES = tuple(INTEGRATORS)
ADAPTIVE_INTEGRATORS = tuple(name for name, spec in INTEGRATORS.items() if spec.adaptive)
FIXED_STEP_INTEGRATORS = tuple(name for name, spec in INTEGRATORS.items() if spec.fixed_step)
COMPILED_INTEGRATORS = tuple(name for name, spec in INTEGRATORS.items() if spec.runs_on(COMPILED))
# The integrator a reduced method runs with (scipy's DOP853: its own switching right-hand side).
REDUCED_INTEGRATOR = "DOP853"
# The methods of a general mechanism's run (physics.mechanism.simulate): every derived formulation, and the
# reduced model in one joint coordinate, which crosses dead centres by switching the coordinate (``reduced``) or
# keeps its first joint's and stops at that joint's dead centre (``reduced_fixed``: where a method fails, shown).
# In alphabetical order, the DAE (the mechanism's default) first.
MECHANISM_METHODS = tuple(sorted(METHODS))


def backend_for(integrator: str, requested: str = DEFAULT_BACKEND) -> str:
    """The back end an integrator runs on when ``requested`` is asked for: the default (compiled) quietly
    becomes the integrator's own back end when it has no compiled kernel (Radau, LSODA); an explicit request
    it cannot honour is refused by the caller (``incompatibility``)."""
    spec = INTEGRATORS[integrator]
    if spec.runs_on(requested):
        return requested
    return spec.backends[0] if requested == DEFAULT_BACKEND else requested


def incompatibility(method: str, integrator: str, backend: str) -> str | None:
    """Why this method, integrator and back end cannot run together (a sentence naming the fix), or None."""
    spec = INTEGRATORS[integrator]
    if not spec.runs_on(backend):
        allowed = " or ".join(f"backend = {b}" for b in spec.backends)
        return f"integrator = {integrator}: available with {allowed} only"
    if spec.needs_lagrangian and not METHODS[method].has_lagrangian:
        needed = ", ".join(name for name, m in METHODS.items() if m.has_lagrangian)
        return f"integrator = {integrator}: needs method = {needed} (got {method})"
    return None


def integrators_for(method: str, integrators=INTEGRATOR_NAMES) -> tuple[str, ...]:
    """Those of ``integrators`` that can run ``method`` (a reduced method runs only REDUCED_INTEGRATOR)."""
    if METHODS[method].reduced:
        return tuple(i for i in integrators if i == REDUCED_INTEGRATOR)
    return tuple(i for i in integrators
                 if not (INTEGRATORS[i].needs_lagrangian and not METHODS[method].has_lagrangian))
