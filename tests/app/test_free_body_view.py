"""The live free-body diagram (issue 15): the forces drawn on each bar balance its motion.

The accelerations are computed here, independently of the run: another formulation's compiled system solved at
the displayed state, and the centre-of-mass acceleration written out from the bar directions.
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import wait_until
from physics.codegen import load_compiled
from physics.mechanism.chains import chain_mechanism, chain_state
from physics.mechanism.statics import evaluate, free_body

INDEPENDENT = {"lagrange": "dae", "newton_euler": "dae", "dae": "lagrange"}


def independent_motion(chain, theta, omega, method):
    """Angular accelerations (n,) from another formulation, centre-of-mass positions and accelerations (n, 2)."""
    other = INDEPENDENT[method] if not (chain.pinned and INDEPENDENT[method] == "lagrange") else "newton_euler"
    compiled = load_compiled(other, chain.n, chain.pinned)
    x, _ = compiled.solve_full(theta, omega, chain.params())
    alpha = x[compiled.theta_ddot_index]
    com, a_com = [], []
    base = np.zeros(2)
    base_acc = np.zeros(2)
    for bar, th, w, al in zip(chain.bars, theta, omega, alpha):
        e = np.array([np.sin(th), -np.cos(th)])
        e_ddot = al * np.array([np.cos(th), np.sin(th)]) - w**2 * e  # second derivative of the bar direction
        com.append(base + bar.d * e)
        a_com.append(base_acc + bar.d * e_ddot)
        base = base + bar.L * e
        base_acc = base_acc + bar.L * e_ddot
    return alpha, np.array(com), np.array(a_com)


@pytest.mark.parametrize("preset, method", [("triple-a", "lagrange"), ("triple-a", "dae"),
                                            ("four-bar", "newton_euler")])
def test_the_drawn_forces_balance_every_bar(connect, preset, method):
    _, session = connect()
    session.set_mechanism(preset)
    session.set("method", method)
    session.free_body_box.value = True  # the Display tab's box (viser runs its callback)
    assert session.goto_time(1.3)
    chain = session.params.chain
    assert list(session.body_menu.options) == [f"bar{k}" for k in range(1, chain.n + 1)]
    for bar in range(1, chain.n + 1):
        session.body_menu.value = f"bar{bar}"
        assert wait_until(lambda bar=bar: session.free_body.shown_bar == bar and session.free_body.shown, timeout=30)
        assert session.free_body.visible()
        with session.free_body._lock:  # the player thread draws: one drawing's forces, labels and time
            forces, labels, shown_t = list(session.free_body.shown), session.free_body.labels(), \
                session.free_body.shown_t
        assert len(forces) == (3 if bar < chain.n or chain.pinned else 2)
        assert len(labels) == len(forces)
        theta, omega = session.state_at(shown_t, exact=True)  # the displayed run's sample drawn, as bar angles
        alpha, com, a_com = independent_motion(chain, theta, omega, method)
        k = bar - 1
        b = chain.bars[k]
        total = np.sum([f.force for f in forces], axis=0)
        moment = sum((f.point_xy - com[k])[0] * f.force[1] - (f.point_xy - com[k])[1] * f.force[0] for f in forces)
        size = max(np.hypot(*f.force) for f in forces)
        assert np.allclose(total, b.m * a_com[k], rtol=0, atol=1e-9 * size)
        assert abs(moment - b.I * alpha[k]) <= 1e-9 * size * b.L
        assert np.allclose(forces[0].point_xy, com[k], atol=1e-12)  # gravity at G
    session.free_body_box.value = False
    assert not session.free_body.visible()


@pytest.mark.parametrize("preset", ["triple-a", "four-bar"])
def test_a_chains_diagram_is_the_general_mechanisms_free_body(connect, preset):
    """The chain's diagram (read off the ring) is physics' general free-body sum of the chain written as a
    mechanism (physics/mechanism/chains.py) at the same state: the same forces at the same points, to 1e-9 of the
    largest (the views differ in where the values come from, not in what they are)."""
    _, session = connect()
    session.set_mechanism(preset)
    session.free_body_box.value = True
    assert session.goto_time(1.3)
    chain = session.params.chain
    for bar in range(1, chain.n + 1):
        session.body_menu.value = f"bar{bar}"
        # the diagram of this bar at the time gone to (not one drawn before the jump, at another time)
        assert wait_until(lambda bar=bar: session.free_body.shown_bar == bar and session.free_body.shown
                          and abs(session.free_body.shown_t - 1.3) < 0.05, timeout=30)
        with session.free_body._lock:  # the player thread draws: one drawing's forces and time
            shown, shown_t = list(session.free_body.shown), session.free_body.shown_t
        theta, omega = session.state_at(shown_t, exact=True)  # the displayed run's sample drawn, as bar angles
        mechanism = chain_mechanism(chain, theta)
        q, qdot = chain_state(chain, theta, theta, omega)
        loads = free_body(mechanism, evaluate(mechanism, q, qdot, "dae", shown_t), f"bar{bar}")
        general = sorted(((tuple(np.round(load.at, 9)), np.array(load.force)) for load in loads.loads
                          if load.at is not None), key=lambda pair: pair[0])
        drawn = sorted(((tuple(np.round(f.point_xy, 9)), f.force) for f in shown),
                       key=lambda pair: pair[0])
        size = max(np.hypot(*f.force) for f in shown)
        assert len(drawn) == len(general)
        for (at_drawn, force_drawn), (at_general, force_general) in zip(drawn, general):
            assert np.allclose(at_drawn, at_general, atol=1e-9)
            assert np.allclose(force_drawn, force_general, rtol=0, atol=1e-9 * size)
