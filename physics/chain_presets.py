"""The seed report's cases as data, plus ``chain(n)``.

Seed values: L = 1, d = 0.5, m = 1, I = 0.2 / 0.3 / 0.4, g = 1, started at rest. Cases B and C have two
readings (the report's text disagrees with its captions and code); the caption/code reading is the default,
the text's is ``triple-b-text`` / ``triple-c-text``. ``single`` and ``double`` are the first one or two bars
of the same with the first angles of case A. The four-bar is the seed's triple pendulum with L3 = 2 and its
tip pinned where it starts. ``change-point`` is a parallelogram four-bar (s + l = p + q) released next to the
position where all four links line up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .errors import LinkageError
from .loop_closure import grashof
from .model import MAX_LINKS, Chain, TracePoint, make_chain

SEED_L = (1.0, 1.0, 1.0)
SEED_D = (0.5, 0.5, 0.5)
SEED_M = (1.0, 1.0, 1.0)
SEED_I = (0.2, 0.3, 0.4)
SEED_G = 1.0
CHAIN_DEFAULT_LINKS = 5


@dataclass(frozen=True)
class Preset:
    name: str
    description: str
    chain: Chain
    theta0: np.ndarray
    omega0: np.ndarray
    trace: TracePoint
    t_end: float = 20.0
    extra: dict = field(default_factory=dict)

    def summary(self) -> dict:
        """JSON-able description, as printed by ``python -m physics presets``."""
        params = {}
        for i, bar in enumerate(self.chain.bars, start=1):
            params.update({f"L{i}": bar.L, f"d{i}": bar.d, f"m{i}": bar.m, f"I{i}": bar.I})
        params["g"] = self.chain.g
        out = {
            "name": self.name,
            "description": self.description,
            "links": self.chain.n,
            "params": params,
            "theta": [float(v) for v in self.theta0],
            "omega": [float(v) for v in self.omega0],
            "pin": list(self.chain.pin) if self.chain.pin is not None else None,
            "trace": {"bar": self.trace.bar, "along": self.trace.along, "across": self.trace.across},
            "t_end": self.t_end,
        }
        out.update(self.extra)
        return out


def _tip(L, theta) -> tuple[float, float]:
    return (
        float(np.sum(np.asarray(L) * np.sin(theta))),
        float(-np.sum(np.asarray(L) * np.cos(theta))),
    )


# The seed report's three starts of the triple pendulum (section 2.4). Case A reads the same everywhere. For
# cases B and C the report's text disagrees with its figure captions and its MATLAB code (which agree with
# each other, and drew the figures): the presets follow the captions and code, and the text's reading is kept
# under a ``-text`` name so either can be run.
CASE_A = (math.pi / 2, math.pi, math.pi)
CASE_B_CODE = (math.pi / 4, math.pi / 2, 3 * math.pi / 4)
CASE_C_CODE = (math.pi, math.pi / 3, math.pi / 3)
CASE_B_TEXT = (math.pi / 4, math.pi / 4, 3 * math.pi / 4)
CASE_C_TEXT = (math.pi / 4, math.pi / 3, math.pi / 3)

CASE_A_TEXT = ("Seed case A (report Figure 9): theta = (pi/2, pi, pi), at rest; bar 1 horizontal, bars 2 and 3 "
               "pointing straight up. Text, caption and code agree.")
CASE_B_CODE_TEXT = ("Seed case B as the report's Figure 10 caption and MATLAB code give it: theta = (pi/4, pi/2, "
                    "3pi/4), at rest. The report's text says (pi/4, pi/4, 3pi/4) instead: see triple-b-text.")
CASE_C_CODE_TEXT = ("Seed case C as the report's Figure 11 caption and MATLAB code give it: theta = (pi, pi/3, "
                    "pi/3), at rest. The report's text says (pi/4, pi/3, pi/3) instead: see triple-c-text.")
CASE_B_TEXT_TEXT = ("Seed case B as the report's text (section 2.4, 'Case 2') gives it: theta = (pi/4, pi/4, "
                    "3pi/4), at rest. Its Figure 10 caption and code use (pi/4, pi/2, 3pi/4): see triple-b.")
CASE_C_TEXT_TEXT = ("Seed case C as the report's text (section 2.4, 'Case 3') gives it: theta = (pi/4, pi/3, "
                    "pi/3), at rest. Its Figure 11 caption and code use (pi, pi/3, pi/3): see triple-c.")


def _seed_triple(name: str, theta, description: str) -> Preset:
    chain = make_chain(SEED_L, SEED_D, SEED_M, SEED_I, g=SEED_G)
    return Preset(name, description, chain, np.array(theta, float), np.zeros(3), TracePoint(bar=3, along=1.0))


def _seed_prefix(name: str, links: int) -> Preset:
    theta = (math.pi / 2, math.pi, math.pi)[:links]
    chain = make_chain(SEED_L[:links], SEED_D[:links], SEED_M[:links], SEED_I[:links], g=SEED_G)
    what = "single bar (compound pendulum)" if links == 1 else "double pendulum"
    return Preset(
        name,
        f"Seed {what}: the first {links} bar(s) of the triple pendulum, started at case A's angles.",
        chain,
        np.array(theta, float),
        np.zeros(links),
        TracePoint(bar=links, along=SEED_L[links - 1]),
    )


def _four_bar_extra(chain: Chain) -> dict:
    info = grashof(chain.array("L"), np.array(chain.pin))
    return {"grashof": info.as_dict()}


def four_bar() -> Preset:
    L = (1.0, 1.0, 2.0)
    theta = np.array([math.pi - math.pi / 30, math.pi / 2, 0.0])
    chain = make_chain(L, SEED_D, SEED_M, SEED_I, g=SEED_G, pin=_tip(L, theta))
    return Preset(
        "four-bar",
        "Seed four-bar linkage: the triple pendulum with L3 = 2 and its tip H pinned where it starts; 100 s.",
        chain,
        theta,
        np.zeros(3),
        TracePoint(bar=2, along=0.5, across=0.5),
        t_end=100.0,
        extra=_four_bar_extra(chain),
    )


def change_point() -> Preset:
    """Parallelogram: crank 1, coupler 2, rocker 1, ground 2, so s + l = p + q. All four links line up when
    the crank is horizontal (theta1 = +-pi/2); released at rest 0.05 rad short of it, it swings to the same
    distance on the other side, so every period passes close to the singular position."""
    L = (1.0, 2.0, 1.0)
    d = (0.5, 1.0, 0.5)
    m = (1.0, 1.0, 1.0)
    I = tuple(mi * Li**2 / 12 for mi, Li in zip(m, L))
    theta1 = math.pi / 2 - 0.05
    theta = np.array([theta1, math.pi / 2, theta1 + math.pi])
    chain = make_chain(L, d, m, I, g=SEED_G, pin=(2.0, 0.0))
    return Preset(
        "change-point",
        "Change-point (parallelogram) four-bar, released 0.05 rad from the position where all links are collinear.",
        chain,
        theta,
        np.zeros(3),
        TracePoint(bar=2, along=1.0, across=0.3),
        t_end=20.0,
        extra=_four_bar_extra(chain),
    )


def chain_preset(links: int = CHAIN_DEFAULT_LINKS) -> Preset:
    """``links`` uniform rods (L = 1, d = 0.5, m = 1, I = 1/12), released at rest lying horizontal
    (every theta = pi/2): the classic falling-chain start."""
    if not 1 <= int(links) <= MAX_LINKS:
        raise LinkageError(f"links = {links}: allowed range 1 <= links <= {MAX_LINKS}")
    n = int(links)
    chain = make_chain([1.0] * n, [0.5] * n, [1.0] * n, [1.0 / 12] * n, g=SEED_G)
    return Preset(
        "chain",
        f"{n} uniform rods (L = 1, d = 0.5, m = 1, I = 1/12) released at rest lying horizontal.",
        chain,
        np.full(n, math.pi / 2),
        np.zeros(n),
        TracePoint(bar=n, along=1.0),
    )


_FACTORIES = {
    "single": lambda: _seed_prefix("single", 1),
    "double": lambda: _seed_prefix("double", 2),
    "triple-a": lambda: _seed_triple("triple-a", CASE_A, CASE_A_TEXT),
    "triple-b": lambda: _seed_triple("triple-b", CASE_B_CODE, CASE_B_CODE_TEXT),
    "triple-c": lambda: _seed_triple("triple-c", CASE_C_CODE, CASE_C_CODE_TEXT),
    "triple-b-text": lambda: _seed_triple("triple-b-text", CASE_B_TEXT, CASE_B_TEXT_TEXT),
    "triple-c-text": lambda: _seed_triple("triple-c-text", CASE_C_TEXT, CASE_C_TEXT_TEXT),
    "four-bar": four_bar,
    "change-point": change_point,
    "chain": chain_preset,
}


def preset_names() -> tuple[str, ...]:
    return tuple(_FACTORIES)


def get_preset(name: str, links: int | None = None) -> Preset:
    """A preset by name; ``links`` applies to ``chain`` only."""
    if name not in _FACTORIES:
        from .mechanism.presets import MECHANISM_PRESETS  # noqa: PLC0415 - only to say what the name is

        if name in MECHANISM_PRESETS:
            raise LinkageError(f"preset = {name!r}: a mechanism preset; this command takes a chain preset "
                               f"({', '.join(_FACTORIES)})")
        raise LinkageError(f"preset = {name!r}: allowed {', '.join(_FACTORIES)}")
    if name == "chain":
        return chain_preset(CHAIN_DEFAULT_LINKS if links is None else links)
    if links is not None and links != _FACTORIES[name]().chain.n:
        raise LinkageError(f"links = {links}: --links applies to preset 'chain' only (preset {name!r} is fixed)")
    return _FACTORIES[name]()


def mechanism_summaries() -> list[dict]:
    """Every mechanism preset as an entry of ``python -m physics presets``: ``kind: "mechanism"``, then the keys
    ``python -m physics mechanism --json`` gives them (its bodies, joints, motors and loops, its mobility after
    the motors, ``mobility``, and before, ``mechanism_mobility``) and the traced point. (A chain's entry,
    :meth:`Preset.summary`, has no ``kind``: its keys are a contract.)"""
    from .mechanism import MECHANISM_PRESETS, assemble  # noqa: PLC0415 - the chain commands never load them

    entries = []
    for name, factory in MECHANISM_PRESETS.items():
        mechanism = factory()
        assembled = assemble(mechanism)
        entries.append({
            "name": name, "kind": "mechanism", "description": mechanism.description,
            "bodies": [body.name for body in mechanism.bodies], "joints": [joint.name for joint in mechanism.joints],
            "drivers": [driver.model_dump(exclude_none=True) for driver in mechanism.drivers],
            "loops": [list(loop.joints) for loop in assembled.topology.loops],
            "mobility": assembled.mobility, "mechanism_mobility": assembled.mechanism_mobility,
            "motors": len(mechanism.drivers), "mobility_text": assembled.mobility_text(), "trace": mechanism.trace,
        })
    return entries
