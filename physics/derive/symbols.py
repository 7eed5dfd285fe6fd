"""Sympy symbols for an n-bar chain, named as the model's fields and the parameter vector.

Parameters stay symbols through every derivation, so changing a slider never re-derives anything;
they become numbers only inside the generated code (``params`` layout in docs/architecture.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp


@dataclass(frozen=True)
class ChainSymbols:
    n: int
    theta: tuple  # angles from the downward vertical
    omega: tuple  # angular velocities
    theta_ddot: tuple  # angular accelerations (unknowns)
    L: tuple
    d: tuple
    m: tuple
    I: tuple
    g: sp.Symbol
    pin_x: sp.Symbol
    pin_y: sp.Symbol
    damping: sp.Symbol

    @property
    def params(self) -> tuple:
        """In the order of ``Chain.params()``."""
        return (*self.L, *self.d, *self.m, *self.I, self.g, self.pin_x, self.pin_y, self.damping)


def chain_symbols(n: int) -> ChainSymbols:
    def vec(name):
        return tuple(sp.Symbol(f"{name}_{i}", real=True) for i in range(1, n + 1))

    return ChainSymbols(
        n=n,
        theta=vec("theta"),
        omega=vec("omega"),
        theta_ddot=vec("theta_ddot"),
        L=tuple(sp.Symbol(f"L_{i}", positive=True) for i in range(1, n + 1)),
        d=vec("d"),
        m=vec("m"),
        I=vec("I"),
        g=sp.Symbol("g", real=True),
        pin_x=sp.Symbol("pin_x", real=True),
        pin_y=sp.Symbol("pin_y", real=True),
        damping=sp.Symbol("c", real=True),
    )


# Planar vectors are plain (x, y) tuples of sympy expressions: the scene is planar, so is the algebra.


def along(theta):
    """Unit vector along a bar at angle ``theta`` from the downward vertical."""
    return (sp.sin(theta), -sp.cos(theta))


def normal(theta):
    """Unit vector perpendicular to the bar, counter-clockwise: d(along)/d(theta)."""
    return (sp.cos(theta), sp.sin(theta))


def add(*vectors):
    return (sum((v[0] for v in vectors), sp.Integer(0)), sum((v[1] for v in vectors), sp.Integer(0)))


def scale(k, v):
    return (k * v[0], k * v[1])


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1])


def cross(a, b):
    """z-component of a x b."""
    return a[0] * b[1] - a[1] * b[0]


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1]
