"""The live free-body diagram (issue 15): the forces drawn on each bar balance its motion.

The accelerations are computed here, independently of the run: another formulation's compiled system solved at
the displayed state, and the centre-of-mass acceleration written out from the bar directions.
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import wait_until
from physics.codegen import load_compiled

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
    session.report.fbd_box.value = True
    assert session.goto_time(1.3)
    chain = session.params.chain
    run = session.player.runs[0]
    for bar in range(1, chain.n + 1):
        session.report.fbd_bar.value = str(bar)
        assert wait_until(lambda bar=bar: session.free_body.shown_bar == bar and session.free_body.shown, timeout=30)
        assert session.free_body.visible()
        forces = session.free_body.shown
        assert len(forces) == (3 if bar < chain.n or chain.pinned else 2)
        assert len(session.free_body.labels()) == len(forces)
        i = run.ring.index_at(session.free_body.shown_t)
        theta, omega = run.ring.get("theta", i).copy(), run.ring.get("omega", i).copy()
        alpha, com, a_com = independent_motion(chain, theta, omega, method)
        k = bar - 1
        b = chain.bars[k]
        total = np.sum([f.force for f in forces], axis=0)
        moment = sum((f.point_xy - com[k])[0] * f.force[1] - (f.point_xy - com[k])[1] * f.force[0] for f in forces)
        size = max(np.hypot(*f.force) for f in forces)
        assert np.allclose(total, b.m * a_com[k], rtol=0, atol=1e-9 * size)
        assert abs(moment - b.I * alpha[k]) <= 1e-9 * size * b.L
        assert np.allclose(forces[0].point_xy, com[k], atol=1e-12)  # gravity at G
    session.report.fbd_box.value = False
    assert not session.free_body.visible()
