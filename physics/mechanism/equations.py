"""The equations of motion a run integrates, for any mechanism and for a chain, in readable symbols.

:func:`equations_of_motion` is the one public way to read a linkage's equations (the app's Equations tab and its
"Download as LaTeX", a notebook): a chain is written as the mechanism its runs integrate
(:func:`physics.mechanism.chains.chain_mechanism`, hanging down, absolute rotations, its DAE in tree coordinates:
:mod:`physics.simulate.mechanism_route`), a mechanism is taken as the app and ``python -m physics mechanism`` run
it by default (the DAE in maximal coordinates, the tree formulations in relative rotations). The system is the
structure's own derivation (:func:`physics.mechanism.symbolic.derive_structure`, the one the generated code is made
from); only its symbols are renamed for reading, and for a chain its bars' points are written in the chain's ``L``
and ``d`` (the values the chain's parameter vector gives them for every chain: docs/mechanisms.md, "A chain as a
mechanism"), so a chain's rows read as docs/physics.md writes them. sympy loads when this module does.
"""

from __future__ import annotations

import dataclasses
import functools
import re

import sympy as sp

from ..derive.formulation import LinearSystem
from ..model import Chain
from .description import Mechanism
from .parameters import Structure, structure
from .symbolic import derive_structure
from .symbolic_parameters import parameter_symbols

METHODS = ("dae", "lagrange", "newton_euler")  # the methods with a symbolic system of their own
TIDY_MAX_BODIES = 4  # entries are trigsimp'd for reading up to this many bodies (seconds of sympy at 4)
TIDY_MAX_OPERATIONS = 400  # an expanded entry larger than this (sympy operations) is shown expanded, not trigsimp'd


@dataclasses.dataclass(frozen=True)
class EquationsOfMotion:
    """``A x = b``, the linear system solved at every evaluation of the right-hand side, in readable symbols.

    ``rows``: per equation its name (which balance or constraint) and ``(lhs_terms, rhs)``, the left side's terms
    ``A_ij x_j`` (coefficients collected per unknown, as derived) and the right side ``b_i``; ``unknowns`` the
    readable ``x``; ``system`` the derivation itself (the structure's symbols: ``q``, ``s``, ``m0`` ...) and
    ``names`` the renaming from its symbols to the readable ones; ``coordinates`` says what the state is."""

    method: str
    name: str  # the mechanism's name, or "chain of n"
    bodies: int
    coordinates: str
    system: LinearSystem
    names: dict
    unknowns: list
    rows: list  # [(row name, [lhs terms], rhs)]

    @property
    def shape(self) -> tuple[int, int]:
        return (len(self.unknowns), len(self.unknowns))


def equations_of_motion(linkage: Chain | Mechanism, method: str, *, tidy: bool = True) -> EquationsOfMotion:
    """The equations ``method`` (``dae``, ``lagrange`` or ``newton_euler``) integrates for ``linkage`` (a
    :class:`~physics.Chain` or a :class:`~physics.mechanism.Mechanism`); derived once per structure (seconds of sympy
    the first time: a chain of 3 in about a second), then from memory. ``tidy``: each entry ``trigsimp``'d for
    reading (products of sines and cosines as sines and cosines of differences) when it is small enough; the
    system itself (``.system``) is never changed. The reduced methods have no symbolic system of their own:
    ``ValueError`` names the ones that do."""
    if method not in METHODS:
        raise ValueError(f"method = {method!r}: the equations exist for {', '.join(METHODS)} (the reduced model "
                         f"integrates one free coordinate and places the bodies by position analysis)")
    if isinstance(linkage, Chain):
        return _chain_equations(linkage.n, linkage.pinned, method, tidy)
    if isinstance(linkage, Mechanism):
        return _described_equations(linkage.model_dump_json(), method, tidy)
    raise TypeError(f"linkage: a physics.Chain or a physics.mechanism.Mechanism, not {type(linkage).__name__}")


