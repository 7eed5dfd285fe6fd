"""The app measures a mechanism's condition only at the sample its status line shows (issue 24, "an edit to the
first new frame <= 50 ms"): a chunk's run computes its condition when it is read (physics' OnRequest), and the
status line needs one sample of it, so a chunk stores NaN ("measure it when shown") and
MechanismSpec.condition_at measures that one pose. What the user sees must not change: the figure at every
sample equals the run's own, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from app import session as session_module
from app.mechanism_runs import MechanismSettings, MechanismSpec, start_state
from app.mechanism_workers import _chunk
from conftest import lab_of, wait_until
from physics.mechanism import MECHANISM_PRESETS
from physics.mechanism.singularity import jacobian_condition
from physics.simulate.trajectory import OnRequest

CHUNK = {"t_end": 0.5, "samples": 31}


def _stored(spec: MechanismSpec, chunk):
    ring = spec.new_ring(64, 1.0 / 60.0)
    ring.append(spec.chunk(chunk))
    return ring


@pytest.mark.parametrize(("preset", "method"), [("slider-crank", "dae"), ("jansen-leg", "dae"),
                                                ("watt-six-bar", "lagrange"), ("geared-five-bar", "newton_euler")])
def test_a_chunk_leaves_its_condition_and_the_status_line_measures_the_shown_pose(preset, method):
    mechanism = MECHANISM_PRESETS[preset]()
    q0, qdot0, _ = start_state(mechanism)
    spec = MechanismSpec("main", mechanism, MechanismSettings(method=method, **CHUNK))
    chunk = spec.simulate(mechanism, q0, qdot0, spec.settings)
    ring = _stored(spec, chunk)
    assert isinstance(chunk.run.__dict__["_condition_value"], OnRequest)  # storing the chunk computed none
    assert np.isnan(ring.window(0, len(ring) - 1, ["condition"])["condition"]).all()
    shown = np.array([spec.condition_at(ring, index) for index in range(len(ring))])
    assert np.array_equal(shown, chunk.run.condition)  # the run's own figure at every sample, bit for bit


def test_a_worker_sends_a_chunk_without_its_condition_and_the_server_measures_it_the_same():
    mechanism = MECHANISM_PRESETS["crank-rocker"]()
    q0, qdot0, _ = start_state(mechanism)
    spec = MechanismSpec("main", mechanism, MechanismSettings(**CHUNK))
    sent = _chunk(mechanism.model_dump_json(), CHUNK["t_end"], CHUNK["samples"], q0, qdot0, 0.0, "dae",
                  "projection")
    assert sent.condition.shape == (0,)  # nothing computed for pickling
    here = spec.simulate(mechanism, q0, qdot0, spec.settings)
    ring = _stored(spec, type(here)(run=sent, status=sent.status, message=sent.message))
    assert np.array_equal([spec.condition_at(ring, k) for k in range(len(ring))], here.run.condition)
    assert np.array_equal(sent.reaction_rows, here.run.reaction_rows)


def test_the_reduced_model_measures_no_condition_and_the_status_line_shows_none():
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    q0, qdot0, _ = start_state(mechanism)
    spec = MechanismSpec("main", mechanism, MechanismSettings(method="reduced", **CHUNK))
    ring = _stored(spec, spec.simulate(mechanism, q0, qdot0, spec.settings))
    assert [spec.condition_at(ring, k) for k in range(len(ring))] == [0.0] * len(ring)


slider_lab = lab_of("slider-crank")


def test_the_status_line_shows_the_condition_of_the_shown_pose(slider_lab, connect, monkeypatch):
    """The session's status line reads the shown sample's condition through condition_at: with the "near a
    singular pose" threshold lowered below every condition, it names the figure of the pose on show."""
    _, session = connect(slider_lab)
    assert wait_until(lambda: len(session.player.runs[0].ring) > 10, timeout=60)
    session.player.pause()
    monkeypatch.setattr(session_module, "NEAR_SINGULAR_CONDITION", 0.5)
    run = session.player.runs[0]
    index = run.ring.index_at(session.player.display_time)
    expected = jacobian_condition(run.spec.constraints, run.ring.get("q", index))
    session._refresh_status()
    assert f"near a singular pose: Jacobian condition {expected:.2g}" in session.status.content
