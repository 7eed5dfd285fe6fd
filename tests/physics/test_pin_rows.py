"""Phi and Phi_q of a mechanism of pins written out for pins (physics/mechanism/pin_rows.py, issue 24: a chain's
new start assembled in a tenth of the time) are the generic rows' numbers bit for bit, at any pose, for open and
closed chains, trees and pins to the ground; assembly through them gives the generic path's pose, Jacobian and
steps, and a mechanism with another row (a slider, a speed motor) has none."""

from __future__ import annotations

import numpy as np
import pytest

from physics.chain_presets import get_preset
from physics.mechanism import MECHANISM_PRESETS, assembly
from physics.mechanism.chains import chain_mechanism
from physics.mechanism.description import Body, Driver, Mechanism, Revolute
from physics.mechanism.prepared import clear_prepared, prepared


def _tree() -> Mechanism:
    """A body on the ground with two bodies hanging off it, one of them on a pin at its centre of mass (an arm of
    zero: the rows' zeros of either sign)."""
    return Mechanism(
        name="tree", g=9.81, ground={"O": (0.0, 0.0)},
        bodies=[Body(name="hub", points={"P": (0.0, 0.0), "L": (-0.3, -0.1), "R": (0.4, -0.2)}, mass=1.0,
                     com=(0.05, -0.1), inertia=0.02),
                Body(name="left", points={"P": (-0.3, -0.1), "D": (-0.6, -0.5)}, mass=0.5, com=(-0.3, -0.1),
                     inertia=0.01),
                Body(name="right", points={"P": (0.4, -0.2), "D": (0.7, -0.6)}, mass=0.7, com=(0.55, -0.4),
                     inertia=0.01)],
        joints=[Revolute(name="O", a="hub.P", b="ground.O"), Revolute(name="L", a="left.P", b="hub.L"),
                Revolute(name="R", a="right.P", b="hub.R", damping=0.1)],
        drivers=[Driver(joint="L", torque=0.3)])


def _mechanisms() -> dict[str, Mechanism]:
    triple, four_bar = get_preset("triple-c"), get_preset("four-bar")
    return {"triple-c": chain_mechanism(triple.chain, np.zeros(triple.chain.n)),
            "triple-c sketched": chain_mechanism(triple.chain, triple.theta0),
            "four-bar": chain_mechanism(four_bar.chain, four_bar.theta0), "tree": _tree()}


@pytest.mark.parametrize("name", ["triple-c", "triple-c sketched", "four-bar", "tree"])
def test_the_pins_rows_are_the_generic_rows_bit_for_bit(name):
    mechanism = _mechanisms()[name]
    pieces = prepared(mechanism)
    rows = pieces.pin_rows
    assert rows is not None
    generator = np.random.default_rng(7)
    sketch = pieces.constraints.sketch_pose()
    poses = [sketch, np.zeros_like(sketch), -np.zeros_like(sketch)]
    poses += [sketch + generator.normal(scale=scale, size=sketch.size) for scale in (1e-9, 0.3, 3.0, 40.0)]
    poses += [np.where(np.arange(sketch.size) % 3 == 2, angle, sketch) for angle in (np.pi / 2, -np.pi, 1e-300)]
    for q in poses:
        residual, jacobian = rows.rows_at(q)
        expected_residual, expected_jacobian = pieces.constraints.residual(q), pieces.constraints.jacobian(q)
        assert residual.tobytes() == expected_residual.tobytes()  # the bits, the sign of a zero too
        assert jacobian.shape == expected_jacobian.shape
        assert jacobian.tobytes() == expected_jacobian.tobytes()


@pytest.mark.parametrize("name", ["triple-c", "four-bar", "tree"])
def test_assembly_through_the_pins_rows_is_the_generic_one(monkeypatch, name):
    mechanism = _mechanisms()[name]
    sketch = prepared(mechanism).constraints.sketch_pose()
    generator = np.random.default_rng(3)
    for guess in (None, sketch + generator.normal(scale=0.05, size=sketch.size)):
        found = []
        for fast in (False, True):
            clear_prepared()  # nothing remembered: assembled each time
            monkeypatch.setattr(assembly, "PIN_ROWS", fast)
            found.append(assembly.assembled_with_jacobian(mechanism, prepared(mechanism), guess))
        (slow, slow_jacobian), (quick, quick_jacobian) = found
        assert quick.q.tobytes() == slow.q.tobytes() and quick_jacobian.tobytes() == slow_jacobian.tobytes()
        assert (quick.newton_steps, quick.residual, quick.mobility) == (slow.newton_steps, slow.residual,
                                                                       slow.mobility)
    assert name != "four-bar" or found[0][0].newton_steps > 0  # the closed chain's rough guess took Newton steps


def test_a_mechanism_with_another_row_has_none():
    assert prepared(MECHANISM_PRESETS["slider-crank"]()).pin_rows is None  # a slider
    assert prepared(MECHANISM_PRESETS["crank-rocker"]()).pin_rows is None  # a speed motor's row