# ------------------------------------------------------------------ a chain
@functools.lru_cache(maxsize=16)
def _chain_equations(n: int, pinned: bool, method: str, tidy: bool) -> EquationsOfMotion:
    """A chain's equations depend on its bar count and whether its tip is pinned only (its numbers are symbols)."""
    from .chains import chain_mechanism  # noqa: PLC0415

    bars = [{"L": 1.0, "d": 0.5, "m": 1.0, "I": 0.1}] * n
    chain = Chain.model_validate({"bars": bars, **({"pin": [0.0, -0.5 * n]} if pinned else {})})
    mechanism = chain_mechanism(chain, [0.0] * n)
    shape = structure(mechanism)
    system = _system(shape, method, "absolute", tree_dae=method == "dae")
    system = _named_rows(system, mechanism)
    names, values = _chain_names(shape, n, pinned)
    coordinates = ("θ_k of bar k from the downward vertical, ω_k its rate" if method != "dae" else
                   "θ_k and ω_k of bar k; the DAE solves every bar's centre acceleration, angular acceleration "
                   "and every pin's reaction with them")
    return _readable(system, method, f"chain of {n}", n, coordinates, names, values, tidy)


def _chain_names(shape: Structure, n: int, pinned: bool) -> tuple[dict, dict]:
    """The chain's symbols for the mechanism's (bar k is body k-1) and the values a chain's parameter vector gives
    its bars' points (``chain_record.parameter_vector``: every bar's centre and arms from ``L`` and ``d`` hanging
    down; pins ``O``, ``J1`` .. ``J(n-1)`` damped by one ``c``, ``H`` by none)."""
    params = parameter_symbols(shape)
    real = functools.partial(sp.Symbol, real=True)
    L = [real(f"L_{k}") for k in range(1, n + 1)]
    d = [real(f"d_{k}") for k in range(1, n + 1)]
    names: dict = {params.g: real("g")}
    values: dict = {}
    below = sp.Integer(0)  # the sketch's y of bar k's top
    for k, body in enumerate(params.bodies):
        names[body.mass], names[body.inertia] = real(f"m_{k + 1}"), real(f"I_{k + 1}")
        values[body.centre[0]], values[body.centre[1]] = sp.Integer(0), below - d[k]
        below -= L[k]
    damping = real("c")
    for j, joint in enumerate(params.joints):
        (ax, ay), (bx, by) = joint.arm_a, joint.arm_b
        if j < n:  # O (j = 0): bar 1's top and the ground's O; Jj: bar j+1's top and bar j's bottom
            values.update({ax: sp.Integer(0), ay: d[j], joint.damping: damping})
            values.update({bx: sp.Integer(0), by: sp.Integer(0)} if j == 0 else
                          {bx: sp.Integer(0), by: -(L[j - 1] - d[j - 1])})
        else:  # H: bar n's bottom and the ground's H (its place; no damper)
            values.update({ax: sp.Integer(0), ay: -(L[n - 1] - d[n - 1]), joint.damping: sp.Integer(0)})
            names[bx], names[by] = real("x_H"), real("y_H")
    assert pinned == (len(params.joints) == n + 1)
    from .symbolic_tree import tree_geometry  # noqa: PLC0415

    for k in range(n):  # bar k + 1's pose (x, y, φ), with rates and accelerations
        names.update(_coordinate_names(k, str(k + 1)))
    # tree coordinate m is the absolute angle of bar order[m] + 1 (a pinned chain's tree is not in bar order)
    for m, bar in enumerate(tree_geometry(shape, params, "absolute").tree.order):
        number = int(bar) + 1
        names.update({real(f"s{m}"): real(f"θ_{number}"), real(f"sd{m}"): real(f"ω_{number}"),
                      real(f"sdd{m}"): real(f"θ\u0308_{number}")})
    return names, values


# ------------------------------------------------------------------ any mechanism
@functools.lru_cache(maxsize=16)
def _described_equations(description: str, method: str, tidy: bool) -> EquationsOfMotion:
    """Kept per description (its names are in the rows), the derivation itself per structure."""
    return _mechanism_equations(Mechanism.model_validate_json(description), method, tidy)


def _mechanism_equations(mechanism: Mechanism, method: str, tidy: bool) -> EquationsOfMotion:
    shape = structure(mechanism)
    system = _named_rows(_system(shape, method, "relative", tree_dae=False), mechanism)
    names: dict = {}
    labels = [re.sub(r"\W", "", body.name) or f"b{b}" for b, body in enumerate(mechanism.bodies)]
    for b, label in enumerate(labels):
        names.update(_coordinate_names(b, label))
    tree_names = {}
    if method != "dae":  # the tree's coordinate m is the joint that joins body tree.order[m] to its parent
        from .symbolic_tree import tree_geometry  # noqa: PLC0415

        tree = tree_geometry(shape, parameter_symbols(shape), "relative").tree
        for m, body in enumerate(tree.order):
            joint = re.sub(r"\W", "", mechanism.joints[tree.parent[body][0]].name) or f"j{m}"
            tree_names.update(_tree_names(m, joint))
    names.update(tree_names)
    coordinates = ("every body's centre x, y and angle φ (maximal coordinates), with the joints' multipliers λ"
                   if method == "dae" else "one coordinate s per joint of the spanning tree, relative to its parent")
    return _readable(system, method, mechanism.name, len(mechanism.bodies), coordinates, names, {}, tidy)


