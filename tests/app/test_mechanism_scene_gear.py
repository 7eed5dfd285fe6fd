"""A gear pair in the app's 3D picture (app/mechanism_scene.py): one thin bar between its two pins, in the same
batched mesh as the bodies' bars, so a frame stays two messages and the line follows the pins."""

from __future__ import annotations

import numpy as np
import pytest
import viser

from app.mechanism_runs import centres_at, drawing, points_at
from app.mechanism_scene import MESH_WIDTH_SHARE, MechanismScene
from app.server import LabServer
from app.session import Session
from conftest import BrowserStandIn, wait_until
from physics.mechanism import MECHANISM_PRESETS
from physics.mechanism.assembly import assemble
from physics.mechanism.simulate import simulate_mechanism


@pytest.fixture(scope="module")
def server():
    target = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield target
    target.stop()


def test_the_geared_five_bar_draws_its_gear_as_a_line_between_its_pins(server):
    mechanism = MECHANISM_PRESETS["geared-five-bar"]()
    draw = drawing(mechanism)
    index = {label: k for k, label in enumerate(draw.labels)}
    assert draw.meshes.tolist() == [[index["crank1.O1"], index["crank2.O2"]]]
    scene = MechanismScene(server)
    run = simulate_mechanism(mechanism, 0.5, 3)
    q = assemble(mechanism).q
    scene.build(draw, points_at(draw, q), centres_at(q))
    poses = scene.poses()
    segments = len(draw.segments)
    assert len(poses) == segments + 1  # every body's bar, then the gear's line
    gear = poses[f"/linkage/bar_{segments + 1}"]
    middle = (np.array(mechanism.ground["O1"]) + np.array(mechanism.ground["O2"])) / 2
    assert gear["position"][0] == pytest.approx(middle[0], abs=1e-6)  # between the two ground pivots
    scales = scene._scales(points_at(draw, q))
    assert scales[-1, 0] == pytest.approx(0.3, rel=1e-6)  # as long as the pivots are apart
    assert scales[-1, 1] == pytest.approx(MESH_WIDTH_SHARE * scales[0, 1])
    for pose in run.q:  # the bodies move, the gear's pins stay on the ground: its line stays
        scene.show(points_at(draw, pose), centres_at(pose))
        assert scene.poses()[f"/linkage/bar_{segments + 1}"]["position"] == pytest.approx(gear["position"])
    scene.remove()


def test_a_mechanism_without_gears_draws_no_line():
    draw = drawing(MECHANISM_PRESETS["crank-rocker"]())
    assert draw.meshes.shape == (0, 2)


def test_a_session_plays_the_geared_five_bar_with_its_gear_line_and_contact_torque():
    """The app's session of the preset: it plays, the gear's line is among the bars the browser receives, and
    every sample holds a finite contact torque in the row the CSV names ``gears: contact torque``."""
    server = LabServer(port=0, warm=False, preset="geared-five-bar")
    client = BrowserStandIn(server.url)
    try:
        assert wait_until(lambda: len(server.sessions) == 1, timeout=60)
        (session,) = server.sessions.values()
        assert isinstance(session, Session)
        assert session.player.wait_idle(60)
        first = session.player.display_time
        assert wait_until(lambda: session.player.display_time > first + 0.3, timeout=60)
        assert session.scene.draw is not None and len(session.scene.draw.meshes) == 1
        assert len(session.scene.poses()) == len(session.scene.draw.segments) + 1
        ring = session.player.runs[0].ring
        row = session.spec.row_names.index("gears: contact torque")
        assert np.isfinite(ring.get("reactions", len(ring) - 1)[row])
    finally:
        client.close()
        server.stop()
