"""Drag to set the start (app/drag_start.py, issue 26): a drag of a bar in the paused scene sets the start through
the Start sliders' path (same validation, same notices), a pinned chain's loop closes, an impossible pose is one
notice and keeps the last valid start, and the drag is bound to the bars only while paused.

The drag events are fed as viser gives them (phase, instance under the mouse, world points); the browser test
(tests/browser/test_drag_start.py) drives the same with real mouse events.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
import viser

import physics
from app import drag_start
from app.mechanism_runs import points_at
from app.parameters import SessionParameters
from app.scene import to_world
from app.session import MECHANISM_PRESETS, Session
from conftest import wait_until


@pytest.fixture
def open_session(in_process):
    """``open_session(preset)``: a paused session of a chain or mechanism preset on a viser server of its own."""
    opened: list[tuple[Session, viser.ViserServer]] = []

    def _open(preset: str) -> Session:
        server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
        if preset in MECHANISM_PRESETS:
            session = Session(server, MECHANISM_PRESETS[preset](), label=preset, shared=True,
                                       autoplay=False)
        else:
            session = Session.for_chain(server, SessionParameters.from_preset(preset), shared=True,
                                                 autoplay=False)
        opened.append((session, server))
        assert session.player.wait_idle(120), "the first start was not shown"
        return session

    yield _open
    for session, server in opened:
        session.close(clean=True)
        server.stop()


def instance_of(session: Session, body: str) -> tuple[int, str]:
    """The first instance drawn for ``body`` and its node: a bar, or (a one-point body: a slider's block) its
    point's ball."""
    names = [b.name for b in session.mechanism.bodies]
    draw = session.spec.draw
    bars = np.flatnonzero(draw.segment_body == names.index(body))
    if len(bars):
        return int(bars[0]), "bars"
    return int(np.flatnonzero(draw.owner == names.index(body))[0]), "spheres"


def point(session: Session, label: str, q=None) -> np.ndarray:
    draw = session.spec.draw
    return points_at(draw, session.q0 if q is None else q)[draw.labels.index(label)]


def drag(session: Session, body: str, grab_xy, *targets_xy) -> None:
    """A drag of ``body`` grabbed at ``grab_xy`` through ``targets_xy`` (physics x, y), the last one released."""
    instance, node = instance_of(session, body)
    grab = to_world(np.asarray(grab_xy, dtype=float))
    session.drag.handle("start", instance, grab, grab, node=node)
    for k, target in enumerate(targets_xy):
        phase = "end" if k == len(targets_xy) - 1 else "update"
        session.drag.handle(phase, instance, grab, to_world(np.asarray(target, dtype=float)), node=node)


def direction(theta: float) -> np.ndarray:
    """A chain bar's direction at absolute angle ``theta`` (from the downward vertical, counter-clockwise)."""
    return np.array([math.sin(theta), -math.cos(theta)])


def count_notices(session: Session) -> list[str]:
    shown: list[str] = []
    original = session.notices.show

    def show(title, body, *args, **kwargs):
        shown.append(f"{title}: {body}")
        return original(title, body, *args, **kwargs)

    session.notices.show = show  # type: ignore[method-assign]
    return shown


def test_dragging_a_bar_of_an_open_chain_sets_its_angle_alone(open_session):
    session = open_session("triple-a")
    theta_before = session.chain.theta0.copy()
    pivot, tip = point(session, "bar2.P"), point(session, "bar2.D")
    wanted = math.radians(75.0)
    reach = float(np.hypot(*(tip - pivot)))
    drag(session, "bar2", (pivot + tip) / 2, pivot + 0.7 * reach * direction(wanted))
    theta = session.chain.theta0
    assert math.degrees(theta[1]) == pytest.approx(75.0, abs=1e-6)
    assert theta[0] == theta_before[0] and theta[2] == theta_before[2]  # absolute angles: the others kept
    assert session.drag.applied >= 1
    assert not session.player.playing, "a drag leaves the session paused"
    assert session.player.wait_idle(60)
    # the start shown is the dragged one, at t = 0; Play starts from it
    assert session.player.display_time == 0.0
    shown = session.player.current_start()
    assert shown is not None and np.allclose(shown[2][2::3], theta)
    assert session._knob_handles["theta2"].value == pytest.approx(75.0, abs=0.5)


def test_dragging_the_crank_of_a_four_bar_closes_the_loop_and_refuses_an_impossible_pose(open_session):
    session = open_session("four-bar")
    params = session.chain
    reachable = physics.loop_closure.driving_range(params.L, params.pin)
    assert reachable, "the four-bar preset closes"
    low, high = reachable[0]
    assert high - low < 2 * math.pi - 1e-6, "the preset's crank has angles it cannot reach (a rocker)"
    inside = low + 0.3 * (high - low)
    outside = high + 0.5 * (2 * math.pi - (high - low))  # the middle of the gap
    pivot = point(session, "bar1.P")
    grab = (pivot + point(session, "bar1.D")) / 2
    notices = count_notices(session)
    drag(session, "bar1", grab, pivot + 0.5 * direction(inside))
    theta = session.chain.theta0
    assert math.degrees(theta[0]) == pytest.approx(drag_start.wrap_degrees(math.degrees(inside)), abs=1e-6)
    # the loop closes at the new start: the tip is at the pin H
    tip = np.sum(np.asarray(params.L)[:, None] * np.stack([np.sin(theta), -np.cos(theta)], axis=1), axis=0)
    assert np.allclose(tip, params.pin, atol=1e-9)
    assert not notices
    kept = theta.copy()
    # the same drag goes on past the reachable range: one notice, the last valid start kept
    grab = (pivot + point(session, "bar1.D")) / 2
    instance, _ = instance_of(session, "bar1")
    session.drag.handle("start", instance, to_world(grab), to_world(grab))
    for fraction in np.linspace(0.0, 1.0, 8):
        angle = inside + fraction * (outside - inside)
        session.drag.handle("update", instance, to_world(grab), to_world(pivot + 0.5 * direction(angle)))
    session.drag.handle("end", instance, to_world(grab), to_world(pivot + 0.5 * direction(outside)))
    refusals = [text for text in notices if "cannot close" in text]
    assert len(refusals) == 1, notices
    assert "theta1" in refusals[0] and "kept theta1" in refusals[0]
    final = session.chain.theta0
    assert not np.allclose(final, kept), "the reachable part of the drag was applied"
    assert math.degrees(final[0]) != pytest.approx(math.degrees(outside) % 360.0, abs=1.0)
    assert low - 1e-9 <= (final[0] - low) % (2 * math.pi) + low <= high + 1e-9, "the start kept is reachable"


def test_dragging_the_coupler_of_a_four_bar_moves_it_along_its_loop(open_session):
    session = open_session("four-bar")
    grab = (point(session, "bar2.P") + point(session, "bar2.D")) / 2
    target = grab + np.array([0.15, 0.05])
    before = session.chain.theta0.copy()
    drag(session, "bar2", grab, target)
    after = session.chain.theta0
    assert after[0] != before[0], "the coupler's drag sets the driving angle"
    params = session.chain
    tip = np.sum(np.asarray(params.L)[:, None] * np.stack([np.sin(after), -np.cos(after)], axis=1), axis=0)
    assert np.allclose(tip, params.pin, atol=1e-9)
    moved = (point(session, "bar2.P") + point(session, "bar2.D")) / 2
    assert np.hypot(*(moved - target)) < np.hypot(*(grab - target)), "the grabbed point came nearer the mouse"


def test_dragging_a_slider_cranks_crank_and_block(open_session):
    session = open_session("slider-crank")
    pivot, end = point(session, "crank.O"), point(session, "crank.A")
    radius = float(np.hypot(*(end - pivot)))
    turn = math.radians(40.0)
    start_angle = math.atan2(*(end - pivot)[::-1])
    drag(session, "crank", end, pivot + radius * np.array([math.cos(start_angle + turn),
                                                          math.sin(start_angle + turn)]))
    crank = next(c for c in session.free if c.body == "crank")
    assert math.degrees(session.q0[crank.index]) == pytest.approx(40.0, abs=1e-6)
    assert session._knob_handles["angle0:crank"].value == pytest.approx(40.0, abs=0.5)
    # the block: dragged along its guide towards the pivot, the crank turns so that it follows
    block = point(session, "piston.B")
    target = block - np.array([0.03, 0.0])
    drag(session, "piston", block, target)
    assert point(session, "piston.B")[0] < block[0] - 0.02
    assert math.degrees(session.q0[crank.index]) != pytest.approx(40.0, abs=1e-3)


def test_the_drag_is_bound_while_paused_only_and_updates_are_coalesced(open_session):
    session = open_session("triple-a")
    assert wait_until(lambda: session.drag.bound, 30), "bound while paused"
    session.play()
    assert wait_until(lambda: not session.drag.bound, 30), "unbound while playing"
    session.pause()
    assert wait_until(lambda: session.drag.bound, 30)
    # forty mouse moves in a burst (viser sends ~20 a second): at most a start per MIN_INTERVAL, the last applied
    pivot, tip = point(session, "bar1.P"), point(session, "bar1.D")
    instance, _ = instance_of(session, "bar1")
    grab = to_world((pivot + tip) / 2)
    began = time.monotonic()
    session.drag.push("start", instance, grab, grab)
    for k in range(40):
        session.drag.push("update", instance, grab, to_world(pivot + direction(math.radians(k))))
    session.drag.push("end", instance, grab, to_world(pivot + direction(math.radians(50.0))))
    assert wait_until(lambda: math.degrees(session.chain.theta0[0]) == pytest.approx(50.0, abs=1e-6), 20)
    elapsed = time.monotonic() - began
    assert session.drag.applied <= 2 + elapsed / drag_start.MIN_INTERVAL
    assert session.drag.applied < 20


def test_the_mouse_ray_meets_the_plane_of_the_motion():
    # a camera in front of the plane (world y = -5) looking through a point behind it: where the ray crosses y = 0
    eye = np.array([1.0, -5.0, 2.0])
    through = np.array([2.0, 5.0, 4.0])
    assert np.allclose(drag_start.plane_point(through, eye), [1.5, 3.0])
    assert np.allclose(drag_start.plane_point(through, None), [2.0, 4.0])


def test_a_scene_rebuilt_while_paused_moves_the_drag_to_its_new_bars(open_session):
    """Moving the four-bar's ground pin redraws its ground, so the scene is built anew while paused: the drag
    follows the new bars, and the player draws on (viser's handles compared with ``==`` raised here, which stopped
    the player with an internal error)."""
    session = open_session("four-bar")
    assert wait_until(lambda: session.drag.bound, 30)
    old_bars = session.scene.bars
    session.set_typed("pin_x", "1.2")
    assert wait_until(lambda: session.scene.bars is not old_bars, 30), "the ground moved: a new drawing"
    assert wait_until(lambda: session.drag.bound and session.drag._bound[0] is session.scene.bars, 30)
    time.sleep(0.6)  # a paused player draws a frame a quarter second at least
    assert session.player.error is None
    assert not session.player.playing
