"""The three formulations of any mechanism agree, each derived on its own: Lagrange and Newton–Euler on a
spanning tree against the maximal-coordinate DAE, at random assembled states of every mechanism preset: every
body's angular acceleration and every multiplier of the joints they close by constraints (cut joints, motors).
"""

from __future__ import annotations

import numpy as np
import pytest

from physics.mechanism import MECHANISM_PRESETS, assemble
from physics.mechanism.dae import MechanismDAE
from physics.mechanism.lagrange import derive_tree_lagrange
from physics.mechanism.newton_euler import derive_tree_newton_euler
from physics.mechanism.simulate import project_velocity
from physics.mechanism.tree import tree_state

STATES = 12


@pytest.mark.parametrize("formulation", ["lagrange", "newton_euler"])
@pytest.mark.parametrize("name", sorted(MECHANISM_PRESETS))
def test_tree_formulations_match_the_dae_at_random_states(name, formulation):
    mechanism = MECHANISM_PRESETS[name]()
    dae = MechanismDAE(mechanism)
    tree = (derive_tree_lagrange if formulation == "lagrange" else derive_tree_newton_euler)(mechanism)
    rng = np.random.default_rng(sum(map(ord, name)))
    angle_map = np.array([tree.body_angles(e) - tree.body_angles(np.zeros(len(tree.coordinates)))
                          for e in np.eye(len(tree.coordinates))]).T  # body angles are linear in s
    checked = 0
    for _ in range(STATES):
        guess = dae.constraints.sketch_pose() + rng.normal(scale=0.05, size=dae.constraints.size)
        q = assemble(mechanism, guess).q
        qdot = project_velocity(dae, q, rng.normal(size=dae.constraints.size))
        s, sd = tree_state(mechanism, q, qdot)
        assert np.allclose(tree.body_angles(s), q[2::3], atol=1e-12)
        if formulation == "lagrange":
            assert np.allclose(tree.body_centres(s), q.reshape(-1, 3)[:, :2], atol=1e-12)
        dae_solution = dae.solve(q, qdot)
        sdd, multipliers = tree.solve(s, sd)
        scale = 1.0 + np.max(np.abs(dae_solution.qddot[2::3]))
        assert np.max(np.abs(angle_map @ sdd - dae_solution.qddot[2::3])) <= 1e-9 * scale
        rows = [row.joint for row in dae.constraints.rows]
        for joint in dict.fromkeys(tree.row_joints):
            mine = multipliers[[k for k, j in enumerate(tree.row_joints) if j == joint]]
            theirs = dae_solution.reactions[[k for k, j in enumerate(rows) if j == joint]]
            if len(mine) == 1 and len(theirs) == 3:  # a motor on a pin: the DAE's third row is its torque
                theirs = theirs[2:]
            elif len(theirs) == 3:  # a pin that is both cut and driven: x, y, then the motor
                theirs = theirs[:2] if len(mine) == 2 else theirs
            force_scale = 1.0 + np.max(np.abs(dae_solution.reactions))
            assert np.max(np.abs(mine - theirs)) <= 1e-9 * force_scale, (joint, mine, theirs)
        checked += 1
    assert checked == STATES