# ------------------------------------------------------------------ shared
@functools.lru_cache(maxsize=32)
def _system(shape: Structure, method: str, rotations: str, tree_dae: bool) -> LinearSystem:
    """The derivation the generated code is made from: the structure's ``method``, or its DAE in tree coordinates
    (:func:`physics.mechanism.tree_dae.compiled_tree_dae`'s)."""
    if not tree_dae:
        return derive_structure(shape, method, rotations)
    from .symbolic_tree_dae import derive_tree_dae  # noqa: PLC0415

    return derive_tree_dae(shape, parameter_symbols(shape), derive_structure(shape, "dae", "relative"), rotations)


def _named_rows(system: LinearSystem, mechanism: Mechanism) -> LinearSystem:
    """The rows' names with the mechanism's body and joint names (as :func:`derive_system` names them)."""
    names = {f"b{k}": body.name for k, body in enumerate(mechanism.bodies)}
    names.update({f"j{k}": joint.name for k, joint in enumerate(mechanism.joints)})
    return dataclasses.replace(system, equation_names=[name.format(**names) for name in system.equation_names])


def _coordinate_names(body: int, label: str) -> dict:
    """Body ``body``'s maximal coordinates (``q3b..q3b+2``: x, y, φ, with rates and accelerations)."""
    real = functools.partial(sp.Symbol, real=True)
    names = {}
    for k, coordinate in enumerate(("x", "y", "φ")):
        for prefix, mark in (("q", ""), ("qd", "\u0307"), ("qdd", "\u0308")):
            names[real(f"{prefix}{3 * body + k}")] = real(f"{coordinate}{mark}_{label}")
    return names


def _tree_names(m: int, joint: str) -> dict:
    real = functools.partial(sp.Symbol, real=True)
    return {real(f"s{m}"): real(f"s_{joint}"), real(f"sd{m}"): real(f"s\u0307_{joint}"),
            real(f"sdd{m}"): real(f"s\u0308_{joint}")}


def _readable(system: LinearSystem, method: str, name: str, bodies: int, coordinates: str, names: dict,
              values: dict, tidy: bool) -> EquationsOfMotion:
    """The rows ``sum_j A_ij x_j = b_i`` in readable symbols: ``values`` put in first (a chain's points), then
    each entry tidied (``tidy``) and renamed; the multipliers ``lam0 ..`` read ``λ_1 ..`` (in the rows' order)."""
    names = dict(names)
    for unknown in system.unknowns:
        if re.fullmatch(r"lam\d+", str(unknown)):
            names[unknown] = sp.Symbol(f"λ_{int(str(unknown)[3:]) + 1}", real=True)
    tidy = tidy and bodies <= TIDY_MAX_BODIES

    def shown(expr):
        expr = expr.xreplace(values) if values else expr
        if tidy:
            expr = sp.expand(expr)
            if sp.count_ops(expr) <= TIDY_MAX_OPERATIONS:
                expr = sp.trigsimp(expr)
        return expr.xreplace(names)

    def terms(coefficient, unknown) -> tuple:
        return sp.Add.make_args(sp.expand(coefficient * unknown)) if tidy else (coefficient * unknown,)

    unknowns = [names.get(u, u) for u in system.unknowns]
    by_name = {str(symbol): str(shown_as) for symbol, shown_as in names.items()}

    def heading(row_name: str) -> str:  # "Lagrange equation for s0 (O)": the coordinate by its readable name
        return re.sub(r"\bs\d+\b", lambda found: by_name.get(found.group(0), found.group(0)), row_name)

    rows = []
    for i, row_name in enumerate(map(heading, system.equation_names)):
        lhs_terms = [term for j, unknown in enumerate(unknowns) if system.A[i, j] != 0
                     for term in terms(shown(system.A[i, j]), unknown)]
        rhs = shown(system.b[i])
        rows.append((row_name, [term for term in lhs_terms if term != 0] or [sp.Integer(0)], rhs))
    return EquationsOfMotion(method=method, name=name, bodies=bodies, coordinates=coordinates, system=system,
                             names=names, unknowns=unknowns, rows=rows)
