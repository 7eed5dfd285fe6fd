"""Drag to set the start: in the paused scene, a bar (a body, a slider's block) dragged with the mouse sets the
start, as lecturers' tools do (myPhysicsLab, PhET, MuJoCo's viewer; issue 26).

Why this way: viser's batched meshes report drags (``on_drag``: start, ~20 Hz updates, end, with the instance
under the mouse), so the bars the scene already draws are what a person grabs; no extra handle to find. The drag
is bound only while paused (a left-drag on a bar then turns the bar instead of orbiting the camera; while playing
it orbits as before) and not in compare mode (three mechanisms, none of them the start's).

What a drag sets, through the session's own start path (``Session.set``, the Start folder's sliders':
same validation, same notices, same restart at t = 0, paused):

* the dragged body's own free angle, when it has one and a pivot (a chain's bar k of its driving bars turns about
  its proximal joint; a mechanism's body about its pin to the ground): the angle follows the mouse about the
  pivot, from where the bar was grabbed. An angle where a closed loop cannot close is refused in the slider's
  words ("the loop cannot close there", "cannot close") and the last valid start is kept; one notice per run of
  refusals within a drag, not one per mouse move.
* any other body (a four-bar's coupler or rocker, a slider's block, a body whose angle is not free): the pose on
  the mechanism's constraints that brings the grabbed point nearest the mouse (Gauss-Newton steps in the
  constraints' null space, each put back on them), whose free coordinates are then set as the sliders set them.

The mouse's point is where its ray from the camera meets the plane of the motion (the world's x-z plane,
app/scene.py ``to_world``), so a drag works in the 3D view too. Drag updates are coalesced: the newest wins, at
most one start every MIN_INTERVAL seconds (the end of a drag always applies), and a value equal to the one last
set does nothing. The work runs on a thread of its own (app/coalesce.py): never in viser's event loop, never under
the player's lock.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from physics import LinkageError
from physics.mechanism import Constraints
from physics.mechanism.assembly import sketch_size

from .coalesce import CoalescingWorker
from .commands import CONTROL
from .logs import quietly
from .mechanism_edits import START_NAMES
from .mechanism_runs import points_at

MIN_INTERVAL = 0.1  # s between two starts set by one drag (viser sends ~20 updates a second)
IK_STEPS = 30
IK_STEP_SHARE = 0.2  # of the mechanism's size: the largest move of the grabbed point in one step
CLOSE_STEPS = 20


@dataclass
class Grab:
    """One drag: the body grabbed (its index), the grabbed point in the body's own frame (relative to its centre of
    mass, at its angle 0), the pivot it turns about (direct mode) or None (pose mode), and the pose it started
    from."""

    body: int
    local: np.ndarray
    pivot: np.ndarray | None
    q: np.ndarray
    refused: bool = False
    last: tuple | None = None  # the changes last applied: the same again does nothing


def _rotation(phi: float) -> np.ndarray:
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, -s], [s, c]])


def grabbed_point(q: np.ndarray, body: int, local: np.ndarray) -> np.ndarray:
    """World (physics x, y) position of the point ``local`` of ``body`` at pose ``q``."""
    return q[3 * body: 3 * body + 2] + _rotation(float(q[3 * body + 2])) @ local


def local_point(q: np.ndarray, body: int, xy: np.ndarray) -> np.ndarray:
    """The body-frame coordinates of world point ``xy`` of ``body`` at pose ``q``."""
    return _rotation(-float(q[3 * body + 2])) @ (np.asarray(xy, dtype=float) - q[3 * body: 3 * body + 2])


def plane_point(end_world, camera_position) -> np.ndarray:
    """Physics (x, y) under the mouse: the ray from the camera through ``end_world`` (viser's drag point on a
    camera-facing plane) meets the motion's plane y_world = 0; without a usable camera (edge-on), the drag point
    itself, flattened."""
    end = np.asarray(end_world, dtype=float)
    if camera_position is not None:
        eye = np.asarray(camera_position, dtype=float)
        ray = end - eye
        if abs(ray[1]) > 1e-6 * (np.linalg.norm(ray) or 1.0):
            s = -eye[1] / ray[1]
            if s > 0:
                hit = eye + s * ray
                return np.array([hit[0], hit[2]])
    return np.array([end[0], end[2]])


def pose_toward(mechanism, q: np.ndarray, body: int, local: np.ndarray, target: np.ndarray) -> np.ndarray:
    """A pose on ``mechanism``'s constraints (at t = 0) near ``q`` that brings the point ``local`` of ``body`` as
    near ``target`` as the constraints allow: Gauss-Newton steps in the null space of the constraint Jacobian,
    each at most IK_STEP_SHARE of the size, put back on the constraints by minimum-norm Newton steps."""
    constraints = Constraints(mechanism)
    size = sketch_size(mechanism)
    q = np.array(q, dtype=float)
    for _ in range(IK_STEPS):
        gap = np.asarray(target, dtype=float) - grabbed_point(q, body, local)
        if np.hypot(*gap) <= 1e-9 * size:
            break
        jac = np.zeros((2, q.size))
        phi = float(q[3 * body + 2])
        jac[:, 3 * body: 3 * body + 2] = np.eye(2)
        jac[:, 3 * body + 2] = np.array([[-math.sin(phi), -math.cos(phi)], [math.cos(phi), -math.sin(phi)]]) @ local
        phi_q = constraints.jacobian(q)
        if phi_q.size:
            _, sv, vt = np.linalg.svd(phi_q)
            rank = int(np.sum(sv > 1e-10 * (sv[0] if sv.size else 1.0)))
            basis = vt[rank:].T
        else:
            basis = np.eye(q.size)
        if basis.shape[1] == 0:
            break
        length = np.hypot(*gap)
        wanted = gap * min(1.0, IK_STEP_SHARE * size / length)
        step, *_ = np.linalg.lstsq(jac @ basis, wanted, rcond=None)
        moved = q + basis @ step
        for _ in range(CLOSE_STEPS):
            residual = constraints.residual(moved, 0.0)
            if not residual.size or np.max(np.abs(residual)) <= 1e-12 * size:
                break
            correction, *_ = np.linalg.lstsq(constraints.jacobian(moved), -residual, rcond=None)
            moved = moved + correction
        if not np.all(np.isfinite(moved)):
            break
        if np.hypot(*(target - grabbed_point(moved, body, local))) >= length - 1e-12 * size:
            break  # no nearer: the constraints stop it here
        q = moved
    return q


def wrap_degrees(angle: float) -> float:
    """An angle in degrees within [-180, 180), as the Start sliders show it."""
    return (angle + 180.0) % 360.0 - 180.0


def _same_nodes(nodes: tuple | None, bound: tuple | None) -> bool:
    """Whether ``nodes`` are the very handles ``bound`` holds: by identity, since viser's handles are dataclasses
    whose ``==`` compares their numpy fields (and raises) once a rebuilt scene holds new handles."""
    if nodes is None or bound is None:
        return nodes is bound
    return len(nodes) == len(bound) and all(a is b for a, b in zip(nodes, bound))


class DragStart:
    """The drag of one session's scene (``session``: a :class:`~app.session.Session`)."""

    def __init__(self, session) -> None:
        self.session = session
        self._bound: Any = None  # the bars and spheres nodes the drag callbacks are on (None: not bound)
        # (phase, instance, start world, end world, camera, client id, node), handled on a thread of its own
        self._worker: CoalescingWorker[tuple] = CoalescingWorker(
            lambda event: self.handle(*event), lambda event: event[0] == "update", name="drag-start",
            what="dragging the start", min_interval=MIN_INTERVAL)
        self._grab: Grab | None = None
        self.applied = 0  # starts set by drags (tests)

    # ------------------------------------------------------------------ binding (the player's thread)
    def follow(self) -> None:
        """Bind the drag to the scene's bars while paused (and not in compare mode), unbind it while playing:
        called with every frame the session draws (a paused player draws one a quarter second at least), so it
        follows every way of pausing or playing; only a change sends anything."""
        session = self.session
        scene = session.scene
        designing = getattr(session, "design_view", None) is not None and session.design_view.on
        paused = not (session.compare or session.closed or session.player.playing or designing)
        nodes = (scene.bars, scene.spheres) if paused and scene.bars is not None else None
        if _same_nodes(nodes, self._bound):
            return
        old, self._bound = self._bound, nodes
        for node in old or ():
            if node is not None and (node is scene.bars or node is scene.spheres):  # a rebuilt scene's old nodes are gone
                quietly(lambda node=node: node.remove_drag_callback("all"), "unbinding the drag")
        if nodes is not None:
            bars, spheres = nodes
            quietly(lambda: bars.on_drag(self._on_bar_drag), "binding the drag")
            if spheres is not None:
                quietly(lambda: spheres.on_drag(self._on_ball_drag), "binding the drag")

    @property
    def bound(self) -> bool:
        """Whether a drag of a bar sets the start now (paused; tests)."""
        return self._bound is not None

    async def _on_bar_drag(self, event) -> None:
        self._record(event, "bars")

    async def _on_ball_drag(self, event) -> None:
        self._record(event, "spheres")

    def _record(self, event, node: str) -> None:
        """viser's drag event (on its event loop, in order): only recorded; the worker does the work."""
        camera = None
        try:
            camera = np.array(event.client.camera.position, dtype=float)
        except Exception:  # no camera message from this browser yet: the drag point flattened
            camera = None
        self.push(event.phase, event.instance_index, event.start_position, event.end_position, camera,
                  event.client_id, node)

    def push(self, phase: str, instance: int | None, start_world, end_world, camera=None,
             client_id: int | None = None, node: str = "bars") -> None:
        """One drag event (``phase`` start, update or end; world coordinates as viser gives them) of an instance
        of ``node`` (``bars`` or ``spheres``)."""
        self._worker.submit((phase, instance, start_world, end_world, camera, client_id, node))

    def close(self) -> None:
        self._worker.close()

    def handle(self, phase: str, instance: int | None, start_world, end_world, camera=None,
               client_id: int | None = None, node: str = "bars") -> None:
        """One drag event, processed (the worker calls this; tests may too)."""
        session = self.session
        if not session.may_change(client_id):
            if phase == "start":
                session.show_notice("Not applied", "the presenter controls this session", color="blue")
            return
        if phase == "start":
            self._grab = self._start(instance, node, np.array([start_world[0], start_world[2]], dtype=float))
            return
        grab = self._grab
        if grab is None:
            return
        self.drag_to(plane_point(end_world, camera))
        if phase == "end":
            self._grab = None

    def _start(self, instance: int | None, node: str, grab_xy: np.ndarray) -> Grab | None:
        """The grab of instance ``instance`` of ``node`` (a bar, or a ball: a point or a centre of mass) at world
        point ``grab_xy``: its body, the point in the body's frame (from the pose shown), and how it turns (about
        a pivot, or along the constraints)."""
        session = self.session
        draw = session.spec.draw
        if instance is None or session.player.playing:
            return None
        if node == "bars" and 0 <= instance < len(draw.segments):
            body = int(draw.segment_body[instance])
        elif node == "spheres" and 0 <= instance < len(draw.labels):
            body = int(draw.owner[instance])
        elif node == "spheres" and 0 <= instance - len(draw.labels) < len(session.mechanism.bodies):
            body = instance - len(draw.labels)
        else:
            return None  # a gear's line
        shown = session.player.current_start()
        q_shown = shown[2] if shown is not None and getattr(shown[0], "structure", None) == session.spec.structure \
            else session.q0
        local = local_point(q_shown, body, grab_xy)
        q0 = np.array(session.q0, dtype=float)
        return Grab(body, local, self._pivot(body, q0), q0)

    def _pivot(self, body: int, q0: np.ndarray) -> np.ndarray | None:
        """Where ``body`` turns about when its own angle is free: a chain's driving bar about its proximal joint,
        a mechanism's body about its pin to the ground; None otherwise (the pose follows the constraints)."""
        session = self.session
        name = session.mechanism.bodies[body].name
        if not any(c.body == name and c.angular for c in session.free):
            return None
        draw = session.spec.draw
        if session.chain is not None:
            return np.array(points_at(draw, q0)[draw.labels.index(f"{name}.P")], dtype=float)
        ground = session.mechanism.ground
        for joint in session.mechanism.joints:
            if getattr(joint, "kind", None) != "revolute":
                continue
            ends = (joint.a, joint.b)
            for mine, other in (ends, ends[::-1]):
                if mine.split(".")[0] == name and other.split(".")[0] == "ground":
                    return np.array(ground[other.split(".", 1)[1]], dtype=float)
        return None

    def drag_to(self, target_xy) -> None:
        """Set the start from the grab in force with its point dragged to ``target_xy`` (physics x, y)."""
        grab, session = self._grab, self.session
        if grab is None:
            return
        target = np.asarray(target_xy, dtype=float)
        if grab.pivot is not None:
            was = grabbed_point(grab.q, grab.body, grab.local) - grab.pivot
            now = target - grab.pivot
            if min(np.hypot(*now), np.hypot(*was)) < 1e-9:
                return  # grabbed at the pivot itself, or the mouse on it: no direction to turn to
            turn = math.atan2(now[1], now[0]) - math.atan2(was[1], was[0])
            q = grab.q.copy()
            q[3 * grab.body + 2] += turn
        else:
            q = pose_toward(session.mechanism, grab.q, grab.body, grab.local, target)
            grab.q = q  # the next update goes on from here (the branch is kept)
        self._apply(grab, self._changes(q, grab))

    def _changes(self, q: np.ndarray, grab: Grab) -> list[tuple[str, float]]:
        """The Start controls' new values (names and panel units) for pose ``q``: those that differ from the start in
        force; with a pivot, only the grabbed body's angle."""
        session = self.session
        out = []
        name = session.mechanism.bodies[grab.body].name
        for k, coordinate in enumerate(session.free):
            if grab.pivot is not None and not (coordinate.body == name and coordinate.angular):
                continue
            value = float(q[coordinate.index])
            if coordinate.angular:
                value = wrap_degrees(math.degrees(value))
            if session.chain is not None:
                control = f"theta{k + 1}"
            else:
                control = f"{START_NAMES[coordinate.axis][0]}:{coordinate.body}"
            old = float(session.q0[coordinate.index])
            if coordinate.angular and abs(wrap_degrees(value - math.degrees(old))) < 1e-9:
                continue
            if not coordinate.angular and abs(value - old) < 1e-12:
                continue
            out.append((control, round(value, 9)))
        return out

    def _apply(self, grab: Grab, changes: list[tuple[str, float]]) -> None:
        """Set ``changes`` through the session's start path; a refusal is one notice per run of refusals."""
        if not changes or tuple(changes) == grab.last:
            return
        grab.last = tuple(changes)
        session = self.session
        self._worker.mark()
        try:
            for name, value in changes:
                session.set(name, value, CONTROL)
        except LinkageError as error:
            refusal = error
            if not grab.refused:
                grab.refused = True
                session.guard(lambda: _raise(refusal))  # the slider's notice, in its words; the start kept
            return
        grab.refused = False
        self.applied += 1


def _raise(error: Exception) -> None:
    raise error
